"""Gait figures: joint angles normalised to the gait cycle, and contact forces over time."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from colloc.plot.common import as_columns, as_times, check_names, new_figure, raise_if_any

#: Samples per normalised stride (0, 1, ..., 100 % of the gait cycle).
DEFAULT_CYCLE_SAMPLES = 101


def _strike_problems(strikes: np.ndarray, time: np.ndarray, name: str) -> list[str]:
    if strikes.ndim != 1:
        return [f"{name}: expected a 1-D array of times, found shape {strikes.shape}"]
    if not np.all(np.isfinite(strikes)):
        return [f"{name}: expected finite times, found NaN or infinity"]
    if np.any(np.diff(strikes) <= 0):
        return [f"{name}: expected strictly increasing times"]
    if time.size and np.count_nonzero((strikes >= time[0]) & (strikes <= time[-1])) < 2:
        return [
            f"{name}: expected at least 2 heel strikes within the time range "
            f"[{time[0]:.6g}, {time[-1]:.6g}] s (one complete stride), found "
            f"{np.count_nonzero((strikes >= time[0]) & (strikes <= time[-1]))}"
        ]
    return []


def strides_by_cycle(
    time: Any, values: Any, heel_strikes: Any, num_samples: int = DEFAULT_CYCLE_SAMPLES
) -> tuple[np.ndarray, np.ndarray]:
    """Cut signals into strides and resample each stride to 0–100 % of the gait cycle.

    Stride ``k`` runs from heel strike ``s[k]`` to ``s[k+1]``; it is sampled at
    ``s[k] + (s[k+1] - s[k]) * c / 100`` for ``c = linspace(0, 100, num_samples)`` by
    linear interpolation. Only strides lying entirely inside ``[time[0], time[-1]]`` count.

    Parameters
    ----------
    time : array_like, shape (N,)
        Increasing sample times [s].
    values : array_like, shape (N,) or (N, k)
        Signals, one row per sample.
    heel_strikes : array_like, shape (S,)
        Strictly increasing heel-strike times [s] of the foot that defines the cycle.
    num_samples : int
        Samples per stride, >= 2.

    Returns
    -------
    percent : ndarray, shape (num_samples,)
        0 .. 100.
    strides : ndarray, shape (num_strides, num_samples, k)

    Raises
    ------
    PlotInputError
        If shapes disagree, times do not increase, or fewer than two heel strikes lie in
        the time range (all problems listed).
    """
    problems: list[str] = []
    t = as_times(time, problems, "time")
    y = as_columns(values, t.size, problems, "values", "len(time)")
    if t.size and np.any(np.diff(t) <= 0):
        problems.append("time: expected strictly increasing values")
    strikes = np.asarray(heel_strikes, dtype=float)
    problems += _strike_problems(strikes, t, "heel_strikes")
    if isinstance(num_samples, bool) or not isinstance(num_samples, int) or num_samples < 2:
        problems.append(f"num_samples: expected an int >= 2, found {num_samples!r}")
    raise_if_any(problems)
    inside = strikes[(strikes >= t[0]) & (strikes <= t[-1])]
    fraction = np.linspace(0.0, 1.0, num_samples)
    sample_times = inside[:-1, None] + np.diff(inside)[:, None] * fraction
    strides = np.stack([np.interp(sample_times, t, column) for column in y.T], axis=-1)
    return 100.0 * fraction, strides


def _per_column_strikes(heel_strikes: Any, count: int) -> list[Any]:
    """One strike array per column: a list of ``count`` arrays, or one array shared by all."""
    if (
        isinstance(heel_strikes, list | tuple)
        and len(heel_strikes) > 0
        and all(np.ndim(entry) == 1 for entry in heel_strikes)
    ):
        return list(heel_strikes)
    return [heel_strikes] * count


def plot_joint_angles_by_cycle(
    time: Any,
    angles: Any,
    heel_strikes: Any,
    names: Sequence[str],
    *,
    in_degrees: bool = True,
    num_samples: int = DEFAULT_CYCLE_SAMPLES,
    ncols: int = 2,
) -> Figure:
    """Plot each joint angle against percent gait cycle: mean over strides ± one sd.

    Parameters
    ----------
    time : array_like, shape (N,)
        Increasing sample times [s].
    angles : array_like, shape (N, k)
        Joint angles [rad], one column per joint.
    heel_strikes : array_like or sequence of array_like
        Heel-strike times [s] defining the cycle: one array shared by every column, or a
        list of ``k`` arrays (e.g. right strikes for right joints, left for left).
    names : sequence of str
        One label per column.
    in_degrees : bool
        Show degrees (the gait-lab habit) instead of radians.
    num_samples : int
        Samples per normalised stride.
    ncols : int
        Columns of the axes grid, filled column by column (so six joints ordered right
        hip, knee, ankle, left hip, knee, ankle give the right leg on the left).

    Returns
    -------
    Figure
        One axis per joint; on each, ``lines[0]`` is the mean (x = percent of the cycle),
        ``collections[0]`` the mean ± sd band (sample sd over strides; no band for a single
        stride). The title of each axis gives the stride count.

    Raises
    ------
    PlotInputError
        If shapes disagree, a strike list is unusable, or ``names`` does not match
        (all problems listed).
    """
    problems: list[str] = []
    t = as_times(time, problems, "time")
    y = as_columns(angles, t.size, problems, "angles", "len(time)")
    k = y.shape[1]
    labels = check_names(names, k, problems)
    if isinstance(ncols, bool) or not isinstance(ncols, int) or ncols < 1:
        problems.append(f"ncols: expected a positive int, found {ncols!r}")
    per_column = _per_column_strikes(heel_strikes, k)
    if len(per_column) != k:
        problems.append(
            f"heel_strikes: expected one array or a list of {k} arrays (one per column), "
            f"found a list of {len(per_column)}"
        )
    else:
        for j, strikes in enumerate(per_column):
            name = "heel_strikes" if per_column[0] is heel_strikes else f"heel_strikes[{j}]"
            found = _strike_problems(np.asarray(strikes, dtype=float), t, name)
            problems += [p for p in found if p not in problems]
    raise_if_any(problems)
    scale = 180.0 / math.pi if in_degrees else 1.0
    nrows = max(1, math.ceil(k / ncols))
    figure = Figure(figsize=(4.0 * ncols, 0.6 + 2.2 * nrows), layout="constrained")
    grid = figure.subplots(nrows, ncols, sharex=True, squeeze=False)
    for j in range(nrows * ncols):
        row, col = j % nrows, j // nrows
        axis = grid[row, col]
        if j >= k:
            axis.set_visible(False)
            continue
        percent, strides = strides_by_cycle(t, y[:, j], per_column[j], num_samples)
        values = scale * strides[:, :, 0]
        mean = values.mean(axis=0)
        axis.plot(percent, mean, color="C0", linewidth=1.5, label="mean")
        if values.shape[0] > 1:
            sd = values.std(axis=0, ddof=1)
            axis.fill_between(percent, mean - sd, mean + sd, color="C0", alpha=0.3, label="± sd")
        axis.set_title(f"{labels[j]} ({values.shape[0]} strides)", fontsize="medium")
        axis.set_ylabel("deg" if in_degrees else "rad")
        if row == nrows - 1 or j + 1 == k:
            axis.set_xlabel("gait cycle [%]")
        axis.set_xlim(0.0, 100.0)
        axis.grid(True, alpha=0.3)
    return figure


def plot_contact_forces(
    time: Any,
    forces: Any,
    names: Sequence[str],
    *,
    per_axis: int = 2,
    window: tuple[float, float] | None = None,
) -> Figure:
    """Plot contact forces against time, ``per_axis`` columns on each axis.

    Parameters
    ----------
    time : array_like, shape (N,)
        Sample times [s].
    forces : array_like, shape (N, k)
        Forces [N], e.g. ``Fx, Fy`` of right heel, right toe, left heel, left toe (k = 8).
    names : sequence of str
        One label per column.
    per_axis : int
        Columns drawn on one axis (2: the ``Fx, Fy`` pair of one contact point).
    window : (float, float), optional
        Only the samples with ``window[0] <= time <= window[1]`` (long trials are
        unreadable in full).

    Returns
    -------
    Figure
        ``ceil(k / per_axis)`` stacked axes; axis ``i`` holds columns
        ``i * per_axis ...`` as ``lines`` in order.

    Raises
    ------
    PlotInputError
        If shapes or names disagree, ``per_axis`` is not a positive int, or the window is
        empty (all problems listed).
    """
    problems: list[str] = []
    t = as_times(time, problems, "time")
    f = as_columns(forces, t.size, problems, "forces", "len(time)")
    labels = check_names(names, f.shape[1], problems)
    if isinstance(per_axis, bool) or not isinstance(per_axis, int) or per_axis < 1:
        problems.append(f"per_axis: expected a positive int, found {per_axis!r}")
        per_axis = 1
    keep = np.ones(t.size, dtype=bool)
    if window is not None:
        if np.shape(window) != (2,) or not window[0] < window[1]:
            problems.append(f"window: expected (start, end) with start < end, found {window!r}")
        else:
            keep = (t >= window[0]) & (t <= window[1])
            if t.size and not keep.any():
                problems.append(
                    f"window: no samples in {window!r}; time spans [{t[0]:.6g}, {t[-1]:.6g}] s"
                )
    if f.shape[1] == 0 and not problems:
        problems.append("forces: expected at least one column, found none")
    raise_if_any(problems)
    num_axes = math.ceil(f.shape[1] / per_axis)
    figure = new_figure(num_axes, height_per_axis=1.6)
    for i, axis in enumerate(figure.axes):
        for j in range(i * per_axis, min((i + 1) * per_axis, f.shape[1])):
            axis.plot(t[keep], f[keep, j], label=labels[j], linewidth=1.0)
        axis.set_ylabel("N")
        axis.legend(loc="upper right", fontsize="small")
        axis.grid(True, alpha=0.3)
    figure.axes[-1].set_xlabel("time [s]")
    return figure
