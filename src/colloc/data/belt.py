"""Treadmill belt speed records: reading, rescaling and integration to belt position."""

from __future__ import annotations

import os

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike
from scipy.integrate import cumulative_trapezoid

from colloc.data.text_tables import read_table

_TIME_HEADER = "Timestamp"
_VELOCITY_HEADER = "Belt Velocity"


def _column(frame: pd.DataFrame, prefix: str, path: str | os.PathLike[str]) -> np.ndarray:
    matches = [name for name in frame.columns if str(name).strip().startswith(prefix)]
    if len(matches) != 1:
        raise ValueError(
            f"path {os.fspath(path)!r}: expected one column whose header starts with "
            f"{prefix!r}, found columns {list(frame.columns)}"
        )
    return pd.to_numeric(frame[matches[0]], errors="coerce").to_numpy(dtype=float)


def read_belt_perturbation(path: str | os.PathLike[str]) -> tuple[np.ndarray, np.ndarray]:
    """Read a measured treadmill belt-velocity record.

    The format is that of the CSU R-Mill perturbation recordings (e.g.
    ``treadmill-belt-perturbation-unloaded/RandomSlowSpeed1.txt``): tab separated, one
    header line with ``Timestamp (s)`` and ``Belt Velocity (m/s)`` among the columns.

    Parameters
    ----------
    path : path-like
        The record file.

    Returns
    -------
    time : ndarray, shape (M,)
        Sample times [s].
    belt_velocity : ndarray, shape (M,)
        Belt velocity [m/s].

    Raises
    ------
    ValueError
        If the time or velocity column is missing, holds non-numeric values, or time is not
        strictly increasing.
    """
    frame = read_table(path)
    time = _column(frame, _TIME_HEADER, path)
    velocity = _column(frame, _VELOCITY_HEADER, path)
    problems = []
    for name, values in (("time", time), ("belt velocity", velocity)):
        if not np.all(np.isfinite(values)):
            first = int(np.argmax(~np.isfinite(values)))
            problems.append(
                f"{name} has {int((~np.isfinite(values)).sum())} missing/non-numeric values "
                f"(first in data row {first})"
            )
    if time.size < 2 or np.any(np.diff(time) <= 0.0):
        problems.append("time must be strictly increasing with at least 2 samples")
    if problems:
        raise ValueError(f"path {os.fspath(path)!r}: " + "; ".join(problems))
    return time, velocity


def rescale_belt_speed(
    velocity: ArrayLike, mean_speed: float, *, deviation_scale: float = 1.0
) -> np.ndarray:
    """Move a belt-speed record to a chosen mean speed.

    The record is shifted, not scaled: ``v_new = mean_speed + deviation_scale * (v - mean(v))``.
    With the default ``deviation_scale=1`` the perturbation keeps its size in m/s (its
    standard deviation is unchanged) and only the mean walking speed changes; pass
    ``deviation_scale = mean_speed / mean(v)`` to scale the perturbation with the speed
    instead (the coefficient of variation is then unchanged).

    Parameters
    ----------
    velocity : array_like, shape (M,)
        Belt speed [m/s].
    mean_speed : float
        Desired mean belt speed [m/s].
    deviation_scale : float
        Factor applied to the deviations from the mean.

    Returns
    -------
    ndarray, shape (M,)
        The rescaled belt speed [m/s].

    Raises
    ------
    ValueError
        If ``velocity`` is empty, not 1-D or not finite, or either number is not finite.
    """
    v = np.asarray(velocity, dtype=float)
    problems = []
    if v.ndim != 1 or v.size == 0:
        problems.append(f"velocity must be a non-empty 1-D array, found shape {v.shape}")
    elif not np.all(np.isfinite(v)):
        problems.append(f"velocity has {int((~np.isfinite(v)).sum())} NaN/infinite values")
    if not np.isfinite(mean_speed):
        problems.append(f"mean_speed must be finite, found {mean_speed}")
    if not np.isfinite(deviation_scale):
        problems.append(f"deviation_scale must be finite, found {deviation_scale}")
    if problems:
        raise ValueError("; ".join(problems))
    return mean_speed + deviation_scale * (v - v.mean())


def belt_position(time: ArrayLike, velocity: ArrayLike, initial: float = 0.0) -> np.ndarray:
    """Integrate belt speed to belt position with the cumulative trapezoidal rule.

    Parameters
    ----------
    time : array_like, shape (M,)
        Strictly increasing sample times [s]; uneven steps are fine.
    velocity : array_like, shape (M,)
        Belt speed [m/s].
    initial : float
        Belt position at ``time[0]`` [m].

    Returns
    -------
    ndarray, shape (M,)
        Belt position [m].

    Raises
    ------
    ValueError
        If the shapes differ, time is not strictly increasing, or values are not finite.
    """
    t = np.asarray(time, dtype=float)
    v = np.asarray(velocity, dtype=float)
    problems = []
    if t.ndim != 1 or t.size < 1:
        problems.append(f"time must be a non-empty 1-D array, found shape {t.shape}")
    if v.shape != t.shape:
        problems.append(f"velocity must have the shape of time {t.shape}, found {v.shape}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
        problems.append("time and velocity must be finite")
    elif t.ndim == 1 and np.any(np.diff(t) <= 0.0):
        problems.append("time must be strictly increasing")
    if problems:
        raise ValueError("; ".join(problems))
    return initial + cumulative_trapezoid(v, t, initial=0.0)


def perturbation_belt_speed(
    path: str | os.PathLike[str],
    mean_speed: float,
    duration: float,
    sample_rate: float = 100.0,
    *,
    deviation_scale: float = 1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """A measured belt-speed record moved to ``mean_speed`` and stretched to ``duration``.

    Beyond its end the record continues mirrored in time (played backward, then forward
    again, ...), which keeps the belt speed continuous where a plain loop would jump.

    Parameters
    ----------
    path : path-like
        Record readable by :func:`colloc.data.belt.read_belt_perturbation`.
    mean_speed : float
        Mean belt speed [m/s] (:func:`colloc.data.belt.rescale_belt_speed`).
    duration : float
        [s], > 0.
    sample_rate : float
        [Hz] of the returned samples.
    deviation_scale : float
        Factor on the record's deviations from its mean (1: as measured).

    Returns
    -------
    times, speed : ndarray
    """
    if not (np.isfinite(duration) and duration > 0):
        raise ValueError(f"duration: expected a positive number of seconds, found {duration!r}")
    t_rec, v_rec = read_belt_perturbation(path)
    v_rec = rescale_belt_speed(v_rec, mean_speed, deviation_scale=deviation_scale)
    times = np.arange(int(round(duration * sample_rate)) + 1) / sample_rate
    length = t_rec[-1] - t_rec[0]
    folded = np.mod(times, 2 * length)
    folded = np.where(folded > length, 2 * length - folded, folded) + t_rec[0]
    return times, np.interp(folded, t_rec, v_rec)
