"""Validation metrics shared by the identification studies: variance accounted for, RMS."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def variance_accounted_for(measured: ArrayLike, predicted: ArrayLike) -> np.ndarray:
    """``VAF = 1 - var(measured - predicted) / var(measured)`` per column.

    Parameters
    ----------
    measured, predicted : array_like, shape (N,) or (N, k)
        Samples in rows.

    Returns
    -------
    ndarray, shape () or (k,)
        1 for a perfect prediction, 0 for one no better than the mean, negative when worse;
        NaN for a column that does not vary.

    Raises
    ------
    ValueError
        When the shapes differ, there are fewer than 2 samples, or a value is not finite.
    """
    y, p = np.asarray(measured, dtype=float), np.asarray(predicted, dtype=float)
    if y.shape != p.shape or y.ndim not in (1, 2) or y.shape[0] < 2:
        raise ValueError(
            f"measured, predicted: expected equal shapes (N,) or (N, k) with N >= 2, found "
            f"{y.shape} and {p.shape}"
        )
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(p))):
        raise ValueError("measured, predicted: expected finite values, found NaN or inf")
    total = np.var(y, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(total > 0, 1.0 - np.var(y - p, axis=0) / total, np.nan)


def rms(values: ArrayLike) -> np.ndarray:
    """Root mean square per column of ``values`` (shape (N,) or (N, k))."""
    v = np.asarray(values, dtype=float)
    return np.sqrt(np.mean(v**2, axis=0))
