"""A gait trial in memory and on disk.

On-disk layout (one directory per trial)::

    <trial>/
        trial.csv       time series: a ``time`` column and the canonical signal columns
                        (see :mod:`colloc.data.columns`); comma separated with a header
                        line. ``trial.tsv`` (tab separated) is read as well; the
                        delimiter is sniffed from the header line.
        events.csv      heel strikes, one per row: columns ``side`` (``right``/``left``)
                        and ``time`` [s].
        metadata.yaml   optional mapping: ``sample_rate`` [Hz], ``body_mass`` [kg],
                        ``height`` [m], ``units`` (column -> unit, must agree with the
                        canonical units), and anything else, e.g. the true controller of
                        a synthetic trial as an arbitrary nested mapping.
        markers.csv,    optional: the lab's raw markers and plates at their own rates
        plates.csv      (:mod:`colloc.data.tables`).

Heel strikes live in their own small file rather than as a sparse column because they are
events, not samples: they need not fall on a sample time, and the two sides are
independent lists of different lengths.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import uuid
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import yaml

from colloc.data.checks import (
    DEFAULT_SAMPLING_TOLERANCE,
    TrialError,
    column_problems,
    heel_strike_problems,
    metadata_problems,
    metadata_sample_rate,
    nan_problems,
    plausibility_problems,
    time_problems,
)
from colloc.data.columns import COLUMN_UNITS, SIDES, TIME_COLUMN
from colloc.data.tables import read_tables, table_file_names, tables_problems, write_tables
from colloc.data.text_tables import not_utf8, read_table
from colloc.data.yaml_io import safe_load_unique

TRIAL_FILE_NAMES: tuple[str, ...] = ("trial.csv", "trial.tsv")
"""Names of the time-series file searched for in a trial directory, in order."""

EVENTS_FILE_NAME = "events.csv"
"""Name of the heel-strike file in a trial directory."""

METADATA_FILE_NAME = "metadata.yaml"
"""Name of the metadata file in a trial directory."""

_EVENT_COLUMNS = ("side", "time")


@dataclass
class Trial:
    """One gait trial: sampled signals, heel-strike events and metadata.

    Parameters
    ----------
    time : ndarray, shape (M,)
        Sample times [s].
    signals : DataFrame, M rows
        Signal columns named as in :data:`colloc.data.columns.SIGNAL_COLUMNS` (extra
        columns are kept); row ``i`` is sampled at ``time[i]``.
    right_heel_strikes, left_heel_strikes : ndarray, shape (S,)
        Heel-strike times [s] of each foot, increasing.
    metadata : dict
        Free-form metadata; see the module docstring for the keys that are checked.
    tables : dict, optional
        The lab's raw records at their own rates, by name (``markers``, ``plates``; see
        :mod:`colloc.data.tables`); empty for a trial that has none.

    Notes
    -----
    Construction checks only the shapes; :meth:`validate` checks the content (columns,
    NaNs, time, heel strikes, units) and :meth:`write` refuses an invalid trial.
    """

    time: np.ndarray
    signals: pd.DataFrame
    right_heel_strikes: np.ndarray
    left_heel_strikes: np.ndarray
    metadata: dict[str, Any] = field(default_factory=dict)
    tables: dict[str, pd.DataFrame] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.signals, pd.DataFrame):
            raise TypeError(
                f"signals must be a pandas.DataFrame, found {type(self.signals).__name__}"
            )
        self.time = np.asarray(self.time, dtype=float)
        self.right_heel_strikes = np.asarray(self.right_heel_strikes, dtype=float)
        self.left_heel_strikes = np.asarray(self.left_heel_strikes, dtype=float)
        problems = []
        if self.time.ndim != 1:
            problems.append(f"time must be 1-D, found shape {self.time.shape}")
        elif len(self.signals) != self.time.size:
            problems.append(
                f"signals must have one row per time sample ({self.time.size}), "
                f"found {len(self.signals)} rows"
            )
        for side in SIDES:
            strikes = getattr(self, f"{side}_heel_strikes")
            if strikes.ndim != 1:
                problems.append(f"{side}_heel_strikes must be 1-D, found shape {strikes.shape}")
        if problems:
            raise TrialError("trial", problems)

    def problems(self, sampling_tolerance: float = DEFAULT_SAMPLING_TOLERANCE) -> list[str]:
        """Return every content problem of the trial (empty when valid).

        Parameters
        ----------
        sampling_tolerance : float
            Largest accepted relative deviation of a time step from the median step.

        Returns
        -------
        list of str
            One sentence per problem.
        """
        columns = [str(name) for name in self.signals.columns]
        found = column_problems(columns)
        found += nan_problems(self.time, self.signals)
        found += time_problems(self.time, sampling_tolerance, metadata_sample_rate(self.metadata))
        for side in SIDES:
            found += heel_strike_problems(side, getattr(self, f"{side}_heel_strikes"), self.time)
        found += metadata_problems(self.metadata, [TIME_COLUMN, *columns])
        found += tables_problems(self.tables)
        found += plausibility_problems(
            self.time,
            self.signals,
            self.right_heel_strikes,
            self.left_heel_strikes,
            metadata_sample_rate(self.metadata),
        )
        return found

    def validate(self, sampling_tolerance: float = DEFAULT_SAMPLING_TOLERANCE) -> None:
        """Raise :class:`TrialError` listing every problem if the trial is invalid.

        Parameters
        ----------
        sampling_tolerance : float
            Largest accepted relative deviation of a time step from the median step.

        Raises
        ------
        TrialError
            If :meth:`problems` finds anything.
        """
        found = self.problems(sampling_tolerance)
        if found:
            raise TrialError("trial", found)

    def write(self, directory: str | os.PathLike[str], *, overwrite: bool = False) -> Path:
        """Write the trial to ``directory`` atomically (see the module docstring for files).

        The files are written into a temporary sibling directory which is then renamed to
        ``directory``, so a crash never leaves half a trial and never replaces a good trial
        by a partial one. Metadata gains a ``units`` entry for the canonical columns
        present unless it has one; NumPy arrays and scalars in the metadata are written as
        plain lists and numbers.

        Parameters
        ----------
        directory : path-like
            Trial directory to create.
        overwrite : bool
            Replace an existing ``directory``; otherwise it is an error. Only a folder that
            holds nothing but a trial's files (see :func:`replace_refusal`) is replaced: a
            folder with anything else in it, such as the lab export the trial was made
            from, is refused and left as it is.

        Returns
        -------
        Path
            The trial directory.

        Raises
        ------
        TrialError
            If the trial is invalid (nothing is written).
        FileExistsError
            If ``directory`` exists and ``overwrite`` is False, or it is not a trial folder
            that may be replaced.
        """
        self.validate()
        target = Path(directory)
        if target.exists() and not overwrite:
            raise FileExistsError(
                f"directory {str(target)!r} already exists; pass overwrite=True to replace it"
            )
        refusal = replace_refusal(target)
        if refusal is not None:
            raise FileExistsError(refusal)
        target.parent.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=target.parent))
        backup = target.parent / f".{target.name}.old-{uuid.uuid4().hex}"
        try:
            staging.chmod(0o755)
            self._write_files(staging)
            if target.exists():
                target.rename(backup)
            staging.rename(target)
        except BaseException:
            shutil.rmtree(staging, ignore_errors=True)
            if backup.exists() and not target.exists():
                backup.rename(target)
            raise
        shutil.rmtree(backup, ignore_errors=True)
        return target

    def _write_files(self, directory: Path) -> None:
        series = self.signals.reset_index(drop=True).copy()
        series.insert(0, TIME_COLUMN, self.time)
        series.to_csv(directory / TRIAL_FILE_NAMES[0], index=False)
        events = pd.DataFrame(
            {
                "side": [side for side in SIDES for _ in getattr(self, f"{side}_heel_strikes")],
                "time": np.concatenate([getattr(self, f"{side}_heel_strikes") for side in SIDES]),
            }
        ).sort_values("time", kind="stable")
        events.to_csv(directory / EVENTS_FILE_NAME, index=False)
        metadata = dict(self.metadata)
        if "units" not in metadata:
            metadata["units"] = {
                name: COLUMN_UNITS[name] for name in series.columns if name in COLUMN_UNITS
            }
        with open(directory / METADATA_FILE_NAME, "w", encoding="utf-8") as stream:
            yaml.safe_dump(_plain(metadata), stream, sort_keys=False, allow_unicode=True)
        write_tables(directory, self.tables)


def replace_refusal(directory: str | os.PathLike[str]) -> str | None:
    """Why an existing ``directory`` may not be replaced by a trial (None when it may).

    A trial replaces only what a trial is: a missing path, an empty folder, or a folder
    holding nothing but the files a trial is made of (``trial.csv`` or ``trial.tsv``,
    ``events.csv``, ``metadata.yaml``, ``markers.csv``, ``plates.csv``). Anything else in the folder (another file, a
    subfolder, a hidden file) may be a user's and is never deleted.

    Parameters
    ----------
    directory : path-like
        The folder a trial is about to be written to.

    Returns
    -------
    str or None
        A sentence naming the folder and what in it is not a trial's, or None.
    """
    target = Path(directory)
    if not target.exists() and not target.is_symlink():
        return None
    if target.is_symlink() or not target.is_dir():
        kind = "a link" if target.is_symlink() else "a file"
        return f"{str(target)!r} is {kind}, not a trial folder; it is left as it is"
    allowed = {*TRIAL_FILE_NAMES, EVENTS_FILE_NAME, METADATA_FILE_NAME, *table_file_names()}
    try:
        entries = sorted(os.listdir(target))
    except OSError as error:
        return f"{str(target)!r} cannot be read ({error}); it is left as it is"
    foreign = [name for name in entries if name not in allowed or not (target / name).is_file()]
    if foreign:
        shown = ", ".join(repr(name) for name in foreign[:5])
        more = f" and {len(foreign) - 5} more" if len(foreign) > 5 else ""
        return (
            f"{str(target)!r} holds {shown}{more}, which is not part of a trial; only a "
            "folder holding a trial's files alone (trial.csv, events.csv, metadata.yaml, and a "
            "lab trial's markers.csv and plates.csv) is "
            "replaced: choose a new folder or move those out"
        )
    return None


def _plain(value: Any) -> Any:
    """Convert NumPy containers and scalars (recursively) to YAML-safe Python objects."""
    if isinstance(value, Mapping):
        return {_plain(key): _plain(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(item) for item in value]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    return value


def _read_frame(path: Path, problems: list[str]) -> pd.DataFrame | None:
    try:
        frame = read_table(path)
    except ValueError as error:
        problems.append(f"cannot parse {path.name}: {error}")
        return None
    frame.columns = [str(name).strip() for name in frame.columns]
    return frame


def _read_events(path: Path, problems: list[str]) -> dict[str, np.ndarray]:
    empty = {side: np.empty(0) for side in SIDES}
    if not path.is_file():
        problems.append(f"heel-strike file {path.name} not found (columns: side, time)")
        return empty
    frame = _read_frame(path, problems)
    if frame is None:
        return empty
    missing = [name for name in _EVENT_COLUMNS if name not in frame.columns]
    if missing:
        problems.append(f"{path.name} is missing columns {missing}, found {list(frame.columns)}")
        return empty
    repeated = [f"{path.name}: {p}" for p in _raw_column_problems(frame)]
    if repeated:
        problems.extend(repeated)
        return empty
    sides = frame["side"].astype(str).str.strip().str.lower()
    unknown = sorted(set(sides) - set(SIDES), key=str)
    if unknown:
        problems.append(f"{path.name} column 'side' must be one of {list(SIDES)}, found {unknown}")
    times = pd.to_numeric(frame["time"], errors="coerce").to_numpy(dtype=float)
    text = frame["time"].astype(str).str.strip()
    unreadable = np.isnan(times) & ~text.str.lower().isin(["nan", ""]).to_numpy()
    if unreadable.any():
        rows = np.flatnonzero(unreadable)
        shown = ", ".join(f"row {int(i) + 2}: {text.iloc[int(i)]!r}" for i in rows[:3])
        problems.append(
            f"{path.name} column 'time': expected numbers in seconds, found {rows.size} "
            f"that are not ({shown}{', ...' if rows.size > 3 else ''})"
        )
        return empty
    return {side: times[(sides == side).to_numpy()] for side in SIDES}


def _read_metadata(path: Path, problems: list[str]) -> dict[str, Any]:
    if not path.is_file():
        return {}
    try:
        with open(path, encoding="utf-8") as stream:
            loaded = safe_load_unique(stream)
    except yaml.YAMLError as error:
        problems.append(f"cannot parse {path.name}: {error}")
        return {}
    except UnicodeDecodeError as error:
        problems.append(f"{path.name} is {not_utf8(error)}")
        return {}
    if loaded is None:
        return {}
    if not isinstance(loaded, dict):
        problems.append(f"{path.name} must hold a mapping, found {type(loaded).__name__}")
        return {}
    return loaded


def _raw_column_problems(frame: pd.DataFrame) -> list[str]:
    """Columns that parse as numbers only by accident: a repeated name (pandas renames the
    second ``x.1``) and true/false columns."""
    problems = []
    names = [str(c) for c in frame.columns]
    for name in names:
        base, dot, suffix = name.rpartition(".")
        if dot and suffix.isdigit() and base in names:
            problems.append(f"column {base!r} appears more than once in the header")
    for name in names:
        if pd.api.types.is_bool_dtype(frame[name]):
            problems.append(f"column {name!r} holds true/false values, not numbers")
    return problems


def _find_series_file(directory: Path) -> Path:
    found = [name for name in TRIAL_FILE_NAMES if (directory / name).is_file()]
    if len(found) > 1:
        raise TrialError(
            str(directory), [f"several time-series files {found}: keep one (which is the trial?)"]
        )
    if found:
        return directory / found[0]
    raise TrialError(
        str(directory), [f"no time-series file found; expected one of {list(TRIAL_FILE_NAMES)}"]
    )


def read_trial_metadata(directory: str | os.PathLike[str]) -> dict[str, Any]:
    """The ``metadata.yaml`` of a trial directory alone, without reading its time series.

    Parameters
    ----------
    directory : path-like
        A trial directory.

    Returns
    -------
    dict
        Empty when the trial has no ``metadata.yaml``.

    Raises
    ------
    FileNotFoundError
        If ``directory`` is not a directory.
    TrialError
        If the file cannot be parsed or does not hold a mapping.
    """
    folder = Path(directory)
    if not folder.is_dir():
        raise FileNotFoundError(f"trial: expected a trial directory, found {str(folder)!r}")
    problems: list[str] = []
    loaded = _read_metadata(folder / METADATA_FILE_NAME, problems)
    if problems:
        raise TrialError(str(folder), problems)
    return loaded


def read_trial(
    path: str | os.PathLike[str], *, sampling_tolerance: float = DEFAULT_SAMPLING_TOLERANCE
) -> Trial:
    """Read and validate a trial directory (or its time-series file).

    Parameters
    ----------
    path : path-like
        A trial directory, or the time-series file inside one (then ``events.csv`` and
        ``metadata.yaml`` are taken from the same directory).
    sampling_tolerance : float
        Largest accepted relative deviation of a time step from the median step.

    Returns
    -------
    Trial
        The validated trial.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    TrialError
        Listing every problem found: unreadable files, missing columns, NaNs, non-increasing
        or non-uniform time, heel strikes out of order or outside the time range, units in
        the metadata that disagree with the canonical ones.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"path {str(path)!r} does not exist (expected a trial directory)")
    series_path = _find_series_file(path) if path.is_dir() else path
    directory = series_path.parent
    problems: list[str] = []
    frame = _read_frame(series_path, problems)
    strikes = _read_events(directory / EVENTS_FILE_NAME, problems)
    metadata = _read_metadata(directory / METADATA_FILE_NAME, problems)
    tables = read_tables(directory, problems)
    if frame is not None and TIME_COLUMN not in frame.columns:
        problems.append(f"missing time column {TIME_COLUMN!r}, found {list(frame.columns)[:5]}...")
        frame = None
    if frame is None:
        raise TrialError(str(path), problems)
    problems += _raw_column_problems(frame)
    time = pd.to_numeric(frame[TIME_COLUMN], errors="coerce").to_numpy(dtype=float)
    signals = frame.drop(columns=TIME_COLUMN).apply(pd.to_numeric, errors="coerce")
    trial = Trial(time, signals, strikes["right"], strikes["left"], metadata, tables)
    problems += trial.problems(sampling_tolerance)
    if problems:
        raise TrialError(str(path), problems)
    return trial
