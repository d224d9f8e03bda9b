"""Noise levels a lab record shows of itself: robust spreads that impacts do not inflate."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from colloc.gait.strikes import UNLOADED_FORCE

#: The standard deviation of a Gaussian per median absolute deviation.
MAD_TO_SD = 1.4826


def robust_sd(residual: np.ndarray) -> float:
    """1.4826 times the median absolute deviation of the finite values of ``residual``."""
    residual = residual[np.isfinite(residual)]
    return float(MAD_TO_SD * np.median(np.abs(residual - np.median(residual))))


def off_plate_noise(series: Sequence[tuple[np.ndarray, np.ndarray]]) -> float:
    """A plate signal's white noise, from the second differences of its samples while the
    foot is off the plate (variance ``6 sigma^2``; the impacts and a filter's ringing after
    them are not noise), over every ``(values, vertical_load)`` pair given (one per foot).
    A foot off its plate for fewer than 10 samples counts all its samples.

    Parameters
    ----------
    series : sequence of (ndarray (N,) or (N, k), ndarray (N,))
        The signal's samples and the vertical load that says when the foot is off.

    Returns
    -------
    float
        Zero when nothing varies.
    """
    differences = []
    for values, load in series:
        unloaded = (np.asarray(load) < UNLOADED_FORCE)[1:-1]
        rows = unloaded if unloaded.sum() >= 10 else np.ones(unloaded.size, bool)
        differences.append(np.diff(values, 2, axis=0)[rows].ravel())
    return robust_sd(np.concatenate(differences)) / np.sqrt(6.0)


def moment_noise(series: Sequence[tuple[np.ndarray, np.ndarray]]) -> float:
    """A plate moment's white noise, from the second differences of its samples where it is
    recorded (three consecutive samples not exactly zero): while the foot is off the plate
    when there are at least 10 such samples, else while it is loaded. A moment made from a
    centre of pressure (OpenSim's MOT, a C3D) is exactly zero off the plate, where no centre
    exists: read there, the noise came out 0.43 N m on a synthetic walk whose moments carry
    1 N m; read under load, where the centre of pressure moves slowly beside the noise,
    1.00 N m. Plates filtered before export carry no white noise to read at all (OpenSim's
    example MOT: 0.02 N m here, its forces exactly zero off the plate):
    :func:`colloc.lab.raw_tables.plate_noise` does not read a moment's noise where the forces
    show none.

    Parameters
    ----------
    series : sequence of (ndarray (N,), ndarray (N,))
        Per foot, the moment's samples and the vertical load.

    Returns
    -------
    float
        Zero when nothing varies.
    """
    differences = []
    for values, load in series:
        values = np.asarray(values, dtype=float)
        recorded = values != 0.0
        rows = recorded[:-2] & recorded[1:-1] & recorded[2:]
        unloaded = (np.asarray(load) < UNLOADED_FORCE)[1:-1]
        chosen = rows & unloaded if (rows & unloaded).sum() >= 10 else rows & ~unloaded
        differences.append(np.diff(values, 2)[chosen])
    found = np.concatenate(differences) if differences else np.empty(0)
    return robust_sd(found) / np.sqrt(6.0) if found.size else 0.0
