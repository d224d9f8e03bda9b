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


def causal_gait_phase(
    time: ArrayLike,
    heel_strikes: ArrayLike,
    stride_duration: float,
    phase_at_strike: float = 0.0,
) -> np.ndarray:
    """The phase a real-time controller can know: reset at each heel strike, then rising at a
    fixed stride rate and holding at the stride's end until the next strike comes.

    A phase linear between heel strikes (:func:`unwrapped_gait_phase`) needs the time of the
    next strike, which a controller walking now cannot have. This one needs only the strikes
    so far: during stride ``k`` (from strike ``k``) it is
    ``k + min(phi_0 + (t - t_k) / D, 1 + phi_0)``, in cycles, never decreasing.

    Parameters
    ----------
    time : array_like
        Sample times.
    heel_strikes : array_like
        Increasing heel-strike times of the reference foot.
    stride_duration : float
        ``D``, seconds per cycle of phase (the nominal stride).
    phase_at_strike : float, optional
        ``phi_0`` in ``[0, 1)``: the phase a strike resets to (the schedule's origin).

    Returns
    -------
    ndarray
        NaN before the first strike.

    Raises
    ------
    ValueError
        When the strikes are fewer than one or not increasing, ``stride_duration`` is not a
        positive finite number or ``phase_at_strike`` is outside ``[0, 1)``.
    """
    t = np.asarray(time, dtype=float)
    hs = np.asarray(heel_strikes, dtype=float)
    problems = []
    if hs.ndim != 1 or hs.size < 1 or np.any(np.diff(hs) <= 0) or not np.all(np.isfinite(hs)):
        problems.append(
            f"heel_strikes: expected at least one strictly increasing time, found {hs.size}"
        )
    if not (isinstance(stride_duration, int | float) and 0 < stride_duration < np.inf):
        problems.append(f"stride_duration: expected seconds > 0, found {stride_duration!r}")
    if not (isinstance(phase_at_strike, int | float) and 0 <= phase_at_strike < 1):
        problems.append(f"phase_at_strike: expected a number in [0, 1), found {phase_at_strike!r}")
    if problems:
        raise ValueError("; ".join(problems))
    k = np.searchsorted(hs, t, side="right") - 1
    since = t - hs[np.clip(k, 0, None)]
    phase = k + np.minimum(phase_at_strike + since / stride_duration, 1.0 + phase_at_strike)
    return np.where(k < 0, np.nan, phase)


def phase_normalised(
    time: ArrayLike, values: ArrayLike, heel_strikes: ArrayLike, points: int = 51
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each complete stride resampled on a common gait-cycle phase; their mean and spread.

    The usual time normalisation of gait (0-100 % of the cycle): the samples of stride ``k``
    (from strike ``k`` to strike ``k + 1``) are interpolated linearly at the phases
    ``0, 1/(points-1), ..., 1``. Two walks compared on these mean cycles differ only in the
    shape of their strides, not in a drift of phase between them.

    Parameters
    ----------
    time : array_like, shape (N,)
        Increasing sample times [s].
    values : array_like, shape (N,) or (N, m)
        The signals.
    heel_strikes : array_like
        Increasing heel-strike times [s] of the reference foot; strides that the samples do
        not cover wholly are left out.
    points : int
        Phase points per cycle, at least 2.

    Returns
    -------
    phase : ndarray, shape (points,)
    cycles : ndarray, shape (S, points, m)
        Each complete stride on the phase grid (``S`` may be 0).
    mean : ndarray, shape (points, m)
        Their mean, NaN when ``S`` is 0.

    Raises
    ------
    ValueError
        When the shapes disagree, ``time`` does not increase or ``points`` is below 2.
    """
    t = np.asarray(time, dtype=float)
    x = np.asarray(values, dtype=float)
    x = x[:, None] if x.ndim == 1 else x
    hs = np.asarray(heel_strikes, dtype=float).ravel()
    problems = []
    if t.ndim != 1 or x.ndim != 2 or x.shape[0] != t.size:
        problems.append(
            f"time, values: expected shapes (N,) and (N, m), found {t.shape} and {x.shape}"
        )
    elif t.size and np.any(np.diff(t) <= 0):
        problems.append("time: expected strictly increasing sample times")
    if not (isinstance(points, int | np.integer) and points >= 2):
        problems.append(f"points: expected an integer >= 2, found {points!r}")
    if problems:
        raise ValueError("; ".join(problems))
    phase = np.linspace(0.0, 1.0, int(points))
    strides = [
        (a, b)
        for a, b in zip(hs[:-1], hs[1:], strict=True)
        if t.size and b > a and a >= t[0] and b <= t[-1]
    ]
    cycles = np.empty((len(strides), phase.size, x.shape[1]))
    for k, (a, b) in enumerate(strides):
        at = a + phase * (b - a)
        cycles[k] = np.column_stack([np.interp(at, t, column) for column in x.T])
    mean = cycles.mean(axis=0) if strides else np.full((phase.size, x.shape[1]), np.nan)
    return phase, cycles, mean
