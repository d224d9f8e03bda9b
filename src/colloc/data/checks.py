"""Validation of gait-trial content: every problem is collected, then reported at once."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from numbers import Real
from typing import Any

import numpy as np
import pandas as pd

from colloc.data.columns import (
    COLUMN_UNITS,
    COP_COLUMNS,
    JOINT_ANGLE_COLUMNS,
    OPTIONAL_GROUPS,
    REQUIRED_COLUMNS,
    TIME_COLUMN,
    normalize_unit,
)

DEFAULT_SAMPLING_TOLERANCE = 0.01
"""Largest accepted relative deviation of a time step from the median step."""

POSITIVE_METADATA_KEYS: tuple[str, ...] = ("sample_rate", "body_mass", "height")
"""Metadata entries that, when present, must be positive numbers (Hz, kg, m)."""


class TrialError(ValueError):
    """A gait trial (or its files) is invalid; ``problems`` lists every problem found.

    Parameters
    ----------
    source : str
        What was checked (a path or ``"trial"``), used in the message.
    problems : sequence of str
        One sentence per problem.
    """

    def __init__(self, source: str, problems: Sequence[str]) -> None:
        self.source = source
        self.problems = list(problems)
        lines = "\n".join(f"  - {problem}" for problem in self.problems)
        count = len(self.problems)
        super().__init__(f"{source}: {count} problem{'s' * (count != 1)} found:\n{lines}")


def column_problems(columns: Sequence[str]) -> list[str]:
    """Report missing required columns and incomplete optional groups (all or none).

    Parameters
    ----------
    columns : sequence of str
        Signal column names present (without the time column).

    Returns
    -------
    list of str
        Problems found; empty when the columns are complete.
    """
    present = set(columns)
    problems = []
    missing = [name for name in REQUIRED_COLUMNS if name not in present]
    partial = []
    for group, names in OPTIONAL_GROUPS.items():
        if any(name in present for name in names):
            absent = [name for name in names if name not in present]
            missing += absent
            if absent:
                partial.append(f"{group} columns are optional, but all {len(names)} or none")
    if missing:
        unknown = [name for name in columns if name not in COLUMN_UNITS]
        hint = f"; columns present but not recognised: {unknown}" if unknown else ""
        note = f" ({'; '.join(partial)})" if partial else ""
        problems.append(f"missing columns {missing}{note}{hint}")
    return problems


def nan_problems(time: np.ndarray, signals: pd.DataFrame) -> list[str]:
    """Report non-finite values in the time column and in each signal column.

    Parameters
    ----------
    time : ndarray, shape (M,)
        Sample times.
    signals : DataFrame, M rows
        Signal columns.

    Returns
    -------
    list of str
        One problem per column that holds NaN or infinite values (NaN is allowed in the
        centre-of-pressure columns, :data:`colloc.data.columns.COP_COLUMNS`).
    """
    problems = []
    bad_time = ~np.isfinite(time)
    if bad_time.any():
        first = int(np.argmax(bad_time))
        problems.append(
            f"column {TIME_COLUMN!r} has {int(bad_time.sum())} NaN/infinite values "
            f"(first at sample {first})"
        )
    for name in signals.columns:
        values = pd.to_numeric(signals[name], errors="coerce").to_numpy(dtype=float)
        # a centre of pressure is undefined while its foot is unloaded: NaN there, never inf
        bad = np.isinf(values) if name in COP_COLUMNS else ~np.isfinite(values)
        if bad.any():
            first = int(np.argmax(bad))
            at_time = f", time {time[first]:.6g} s" if np.isfinite(time[first]) else ""
            problems.append(
                f"column {name!r} has {int(bad.sum())} NaN/infinite/non-numeric values "
                f"(first at sample {first}{at_time})"
            )
    return problems


def time_problems(
    time: np.ndarray,
    sampling_tolerance: float = DEFAULT_SAMPLING_TOLERANCE,
    sample_rate: float | None = None,
) -> list[str]:
    """Report a too short, non-increasing or non-uniformly sampled time column.

    Parameters
    ----------
    time : ndarray, shape (M,)
        Sample times; non-finite entries are reported elsewhere and skipped here.
    sampling_tolerance : float
        Largest accepted relative deviation of a step from the median step.
    sample_rate : float, optional
        Sample rate [Hz] stated in the metadata; checked against the median step.

    Returns
    -------
    list of str
        Problems found.
    """
    if time.size < 2:
        return [f"column {TIME_COLUMN!r} needs at least 2 samples, found {time.size}"]
    if not np.all(np.isfinite(time)):
        return []
    step = np.diff(time)
    not_after = step <= 0.0
    if not_after.any():
        i = int(np.argmax(not_after)) + 1
        return [
            f"column {TIME_COLUMN!r} is not strictly increasing: sample {i} "
            f"(time {time[i]:.6g} s) is not after sample {i - 1} (time {time[i - 1]:.6g} s)"
        ]
    problems = []
    nominal = float(np.median(step))
    deviation = np.abs(step - nominal) / nominal
    off = deviation > sampling_tolerance
    if off.any():
        i = int(np.argmax(off))
        problems.append(
            f"column {TIME_COLUMN!r} is not uniformly sampled: {int(off.sum())} steps differ "
            f"from the median step {nominal:.6g} s by more than {sampling_tolerance:.3g} "
            f"(relative); first between samples {i} and {i + 1} (time {time[i]:.6g} s, "
            f"step {step[i]:.6g} s); resample the trial or raise sampling_tolerance"
        )
    if sample_rate is not None and abs(sample_rate * nominal - 1.0) > sampling_tolerance:
        problems.append(
            f"metadata 'sample_rate' is {sample_rate:.6g} Hz but the time column is sampled "
            f"at {1.0 / nominal:.6g} Hz"
        )
    return problems


def heel_strike_problems(side: str, strikes: np.ndarray, time: np.ndarray) -> list[str]:
    """Report heel strikes that are non-finite, out of order or outside the time range.

    Parameters
    ----------
    side : str
        ``"right"`` or ``"left"``, used in the messages.
    strikes : ndarray, shape (S,)
        Heel-strike times [s].
    time : ndarray, shape (M,)
        Sample times of the trial.

    Returns
    -------
    list of str
        Problems found.
    """
    name = f"{side}_heel_strikes"
    if not np.all(np.isfinite(strikes)):
        return [f"{name} has {int((~np.isfinite(strikes)).sum())} NaN/infinite times"]
    problems = []
    not_after = np.diff(strikes) <= 0.0
    if not_after.any():
        i = int(np.argmax(not_after)) + 1
        problems.append(
            f"{name} are not strictly increasing: strike {i} ({strikes[i]:.6g} s) is not "
            f"after strike {i - 1} ({strikes[i - 1]:.6g} s)"
        )
    finite_time = time[np.isfinite(time)]
    if finite_time.size and strikes.size:
        start, end = float(finite_time.min()), float(finite_time.max())
        outside = (strikes < start) | (strikes > end)
        if outside.any():
            problems.append(
                f"{name} has {int(outside.sum())} strikes outside the time range "
                f"[{start:.6g}, {end:.6g}] s, first {strikes[outside][0]:.6g} s"
            )
    return problems


def metadata_problems(metadata: Any, columns: Sequence[str]) -> list[str]:
    """Report wrong units and non-positive physical constants in trial metadata.

    Parameters
    ----------
    metadata : mapping
        Trial metadata. ``units`` (optional) maps column names to unit strings; each
        canonical column listed must carry its canonical unit (see
        :data:`colloc.data.columns.COLUMN_UNITS`). ``sample_rate`` [Hz], ``body_mass`` [kg]
        and ``height`` [m], when present, must be positive numbers.
    columns : sequence of str
        Columns present in the trial, including the time column.

    Returns
    -------
    list of str
        Problems found.
    """
    if not isinstance(metadata, Mapping):
        return [f"metadata must be a mapping, found {type(metadata).__name__}"]
    problems = []
    for key in POSITIVE_METADATA_KEYS:
        if key not in metadata:
            continue
        value = metadata[key]
        if _positive_number(value) is None:
            problems.append(f"metadata {key!r} must be a positive number, found {value!r}")
    units = metadata.get("units", {})
    if not isinstance(units, Mapping):
        return problems + [
            f"metadata 'units' must map column names to units, found {type(units).__name__}"
        ]
    wrong = []
    for name in columns:
        if name not in units or name not in COLUMN_UNITS:
            continue
        given, expected = units[name], COLUMN_UNITS[name]
        if not isinstance(given, str) or normalize_unit(given) != normalize_unit(expected):
            wrong.append(f"{name!r}: expected {expected!r}, found {given!r}")
    if wrong:
        problems.append(
            "metadata 'units' disagree with the canonical units (convert the data): "
            + "; ".join(wrong)
        )
    return problems


def metadata_sample_rate(metadata: Any) -> float | None:
    """Return the metadata's ``sample_rate`` if it is a usable positive number, else None."""
    if not isinstance(metadata, Mapping):
        return None
    return _positive_number(metadata.get("sample_rate"))


