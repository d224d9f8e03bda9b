"""A gait lab's exported time series: markers and force plates by the lab's column names.

Gait labs export one row per frame, tab or comma separated, with a time stamp column and,
for every marker, its coordinates in ``NAME.PosX`` / ``NAME.PosY`` (``.PosZ`` is read past:
the analysis is sagittal, X forward in the walking direction, Y up), and for every force
plate ``PLATE.ForX`` / ``PLATE.ForY`` / ``PLATE.MomZ``: the ground's force on the foot [N]
and its moment about the lab's origin [N m] (the origin on the floor, so that the centre of
pressure is ``MomZ / ForY``). :func:`read_lab_export` reads such a file, names every problem
at once, and marks missing marker samples (NaN, or both coordinates exactly zero as some
systems write them) as NaN.

A file without a header line (only numbers) is read with ``names`` given by the caller.
A header line may start with ``%`` or ``#`` (a comment mark some exporters add).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from colloc.data.checks import DEFAULT_SAMPLING_TOLERANCE, TrialError
from colloc.data.text_tables import detect_delimiter, not_utf8

#: Names accepted for the time stamp column (compared without case).
TIME_COLUMN_NAMES: tuple[str, ...] = ("timestamp", "time", "time stamp")

#: Marker coordinate suffixes read (the sagittal plane), and the one read past.
MARKER_AXES: tuple[str, ...] = ("PosX", "PosY")
_IGNORED_MARKER_AXES: tuple[str, ...] = ("PosZ",)

#: Force-plate channel suffixes read: forward and vertical force, moment about the lab's z.
PLATE_CHANNELS: tuple[str, ...] = ("ForX", "ForY", "MomZ")


def stamp_problems(time: np.ndarray) -> list[str]:
    """What keeps in-memory time stamps from being a record's: not 1-D with 2 or more
    samples, not finite, or not strictly increasing (at most one sentence).

    Parameters
    ----------
    time : ndarray

    Returns
    -------
    list of str
    """
    if time.ndim != 1 or time.size < 2:
        return [f"time: expected a 1-D array of 2 or more stamps, found shape {time.shape}"]
    if not np.all(np.isfinite(time)):
        return [f"time: {int((~np.isfinite(time)).sum())} NaN or infinite stamps"]
    if np.any(np.diff(time) <= 0):
        return [f"time: not strictly increasing at sample {int(np.argmax(np.diff(time) <= 0)) + 1}"]
    return []


#: A time step [s] no lab instrument takes (a rate of 2 Hz): stamps in milliseconds.
MAX_TIME_STEP = 0.5


class LabFileError(TrialError):
    """A lab export cannot be used as it is; ``problems`` lists every problem found."""


@dataclass(frozen=True)
class LabExport:
    """The markers and force plates of one lab export, on its own time stamps.

    Attributes
    ----------
    time : ndarray, shape (N,)
        Time stamps [s], strictly increasing and evenly spaced.
    markers : dict
        Marker name (e.g. ``"RGTRO"``) -> array (N, 2): x forward and y up [m], NaN where the
        marker was not seen.
    plates : dict
        Plate name (e.g. ``"FP2"``) -> array (N, 3): ``ForX``, ``ForY`` [N], ``MomZ`` [N m].
    columns : dict
        Every other numeric column by its name (e.g. a belt speed).
    source : str
        The file read (or what the export was made from).
    lateral : dict
        Marker name -> array (N,): its ``.PosZ`` column [m] (to the subject's right of the
        plane), for the markers that have one. The planar pipeline reads past it; a marker
        set of clusters and pelvis markers needs it (:func:`colloc.lab.from_files`).
    """

    time: np.ndarray
    markers: dict[str, np.ndarray]
    plates: dict[str, np.ndarray]
    columns: dict[str, np.ndarray] = field(default_factory=dict)
    source: str = ""
    lateral: dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        time = np.asarray(self.time, dtype=float)
        problems = stamp_problems(time)
        for kind, items, width in (("marker", self.markers, 2), ("plate", self.plates, 3)):
            for name, values in items.items():
                array = np.asarray(values, dtype=float)
                if array.shape != (time.size, width):
                    problems.append(
                        f"{kind} {name}: expected shape ({time.size}, {width}), found {array.shape}"
                    )
                    continue
                bad = np.isinf(array) if kind == "marker" else ~np.isfinite(array)
                if bad.any():
                    row = int(np.argmax(bad.any(axis=1)))
                    what = "infinite" if kind == "marker" else "NaN or infinite"
                    problems.append(
                        f"{kind} {name}: {what} at sample {row} (t = {time[row]:g} s)"
                        + ("; a missing sample is NaN" if kind == "marker" else "")
                    )
        if problems:
            raise LabFileError(self.source or "lab export", problems)

    @property
    def sample_rate(self) -> float:
        """Samples per second, from the median time step."""
        return float(1.0 / np.median(np.diff(self.time)))

    def missing(self) -> dict[str, int]:
        """Missing samples per marker (only markers with some)."""
        counts = {name: int(np.isnan(xy[:, 0]).sum()) for name, xy in self.markers.items()}
        return {name: count for name, count in counts.items() if count}


def read_lab_export(
    path: str | os.PathLike[str],
    *,
    names: Sequence[str] | None = None,
    zeros_are_missing: bool = True,
    sampling_tolerance: float = DEFAULT_SAMPLING_TOLERANCE,
) -> LabExport:
    """Read a lab's marker and/or force-plate export.

    Parameters
    ----------
    path : path-like
        A tab- or comma-separated text file (the delimiter is sniffed from the first line).
    names : sequence of str, optional
        Column names for a file without a header line (its first line is data). With a
        header line, leave it out.
    zeros_are_missing : bool
        Take a marker sample whose coordinates are all exactly zero as missing, as systems
        that write 0 for an occluded marker do (default True).
    sampling_tolerance : float
        Largest accepted relative deviation of a time step from the median step.

    Returns
    -------
    LabExport

    Raises
    ------
    LabFileError
        Naming every problem found: no time column, time not increasing or uneven, text in
        a number column, a marker with an X but no Y column, a plate without all of ForX,
        ForY and MomZ, NaN in a plate channel, a header-less file without ``names``, or
        ``names`` not matching the number of columns.
    """
    path = Path(path)
    if not (
        isinstance(sampling_tolerance, int | float)
        and np.isfinite(sampling_tolerance)
        and 0 <= sampling_tolerance < 1
    ):
        raise ValueError(
            f"sampling_tolerance: expected a fraction in [0, 1), found {sampling_tolerance!r}"
        )
    if isinstance(names, str):
        raise TypeError(f"names: expected a sequence of column names, found the string {names!r}")
    frame = _read(path, names)
    problems: list[str] = []
    header = [str(name).strip().lstrip("%#").strip() for name in frame.columns]
    frame.columns = header
    # pandas renames a repeated name (RLEK.PosX.1): the file's own header line says
    written = header if names else _header_line(path)
    duplicated = sorted({name for name in written if written.count(name) > 1})
    if duplicated:
        raise LabFileError(str(path), [f"column names repeated: {', '.join(duplicated)}"])
    values = _numbers(frame, problems)
    time_name = next((n for n in header if n.lower() in TIME_COLUMN_NAMES), None)
    if time_name is None:
        problems.append(
            f"no time stamp column: expected one named {' or '.join(TIME_COLUMN_NAMES)} "
            f"(any case), found columns {header[:6]}{' ...' if len(header) > 6 else ''}"
        )
    markers, plates, rest = _groups(header, time_name, problems)
    if problems:
        raise LabFileError(str(path), problems)
    assert time_name is not None  # else a problem above
    time = values[time_name]
    problems += _time_problems(time, sampling_tolerance)
    marker_xy = {
        name: np.column_stack([values[f"{name}.{axis}"] for axis in MARKER_AXES])
        for name in markers
    }
    if zeros_are_missing:
        for xy in marker_xy.values():
            xy[np.all(xy == 0.0, axis=1)] = np.nan
    for xy in marker_xy.values():
        xy[np.any(np.isnan(xy), axis=1)] = np.nan
    plate_channels = {
        name: np.column_stack([values[f"{name}.{channel}"] for channel in PLATE_CHANNELS])
        for name in plates
    }
    for name, channels in plate_channels.items():
        bad = ~np.isfinite(channels)
        if bad.any():
            row = int(np.argmax(bad.any(axis=1)))
            problems.append(
                f"plate {name}: {int(bad.sum())} NaN or infinite values (first at row {row + 1}, "
                f"t = {time[row]:g} s); a force plate's channels are never missing, check the "
                "export"
            )
    if problems:
        raise LabFileError(str(path), problems)
    lateral = {
        name: np.where(np.isnan(marker_xy[name][:, 0]), np.nan, values[f"{name}.PosZ"])
        for name in markers
        if f"{name}.PosZ" in values
    }
    return LabExport(
        time=time,
        markers=marker_xy,
        plates=plate_channels,
        columns={name: values[name] for name in rest},
        source=str(path),
        lateral=lateral,
    )


def _read(path: Path, names: Sequence[str] | None) -> pd.DataFrame:
    if not path.is_file():
        raise LabFileError(str(path), ["file not found"])
    try:
        delimiter = detect_delimiter(path)
        if names:
            with open(path, encoding="utf-8-sig") as stream:
                fields = len(stream.readline().rstrip("\r\n").split(delimiter))
            if fields != len(names):
                raise LabFileError(
                    str(path), [f"names: {len(names)} given, but the file has {fields} columns"]
                )
        options: dict[str, object] = {"header": None, "names": list(names)} if names else {}
        frame = pd.read_csv(
            path, sep=delimiter, encoding="utf-8-sig", dtype=str, skipinitialspace=True, **options
        )
    except UnicodeDecodeError as error:
        raise LabFileError(str(path), [not_utf8(error)]) from error
    except (pd.errors.ParserError, pd.errors.EmptyDataError) as error:
        raise LabFileError(str(path), [f"cannot parse it as a table ({error})"]) from error
    if frame.empty:
        raise LabFileError(str(path), ["no data rows"])
    if not names and _is_number(str(frame.columns[0]).strip().lstrip("%#")):
        raise LabFileError(
            str(path),
            [
                "the first line holds numbers, not column names: give the names of the "
                "columns (names=..., or --columns on the command line)"
            ],
        )
    return frame


def _header_line(path: Path) -> list[str]:
    """The column names as the file's first line writes them."""
    delimiter = detect_delimiter(path)
    with open(path, encoding="utf-8-sig") as stream:
        line = stream.readline().rstrip("\r\n")
    return [name.strip().lstrip("%#").strip() for name in line.split(delimiter)]


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _numbers(frame: pd.DataFrame, problems: list[str]) -> dict[str, np.ndarray]:
    """Every column as floats; text that is not a number (nor NaN) is a problem."""
    values = {}
    for name in frame.columns:
        text = frame[name].astype(str).str.strip()
        numbers = pd.to_numeric(text, errors="coerce")
        bad = numbers.isna() & ~text.str.lower().isin(("nan", "", "none"))
        bad &= frame[name].notna()
        if bad.any():
            row = int(np.argmax(bad.to_numpy()))
            problems.append(
                f"column {name}: {int(bad.sum())} entries are not numbers (first at row "
                f"{row + 1}: {text.iloc[row]!r})"
            )
        values[name] = numbers.to_numpy(dtype=float)
    return values


