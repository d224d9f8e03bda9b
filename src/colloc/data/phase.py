"""Gait phase from heel-strike times."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def gait_phase(
    time: ArrayLike, heel_strikes: ArrayLike, *, extrapolate: bool = False
) -> np.ndarray:
    """Return the gait phase φ in [0, 1) at each time.

    φ is 0 at a heel strike and rises linearly to 1 at the next one (where it wraps to 0):
    for ``s[k] <= t < s[k+1]``, ``φ = (t - s[k]) / (s[k+1] - s[k])``. At the last strike
    φ = 0. Pass right heel strikes for the usual right-leg gait cycle.

    Outside ``[s[0], s[-1]]`` the stride in progress is unknown, so φ is NaN by default.
    With ``extrapolate=True`` the nearest complete stride's duration is assumed instead:
    ``φ = ((t - s[0]) / (s[1] - s[0])) mod 1`` before the first strike and
    ``φ = ((t - s[-1]) / (s[-1] - s[-2])) mod 1`` after the last.

    Parameters
    ----------
    time : array_like
        Times [s], any shape, finite.
    heel_strikes : array_like, shape (S,)
        Heel-strike times [s] of one foot, strictly increasing, at least 2.
    extrapolate : bool
        Extrapolate outside the first and last strike instead of returning NaN.

    Returns
    -------
    ndarray
        Gait phase, same shape as ``time``.

    Raises
    ------
    ValueError
        If ``heel_strikes`` is not 1-D, has fewer than 2 entries, is not strictly
        increasing or not finite, or ``time`` is not finite.
    """
    t = np.asarray(time, dtype=float)
    strikes = np.asarray(heel_strikes, dtype=float)
    problems = []
    if strikes.ndim != 1 or strikes.size < 2:
        problems.append(
            f"heel_strikes must be 1-D with at least 2 strikes, found shape {strikes.shape}"
        )
    elif not np.all(np.isfinite(strikes)):
        problems.append(f"heel_strikes has {int((~np.isfinite(strikes)).sum())} NaN/inf values")
    elif np.any(np.diff(strikes) <= 0.0):
        i = int(np.argmax(np.diff(strikes) <= 0.0)) + 1
        problems.append(
            f"heel_strikes must be strictly increasing; strike {i} ({strikes[i]} s) is not "
            f"after strike {i - 1} ({strikes[i - 1]} s)"
        )
    if not np.all(np.isfinite(t)):
        problems.append(f"time has {int((~np.isfinite(t)).sum())} NaN/infinite values")
    if problems:
        raise ValueError("; ".join(problems))

    # Index of the stride in progress, clipped so that both ends have a neighbour stride.
    k = np.clip(np.searchsorted(strikes, t, side="right") - 1, 0, strikes.size - 2)
    phase = (t - strikes[k]) / (strikes[k + 1] - strikes[k])
    phase = np.where(t == strikes[-1], 0.0, phase)
    before, after = t < strikes[0], t > strikes[-1]
    if extrapolate:
        last_stride = strikes[-1] - strikes[-2]
        phase = np.where(before, np.mod(phase, 1.0), phase)
        phase = np.where(after, np.mod((t - strikes[-1]) / last_stride, 1.0), phase)
    else:
        phase = np.where(before | after, np.nan, phase)
    return phase


def unwrapped_gait_phase(time: ArrayLike, heel_strikes: ArrayLike) -> np.ndarray:
    """Gait phase in cycles that keeps counting: ``k + phi`` during stride ``k``.

    This is the form scheduled controllers take (see :class:`colloc.GainScheduled`): it is
    non-decreasing, so it can be interpolated between samples without wrapping artefacts.
    Outside the first and last heel strike the result is NaN.

    Parameters
    ----------
    time : array_like
        Sample times.
    heel_strikes : array_like
        Increasing heel-strike times of the reference foot.

    Returns
    -------
    ndarray
        0 at the first strike, 1 at the second, ... linear in between.
    """
    t = np.asarray(time, dtype=float)
    hs = np.asarray(heel_strikes, dtype=float)
    if hs.ndim != 1 or hs.size < 2 or np.any(np.diff(hs) <= 0):
        raise ValueError(
            "heel_strikes: expected at least two strictly increasing times, "
            f"found {hs.size} value(s)"
        )
    out = np.interp(t, hs, np.arange(hs.size, dtype=float))
    out[(t < hs[0]) | (t > hs[-1])] = np.nan
    return out
