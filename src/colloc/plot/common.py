"""Shared pieces of the figures: input checks, figure creation and saving.

Figures are built as :class:`matplotlib.figure.Figure` objects directly, never through
``pyplot``: they need no GUI backend, are not kept alive by a global figure manager, and the
caller decides whether to show, save or discard them.
"""

from __future__ import annotations

import os
import re
import secrets
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

_STEM_PATTERN = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.\-]*$")


class PlotInputError(ValueError):
    """Data given to a plotting function has one or more problems, all listed."""

    def __init__(self, problems: Sequence[str]) -> None:
        self.problems = list(problems)
        lines = "\n".join(f"  - {p}" for p in self.problems)
        super().__init__(f"cannot plot: {len(self.problems)} problem(s):\n{lines}")


def raise_if_any(problems: list[str]) -> None:
    """Raise :class:`PlotInputError` listing ``problems`` when there are any.

    Parameters
    ----------
    problems : list of str
        Problems found so far.
    """
    if problems:
        raise PlotInputError(problems)


def as_times(times: Any, problems: list[str], name: str = "times") -> np.ndarray:
    """Check that ``times`` is a 1-D array of finite numbers.

    Parameters
    ----------
    times : array_like
        Sample times.
    problems : list of str
        Problems found are appended here.
    name : str, optional
        Argument name used in messages.

    Returns
    -------
    numpy.ndarray
        ``times`` as a float array (empty when it is unusable).
    """
    try:
        array = np.asarray(times, dtype=float)
    except (TypeError, ValueError):
        problems.append(f"{name}: expected a 1-D array of numbers, found {type(times).__name__}")
        return np.empty(0)
    if array.ndim != 1:
        problems.append(f"{name}: expected a 1-D array, found shape {array.shape}")
        return np.empty(0)
    if not np.all(np.isfinite(array)):
        problems.append(f"{name}: expected finite values, found NaN or infinity")
    return array


def as_columns(
    values: Any, num_rows: int, problems: list[str], name: str, rows_meaning: str = "len(times)"
) -> np.ndarray:
    """Check that ``values`` is a (num_rows,) or (num_rows, k) array; return it as 2-D.

    Parameters
    ----------
    values : array_like
        One row per time sample, one column per signal.
    num_rows : int
        Required number of rows.
    problems : list of str
        Problems found are appended here.
    name : str
        Argument name used in messages.
    rows_meaning : str, optional
        Where ``num_rows`` comes from, for the message.

    Returns
    -------
    numpy.ndarray
        Shape (num_rows, k); an empty (num_rows, 0) array when ``values`` is unusable.
    """
    unusable = np.empty((num_rows, 0))
    try:
        array = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        problems.append(f"{name}: expected an array of numbers, found {type(values).__name__}")
        return unusable
    if array.ndim == 1:
        array = array[:, np.newaxis]
    if array.ndim != 2 or array.shape[0] != num_rows:
        hint = ""
        if array.ndim == 2 and array.shape[1] == num_rows:
            hint = "; it looks transposed, pass one row per time sample"
        problems.append(
            f"{name}: expected shape ({num_rows},) or ({num_rows}, k) with {num_rows} = "
            f"{rows_meaning}, found {np.shape(values)}{hint}"
        )
        return unusable
    return array


def check_names(names: Any, count: int, problems: list[str], name: str = "names") -> list[str]:
    """Check that ``names`` holds exactly ``count`` strings.

    Parameters
    ----------
    names : sequence of str
        Labels, one per column.
    count : int
        Required number of labels.
    problems : list of str
        Problems found are appended here.
    name : str, optional
        Argument name used in messages.

    Returns
    -------
    list of str
        The labels (placeholders when they are unusable).
    """
    if isinstance(names, str) or not isinstance(names, Sequence):
        problems.append(f"{name}: expected a sequence of {count} str, found {type(names).__name__}")
        return [f"{name}[{i}]" for i in range(count)]
    if len(names) != count:
        problems.append(f"{name}: expected {count} labels (one per column), found {len(names)}")
        return [f"{name}[{i}]" for i in range(count)]
    return [str(label) for label in names]


def new_figure(num_axes: int, width: float = 8.0, height_per_axis: float = 1.8) -> Figure:
    """Create a figure with ``num_axes`` stacked axes sharing the time axis.

    Parameters
    ----------
    num_axes : int
        Number of axes, one above the other.
    width : float, optional
        Figure width in inches.
    height_per_axis : float, optional
        Height of each axis in inches.

    Returns
    -------
    matplotlib.figure.Figure
        The figure; its axes are ``figure.axes`` from top to bottom.
    """
    figure = Figure(figsize=(width, 0.8 + height_per_axis * num_axes), layout="constrained")
    figure.subplots(num_axes, 1, sharex=True, squeeze=False)
    return figure


def save_figure(
    fig: Figure,
    directory: str | Path,
    stem: str,
    formats: Sequence[str] = ("png", "svg"),
    dpi: float = 150.0,
) -> list[Path]:
    """Save a figure in several formats, each file complete or not written at all.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure to save.
    directory : str or Path
        Target directory, created if missing.
    stem : str
        File name without suffix, e.g. ``"one-link-pendulum-trajectory"``.
    formats : sequence of str, optional
        File formats matplotlib can write (``"png"``, ``"svg"``, ``"pdf"``, ...).
    dpi : float, optional
        Resolution of raster formats.

    Returns
    -------
    list of Path
        ``directory / f"{stem}.{format}"`` for each format.

    Raises
    ------
    PlotInputError
        If ``fig`` is not a Figure, ``stem`` is not a plain file name, or a format is not
        supported; all problems are listed.
    """
    problems: list[str] = []
    if not isinstance(fig, Figure):
        problems.append(f"fig: expected a matplotlib Figure, found {type(fig).__name__}")
    if not isinstance(stem, str) or not _STEM_PATTERN.match(stem):
        problems.append(f"stem: expected a file name without directories, found {stem!r}")
    supported = Figure().canvas.get_supported_filetypes()
    if isinstance(formats, str):
        problems.append(f"formats: expected a sequence of format names, found the str {formats!r}")
        formats = ()
    unknown = [f for f in formats if f not in supported]
    if unknown:
        problems.append(f"formats: expected some of {sorted(supported)}, found {unknown}")
    raise_if_any(problems)
    target = Path(directory)
    target.mkdir(parents=True, exist_ok=True)
    written = []
    for file_format in formats:
        final = target / f"{stem}.{file_format}"
        temporary = target / f".{stem}.{secrets.token_hex(8)}.{file_format}.part"
        try:
            fig.savefig(temporary, format=file_format, dpi=dpi)
            os.replace(temporary, final)
        finally:
            temporary.unlink(missing_ok=True)
        written.append(final)
    return written