def _positive_number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, Real):
        return None
    number = float(value)
    return number if math.isfinite(number) and number > 0.0 else None


#: No gait signal in SI units comes near this: larger values are corrupt (1e300) or in
#: the wrong units.
MAX_SIGNAL_MAGNITUDE = 1e6
#: A joint angle beyond a full turn in a column of radians is most likely in degrees.
MAX_ANGLE_RAD = 2 * math.pi
#: Below this rate (Hz) a time column without a stated sample rate is most likely not in
#: seconds (milliseconds give 0.1 Hz at 100 Hz).
MIN_PLAUSIBLE_RATE = 10.0


def plausibility_problems(
    time: np.ndarray,
    signals: pd.DataFrame,
    right: np.ndarray,
    left: np.ndarray,
    sample_rate: float | None,
) -> list[str]:
    """Report data that parse but cannot be a gait trial in the canonical units.

    Values beyond :data:`MAX_SIGNAL_MAGNITUDE`, joint angles beyond a full turn (degrees
    under a radian column), a time column stepping slower than :data:`MIN_PLAUSIBLE_RATE`
    when no sample rate is stated (milliseconds), and heel strikes on one side only or
    none at all.

    Parameters
    ----------
    time : ndarray, shape (M,)
    signals : DataFrame, M rows
    right, left : ndarray
        Heel-strike times of each side.
    sample_rate : float or None
        The metadata's stated rate, if any.

    Returns
    -------
    list of str
    """
    problems = []
    for name in signals.columns:
        values = pd.to_numeric(signals[name], errors="coerce").to_numpy(dtype=float)
        finite = values[np.isfinite(values)]
        if not finite.size:
            continue
        peak = float(np.max(np.abs(finite)))
        if peak > MAX_SIGNAL_MAGNITUDE:
            problems.append(
                f"column {name!r} reaches {peak:.3g}: not a physical signal in SI units"
            )
        elif name in JOINT_ANGLE_COLUMNS and peak > MAX_ANGLE_RAD:
            problems.append(
                f"column {name!r} is in radians but reaches {peak:.3g} (more than a full "
                "turn): degrees? convert to radians"
            )
    finite_time = time[np.isfinite(time)]
    if sample_rate is None and finite_time.size > 1:
        step = float(np.median(np.diff(finite_time)))
        if step > 1.0 / MIN_PLAUSIBLE_RATE:
            problems.append(
                f"column {TIME_COLUMN!r} steps by {step:.6g} (a rate of {1.0 / step:.3g} Hz): "
                "not seconds? (time must be in seconds; state sample_rate in the metadata)"
            )
    counts = {"right": np.asarray(right).size, "left": np.asarray(left).size}
    if not any(counts.values()):
        problems.append("no heel strikes: the events file lists none")
    elif not all(counts.values()):
        problems.append(
            f"heel strikes on one side only ({counts['right']} right, {counts['left']} left): "
            "check the events file's 'side' column"
        )
    return problems