def _groups(
    header: list[str], time_name: str | None, problems: list[str]
) -> tuple[list[str], list[str], list[str]]:
    """Marker and plate names with complete channel sets, and the other columns."""
    markers: dict[str, set[str]] = {}
    plates: dict[str, set[str]] = {}
    rest = []
    for column in header:
        if column == time_name:
            continue
        base, _, suffix = column.rpartition(".")
        if base and suffix in MARKER_AXES + _IGNORED_MARKER_AXES:
            markers.setdefault(base, set()).add(suffix)
        elif base and suffix in PLATE_CHANNELS:
            plates.setdefault(base, set()).add(suffix)
        elif base and suffix.startswith(("For", "Mom", "Cop")):
            continue  # other plate channels (ForZ, MomX, ...): out of the sagittal plane
        else:
            rest.append(column)
    for name, axes in markers.items():
        lacking = [axis for axis in MARKER_AXES if axis not in axes]
        if lacking:
            problems.append(
                f"marker {name}: no column {', '.join(f'{name}.{a}' for a in lacking)} (a "
                f"marker needs both {' and '.join(MARKER_AXES)})"
            )
    for name, channels in plates.items():
        lacking = [c for c in PLATE_CHANNELS if c not in channels]
        if lacking:
            problems.append(
                f"plate {name}: no column {', '.join(f'{name}.{c}' for c in lacking)} (a plate "
                f"needs {', '.join(PLATE_CHANNELS)})"
            )
    complete_markers = [n for n, a in markers.items() if all(x in a for x in MARKER_AXES)]
    complete_plates = [n for n, c in plates.items() if all(x in c for x in PLATE_CHANNELS)]
    return complete_markers, complete_plates, rest


