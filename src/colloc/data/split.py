"""Split a gait trial into an identification (fit) part and a validation part."""

from __future__ import annotations

import copy

import numpy as np

from colloc.data.columns import SIDES
from colloc.data.tables import slice_tables
from colloc.data.trial import Trial

MIN_STRIDES = 2
"""Fewest complete strides (right heel strike to right heel strike) each part must keep."""


def _count_strides(right_heel_strikes: np.ndarray) -> int:
    return max(right_heel_strikes.size - 1, 0)


def split(trial: Trial, fit_fraction: float = 0.75) -> tuple[Trial, Trial]:
    """Split a trial in time: fit on the first part, validate on the rest.

    The first ``round(fit_fraction * M)`` samples form the fit part and the remaining
    samples the validation part (no sample is shared). Heel strikes go to the part whose
    time range contains them; a strike that falls strictly between the last fit sample
    and the first validation sample belongs to neither and is dropped. Both parts get a
    deep copy of the metadata with a ``split`` entry (``part``, ``fit_fraction``).

    Parameters
    ----------
    trial : Trial
        The trial to split.
    fit_fraction : float
        Fraction of the samples used for fitting, strictly between 0 and 1. The seed
        document uses 3/4 for identification and 1/4 for validation.

    Returns
    -------
    fit, validate : Trial
        The two parts.

    Raises
    ------
    ValueError
        If ``fit_fraction`` is not in (0, 1), or either part keeps fewer than
        :data:`MIN_STRIDES` complete strides (counted between right heel strikes).
    """
    if isinstance(fit_fraction, bool) or not isinstance(fit_fraction, int | float):
        raise TypeError(f"fit_fraction must be a number, found {type(fit_fraction).__name__}")
    if not 0.0 < fit_fraction < 1.0:
        raise ValueError(f"fit_fraction must lie strictly between 0 and 1, found {fit_fraction}")
    num_samples = trial.time.size
    num_fit = int(round(fit_fraction * num_samples))
    if not 2 <= num_fit <= num_samples - 2:
        raise ValueError(
            f"fit_fraction={fit_fraction} of {num_samples} samples leaves {num_fit} fit and "
            f"{num_samples - num_fit} validation samples; each part needs at least 2"
        )
    parts = []
    for part, rows in (("fit", np.arange(num_fit)), ("validate", np.arange(num_fit, num_samples))):
        piece = take_rows(trial, rows)
        piece.metadata["split"] = {"part": part, "fit_fraction": float(fit_fraction)}
        parts.append(piece)
    fit, validate = parts
    strides = {
        "fit": _count_strides(fit.right_heel_strikes),
        "validate": _count_strides(validate.right_heel_strikes),
    }
    if min(strides.values()) < MIN_STRIDES:
        # how long a record this fraction needs: MIN_STRIDES complete strides in the smaller
        # part, and up to one more lost between its ends and the nearest strikes
        total = strides["fit"] + strides["validate"]
        stride = float(np.median(np.diff(trial.right_heel_strikes))) if total else float("nan")
        share = min(fit_fraction, 1.0 - fit_fraction)
        needed = (MIN_STRIDES + 1) / share * stride
        raise ValueError(
            f"fit_fraction={fit_fraction} leaves {strides['fit']} complete strides in the fit "
            f"part and {strides['validate']} in the validation part; each needs at least "
            f"{MIN_STRIDES} (strides counted between right heel strikes): a trial of about "
            f"{needed:.0f} s or longer at this trial's stride of {stride:.2f} s, or another "
            f"fit fraction"
        )
    return fit, validate


def take_rows(trial: Trial, rows: np.ndarray) -> Trial:
    """Consecutive samples of a trial as a trial of its own.

    Parameters
    ----------
    trial : Trial
    rows : ndarray of int
        Consecutive sample indices (at least two).

    Returns
    -------
    Trial
        Its times and signals, the heel strikes inside its time range, a deep copy of the
        metadata, and the rows of its tables (markers, plates) within half a sample of its
        time range.
    """
    rows = np.asarray(rows)
    time = trial.time[rows]
    strikes = {}
    for side in SIDES:
        all_strikes = getattr(trial, f"{side}_heel_strikes")
        strikes[side] = all_strikes[(all_strikes >= time[0]) & (all_strikes <= time[-1])]
    signals = trial.signals.iloc[rows].reset_index(drop=True)
    step = float(np.median(np.diff(trial.time))) if trial.time.size > 1 else 0.0
    tables = slice_tables(trial.tables, float(time[0]), float(time[-1]), 0.5 * step)
    return Trial(
        time, signals, strikes["right"], strikes["left"], copy.deepcopy(trial.metadata), tables
    )


def stride_windows(
    times: np.ndarray, right_heel_strikes: np.ndarray, strides_per_window: int
) -> list[tuple[int, int]]:
    """Cut a record into windows of whole strides, each from one right heel strike.

    Windows are consecutive and disjoint and together hold every sample: the record's
    ``S`` whole strides are shared out over ``S // strides_per_window`` windows as evenly as
    whole strides allow (each holds ``strides_per_window`` to ``2 strides_per_window - 1``
    of them), each window from the sample at a right heel strike to the sample before the
    next window's; samples before the first strike join the first window, those after the
    last the last.

    Parameters
    ----------
    times : ndarray, shape (N,)
        Increasing sample times.
    right_heel_strikes : ndarray
        Times of right heel strikes [s]; those outside ``times`` are ignored.
    strides_per_window : int
        Whole strides per window, >= 1.

    Returns
    -------
    list of (first, stop)
        Sample ranges ``times[first:stop]``; one window covering all when the record has
        fewer than ``2 * strides_per_window`` strides.

    Raises
    ------
    ValueError
        If ``strides_per_window`` is not a whole number >= 1 or ``times`` is not increasing.
    """
    if (
        isinstance(strides_per_window, bool)
        or not isinstance(strides_per_window, int | np.integer)
        or strides_per_window < 1
    ):
        raise ValueError(
            f"strides_per_window: expected a whole number >= 1, found {strides_per_window!r}"
        )
    times = np.asarray(times, dtype=float)
    if times.ndim != 1 or times.size < 2 or np.any(np.diff(times) <= 0):
        raise ValueError("times: expected at least two increasing sample times")
    strikes = np.asarray(right_heel_strikes, dtype=float)
    strikes = strikes[(strikes >= times[0]) & (strikes <= times[-1])]
    # the sample at or just after each strike
    starts = np.unique(np.searchsorted(times, strikes - 1e-9 * (times[1] - times[0])))
    strides = starts.size - 1
    count = max(strides // strides_per_window, 1)
    # the strides shared out as evenly as whole strides allow (windows of equal work are
    # what two workers finish together)
    cuts = starts[np.round(np.arange(1, count) * strides / count).astype(int)]
    bounds = [0, *map(int, cuts), times.size]
    return [(bounds[k], bounds[k + 1]) for k in range(len(bounds) - 1)]
