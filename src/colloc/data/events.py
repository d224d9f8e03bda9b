"""Gait events from force-plate signals."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from colloc.data.filtering import zero_lag_lowpass

DEFAULT_MIN_INTERVAL = 0.4
"""Default de-bounce interval [s]: shorter than any walking or running stride of one foot."""

_FILTER_ORDER = 2


def _validated(time: ArrayLike, vertical_force: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(time, dtype=float)
    f = np.asarray(vertical_force, dtype=float)
    problems = []
    if t.ndim != 1 or t.size < 2:
        problems.append(f"time must be 1-D with at least 2 samples, found shape {t.shape}")
    if f.shape != t.shape:
        problems.append(f"vertical_force must have the shape of time {t.shape}, found {f.shape}")
    if t.ndim == 1 and not np.all(np.isfinite(t)):
        problems.append(f"time has {int((~np.isfinite(t)).sum())} NaN/infinite values")
    elif t.ndim == 1 and t.size >= 2 and np.any(np.diff(t) <= 0.0):
        first = int(np.argmax(np.diff(t) <= 0.0)) + 1
        problems.append(f"time must be strictly increasing; sample {first} is not ({t[first]} s)")
    if f.ndim == 1 and not np.all(np.isfinite(f)):
        first = int(np.argmax(~np.isfinite(f)))
        problems.append(
            f"vertical_force has {int((~np.isfinite(f)).sum())} NaN/infinite values "
            f"(first at sample {first}); fill the gaps first"
        )
    if problems:
        raise ValueError("; ".join(problems))
    return t, f


def lowpass(time: np.ndarray, signal: np.ndarray, cutoff_hz: float) -> np.ndarray:
    """Zero-lag low-pass filter a signal with a 2nd-order Butterworth filter, each pass at
    ``cutoff_hz`` (:func:`colloc.data.filtering.zero_lag_lowpass` with ``per_pass``).

    Gait-lab clocks jitter, so the signal is first interpolated onto a uniform grid with
    the same number of samples and span, filtered there, and interpolated back.

    Parameters
    ----------
    time : ndarray, shape (M,)
        Strictly increasing sample times [s].
    signal : ndarray, shape (M,)
        Samples.
    cutoff_hz : float
        Cut-off frequency [Hz], positive and below the Nyquist frequency.

    Returns
    -------
    ndarray, shape (M,)
        The filtered signal at ``time``.
    """
    grid = np.linspace(time[0], time[-1], time.size)
    sample_rate = (time.size - 1) / (time[-1] - time[0])
    nyquist = 0.5 * sample_rate
    if not 0.0 < cutoff_hz < nyquist:
        raise ValueError(
            f"cutoff_hz (lowpass_hz) must lie strictly between 0 and the Nyquist frequency "
            f"{nyquist:.6g} Hz, found {cutoff_hz}"
        )
    filtered = zero_lag_lowpass(
        np.interp(grid, time, signal), sample_rate, cutoff_hz, _FILTER_ORDER, per_pass=True
    )
    return np.interp(time, grid, filtered)


def detect_heel_strikes(
    time: ArrayLike,
    vertical_force: ArrayLike,
    threshold: float = 25.0,
    lowpass_hz: float | None = None,
    min_interval: float = DEFAULT_MIN_INTERVAL,
) -> np.ndarray:
    """Detect heel strikes as upward crossings of a vertical-force threshold.

    A heel strike is where the (optionally low-passed) vertical ground reaction force of
    one foot rises through ``threshold``; its time is interpolated linearly between the two
    samples that bracket the crossing. A crossing closer than ``min_interval`` to the
    previously accepted one is taken as noise chatter and dropped. A record that starts
    in stance yields no strike for that stance.

    Parameters
    ----------
    time : array_like, shape (M,)
        Strictly increasing sample times [s]; uneven steps are fine.
    vertical_force : array_like, shape (M,)
        Vertical ground reaction force of one foot [N].
    threshold : float
        Force threshold [N].
    lowpass_hz : float, optional
        If given, cut-off [Hz] of a 2nd-order zero-lag Butterworth low-pass applied first
        (see :func:`lowpass`).
    min_interval : float
        Minimum time [s] between two accepted heel strikes.

    Returns
    -------
    ndarray, shape (S,)
        Heel-strike times [s], increasing.

    Raises
    ------
    ValueError
        On mismatched shapes, non-finite samples, non-increasing time, a non-finite
        threshold, a negative ``min_interval`` or a cut-off outside (0, Nyquist).
    """
    t, f = _validated(time, vertical_force)
    if not np.isfinite(threshold):
        raise ValueError(f"threshold must be a finite force [N], found {threshold}")
    if not min_interval >= 0.0:
        raise ValueError(f"min_interval must be a non-negative time [s], found {min_interval}")
    if lowpass_hz is not None:
        f = lowpass(t, f, lowpass_hz)
    rising = np.nonzero((f[:-1] < threshold) & (f[1:] >= threshold))[0]
    fraction = (threshold - f[rising]) / (f[rising + 1] - f[rising])
    crossings = t[rising] + fraction * (t[rising + 1] - t[rising])
    accepted: list[float] = []
    for crossing in crossings:
        if not accepted or crossing - accepted[-1] >= min_interval:
            accepted.append(float(crossing))
    return np.asarray(accepted, dtype=float)