def _time_problems(time: np.ndarray, tolerance: float) -> list[str]:
    if time.size < 2:
        return [f"time: expected at least 2 samples, found {time.size}"]
    if not np.all(np.isfinite(time)):
        row = int(np.argmax(~np.isfinite(time)))
        return [f"time: {int((~np.isfinite(time)).sum())} missing stamps (first at row {row + 1})"]
    step = np.diff(time)
    if np.any(step <= 0):
        row = int(np.argmax(step <= 0)) + 1
        return [
            f"time: not strictly increasing at row {row + 1} ({time[row - 1]:g} -> {time[row]:g} s)"
        ]
    median = float(np.median(step))
    if median >= MAX_TIME_STEP:
        return [
            f"time: {median:g} between samples, a rate of {1 / median:.3g} Hz; motion capture "
            f"and force plates sample at 50 Hz or more: are the time stamps in milliseconds? "
            "(expected seconds)"
        ]
    uneven = np.abs(step - median) > tolerance * median
    if uneven.any():
        row = int(np.argmax(uneven)) + 1
        return [
            f"time: uneven sampling, {int(uneven.sum())} steps deviate from the median step "
            f"{median:g} s by more than {tolerance:.0%} (first at row {row + 1}, step "
            f"{step[row - 1]:g} s); resample the export at a fixed rate first"
        ]
    return []
