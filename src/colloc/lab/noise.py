"""Noise levels a lab record shows of itself: robust spreads that impacts do not inflate."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from colloc.gait.strikes import UNLOADED_FORCE

#: The standard deviation of a Gaussian per median absolute deviation.
MAD_TO_SD = 1.4826
#: Most the noise read from second differences and the one read from fourth ones may differ,
#: as a ratio either way, for both to be white noise (their robust estimates agree to a few
#: per cent on 600 or more samples; a skin export's 100 Hz moments under load read 18
#: against 11 N m, and content near the Nyquist rate reads higher in the fourth).
WHITE_NOISE_ORDER_RATIO = 1.2


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
        Zero when nothing varies, or when read under load the second and fourth
        differences disagree (:data:`WHITE_NOISE_ORDER_RATIO`): the moment's own motion,
        not white noise (a caller then uses its default).
    """
    second, fourth = [], []
    under_load = False
    for values, load in series:
        values = np.asarray(values, dtype=float)
        recorded = values != 0.0
        rows = recorded[:-2] & recorded[1:-1] & recorded[2:]
        unloaded = (np.asarray(load) < UNLOADED_FORCE)[1:-1]
        off = (rows & unloaded).sum() >= 10
        chosen = rows & unloaded if off else rows & ~unloaded
        under_load |= not off
        second.append(np.diff(values, 2)[chosen])
        # the fourth differences centred on the same samples (variance 70 sigma^2)
        inner = chosen[1:-1] & recorded[:-4] & recorded[4:]
        fourth.append(np.diff(values, 4)[inner])
    found = np.concatenate(second) if second else np.empty(0)
    if not found.size:
        return 0.0
    sigma = robust_sd(found) / np.sqrt(6.0)
    if under_load:
        # white noise shows the same spread at every order of differences; a moment whose
        # own motion under load passes for noise (100 Hz plates: heel-to-toe transfer and
        # contact ringing) shows another. Then it cannot be read here.
        higher = np.concatenate(fourth)
        if higher.size:
            ratio = sigma / max(robust_sd(higher) / np.sqrt(70.0), 1e-300)
            if not 1.0 / WHITE_NOISE_ORDER_RATIO <= ratio <= WHITE_NOISE_ORDER_RATIO:
                return 0.0
    return sigma
