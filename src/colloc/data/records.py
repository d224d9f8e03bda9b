"""Readers for shared measured records: Winter's normative gait cycle and a vertical GRF."""

from __future__ import annotations

import csv
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from colloc.data.text_tables import not_utf8, read_table

# Header names in Winter_normal.csv (stripped, lower case) -> WinterGaitCycle field.
_WINTER_COLUMNS: dict[str, str] = {
    "%gait cycle": "percent",
    "hip angle": "hip",
    "knee angle": "knee",
    "ankle angle": "ankle",
    "horizontal grf": "horizontal_grf",
    "vertical grf": "vertical_grf",
    "hip moment": "hip_moment",
    "knee moment": "knee_moment",
    "ankle moment": "ankle_moment",
}
_WINTER_ANGLE_UNIT = "(deg)"
# gait2d sign of each Winter angle: knee flexion + in the file, knee extension + in gait2d.
_GAIT2D_SIGN = {"hip": 1.0, "knee": -1.0, "ankle": 1.0}


@dataclass(frozen=True)
class WinterGaitCycle:
    """Winter's normative gait cycle (one averaged stride), in gait2d conventions.

    Attributes
    ----------
    cycle_duration : float
        Duration of the gait cycle [s].
    walking_speed : float
        Walking speed [m/s].
    percent : ndarray, shape (K,)
        Percent of the gait cycle, 0 to 100.
    hip, knee, ankle : ndarray, shape (K,)
        Joint angles [rad] as gait2d coordinates: hip flexion +, knee = minus knee flexion,
        ankle dorsiflexion +.
    horizontal_grf, vertical_grf : ndarray, shape (K,)
        Ground reaction force per body mass [N/kg], as in the file.
    hip_moment, knee_moment, ankle_moment : ndarray, shape (K,)
        Joint moments per body mass [N·m/kg], with Winter's signs as in the file (not
        converted; check the sign convention before use).
    """

    cycle_duration: float
    walking_speed: float
    percent: np.ndarray
    hip: np.ndarray
    knee: np.ndarray
    ankle: np.ndarray
    horizontal_grf: np.ndarray
    vertical_grf: np.ndarray
    hip_moment: np.ndarray
    knee_moment: np.ndarray
    ankle_moment: np.ndarray

    @property
    def time(self) -> np.ndarray:
        """Time within the cycle [s]: ``percent / 100 * cycle_duration``."""
        return self.percent / 100.0 * self.cycle_duration

    def to_pandas(self) -> pd.DataFrame:
        """Return the samples as a DataFrame indexed by time [s]."""
        columns = {field: getattr(self, field) for field in _WINTER_COLUMNS.values()}
        return pd.DataFrame(columns, index=pd.Index(self.time, name="time"))


def _labelled_number(rows: list[list[str]], label: str, path: Path) -> float:
    for row in rows:
        if row and row[0].strip().lower().startswith(label):
            for cell in row[1:]:
                try:
                    return float(cell)
                except ValueError:
                    continue
    raise ValueError(f"path {str(path)!r}: no number found on a line starting with {label!r}")


def read_winter_gait_cycle(path: str | os.PathLike[str]) -> WinterGaitCycle:
    """Read Winter's normative gait cycle (``winter-normal-gait-cycle/Winter_normal.csv``).

    The file is a CSV with a UTF-8 byte-order mark: a title line, ``Gait cycle duration``
    and ``Walking speed`` lines, a blank line, the column names, a units line, then one
    row per 2 % of the gait cycle. Angles are converted from degrees to radians and to
    gait2d signs (see :class:`WinterGaitCycle`).

    Parameters
    ----------
    path : path-like
        The CSV file.

    Returns
    -------
    WinterGaitCycle
        The parsed cycle.

    Raises
    ------
    ValueError
        If the duration, speed, a column or the units line is missing or wrong, or a data
        value is not numeric.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as error:
        raise ValueError(f"path {str(path)!r}: {not_utf8(error)}") from error
    rows = list(csv.reader(text.splitlines()))
    duration = _labelled_number(rows, "gait cycle duration", path)
    speed = _labelled_number(rows, "walking speed", path)
    header_index = next(
        (i for i, row in enumerate(rows) if row and row[0].strip().lower() == "sample"), None
    )
    if header_index is None:
        raise ValueError(f"path {str(path)!r}: no header line starting with 'sample'")
    header = [cell.strip().lower() for cell in rows[header_index]]
    units = rows[header_index + 1] if header_index + 1 < len(rows) else []
    missing = [name for name in _WINTER_COLUMNS if name not in header]
    problems = [f"missing columns {missing}, found {header}"] if missing else []
    wrong_units = []
    for name in ("hip angle", "knee angle", "ankle angle"):
        column = header.index(name) if name in header else None
        unit = units[column].strip() if column is not None and column < len(units) else ""
        if column is not None and unit != _WINTER_ANGLE_UNIT:
            wrong_units.append(f"{name!r}: {unit!r}")
    if wrong_units:
        problems.append(f"angle units must be {_WINTER_ANGLE_UNIT!r}, found {wrong_units}")
    if problems:
        raise ValueError(f"path {str(path)!r}: " + "; ".join(problems))
    data_rows = [row for row in rows[header_index + 2 :] if any(cell.strip() for cell in row)]
    values: dict[str, np.ndarray] = {}
    for name, field in _WINTER_COLUMNS.items():
        column = header.index(name)
        try:
            values[field] = np.array([float(row[column]) for row in data_rows])
        except (ValueError, IndexError) as error:
            raise ValueError(
                f"path {str(path)!r}: column {name!r} holds a missing or non-numeric value "
                f"({error})"
            ) from error
    for joint, sign in _GAIT2D_SIGN.items():
        values[joint] = sign * np.deg2rad(values[joint])
    return WinterGaitCycle(cycle_duration=duration, walking_speed=speed, **values)


def read_vertical_grf(path: str | os.PathLike[str]) -> tuple[np.ndarray, np.ndarray]:
    """Read a two-column vertical ground-reaction-force record without header.

    The format is that of ``gatk-grf-and-treadmill-speed/example_vertical_grf.csv``:
    time [s] and vertical force of one foot [N], comma (or tab) separated.

    Parameters
    ----------
    path : path-like
        The record file.

    Returns
    -------
    time : ndarray, shape (M,)
        Sample times [s] (the steps may jitter).
    vertical_force : ndarray, shape (M,)
        Vertical ground reaction force [N].

    Raises
    ------
    ValueError
        If the file does not have exactly 2 numeric columns, or time is not strictly
        increasing.
    """
    frame = read_table(path, header=None)
    if frame.shape[1] != 2:
        raise ValueError(
            f"path {os.fspath(path)!r}: expected 2 columns (time, force), found {frame.shape[1]}"
        )
    numeric = frame.apply(pd.to_numeric, errors="coerce").to_numpy(dtype=float)
    problems = []
    bad = ~np.isfinite(numeric)
    if bad.any():
        problems.append(
            f"{int(bad.sum())} missing/non-numeric values (first in data row "
            f"{int(np.argmax(bad.any(axis=1)))})"
        )
    elif np.any(np.diff(numeric[:, 0]) <= 0.0):
        problems.append("time (column 1) must be strictly increasing")
    if problems:
        raise ValueError(f"path {os.fspath(path)!r}: " + "; ".join(problems))
    return numeric[:, 0], numeric[:, 1]
