"""Figures of the pendulum identification study.

Time series are given as one row per time sample (shape ``(N,)`` or ``(N, k)``), the
layout of :meth:`pandas.DataFrame.to_numpy` and of the stored run arrays.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from colloc.plot.common import (
    PlotInputError,
    as_columns,
    as_times,
    check_names,
    new_figure,
    raise_if_any,
)

TIME_LABEL = "time [s]"


def _stacked(times: np.ndarray, columns: np.ndarray, names: list[str], title: str) -> Figure:
    figure = new_figure(columns.shape[1])
    for axis, column, label in zip(figure.axes, columns.T, names, strict=True):
        axis.plot(times, column, linewidth=1.0)
        axis.set_ylabel(label)
        axis.grid(True, alpha=0.3)
    figure.axes[-1].set_xlabel(TIME_LABEL)
    figure.suptitle(title)
    return figure


def plot_force(times: Any, force: Any, name: str = "F") -> Figure:
    """Plot the force applied to the cart over time.

    Parameters
    ----------
    times : array_like, shape (N,)
        Sample times in seconds.
    force : array_like, shape (N,) or (N, 1)
        The applied force.
    name : str, optional
        Axis label.

    Returns
    -------
    matplotlib.figure.Figure
        One axis with one line.

    Raises
    ------
    PlotInputError
        If the shapes do not match (all problems listed).
    """
    problems: list[str] = []
    t = as_times(times, problems)
    values = as_columns(force, t.size, problems, "force")
    if values.shape[1] > 1:
        problems.append(f"force: expected one column, found {values.shape[1]}")
    raise_if_any(problems)
    return _stacked(t, values, [name], "Applied force")


def plot_states(times: Any, states: Any, names: Sequence[str]) -> Figure:
    """Plot state trajectories, one axis per state.

    Parameters
    ----------
    times : array_like, shape (N,)
        Sample times in seconds.
    states : array_like, shape (N, n)
        One row per time sample, one column per state.
    names : sequence of str
        The n state names, e.g. ``["q0", "q1", "u0", "u1"]``.

    Returns
    -------
    matplotlib.figure.Figure
        n axes, each with one line.

    Raises
    ------
    PlotInputError
        If the shapes or the number of names do not match (all problems listed).
    """
    problems: list[str] = []
    t = as_times(times, problems)
    values = as_columns(states, t.size, problems, "states")
    labels = check_names(names, values.shape[1], problems)
    raise_if_any(problems)
    return _stacked(t, values, labels, "State trajectories")


def plot_trajectory_comparison(
    times: Any, measured: Any, identified: Any, names: Sequence[str]
) -> Figure:
    """Plot measured against identified coordinates, one axis per coordinate.

    Parameters
    ----------
    times : array_like, shape (N,)
        Sample times in seconds.
    measured : array_like, shape (N, k)
        The (noisy) measurements.
    identified : array_like, shape (N, k)
        The trajectories of the identified model.
    names : sequence of str
        The k coordinate names.

    Returns
    -------
    matplotlib.figure.Figure
        k axes; on each, line 0 is the measurement (dots) and line 1 the identified
        trajectory.

    Raises
    ------
    PlotInputError
        If the shapes or the number of names do not match (all problems listed).
    """
    problems: list[str] = []
    t = as_times(times, problems)
    y_measured = as_columns(measured, t.size, problems, "measured")
    y_identified = as_columns(identified, t.size, problems, "identified")
    if not problems and y_measured.shape != y_identified.shape:
        problems.append(
            f"identified: expected the shape of measured {y_measured.shape}, "
            f"found {y_identified.shape}"
        )
    labels = check_names(names, y_measured.shape[1], problems)
    raise_if_any(problems)
    figure = new_figure(y_measured.shape[1])
    for i, (axis, label) in enumerate(zip(figure.axes, labels, strict=True)):
        axis.plot(t, y_measured[:, i], ".", markersize=2, color="0.5", label="measured")
        axis.plot(t, y_identified[:, i], "-", linewidth=1.0, color="C0", label="identified")
        axis.set_ylabel(label)
        axis.grid(True, alpha=0.3)
    figure.axes[0].legend(loc="upper right")
    figure.axes[-1].set_xlabel(TIME_LABEL)
    figure.suptitle("Measured and identified trajectories")
    return figure


def plot_constraint_violations(times: Any, defects: Any, names: Sequence[str]) -> Figure:
    """Plot the defect of each equation of motion over time at a solution.

    Parameters
    ----------
    times : array_like, shape (M,)
        Times at which the defects are evaluated (for backward Euler, the N - 1 nodes
        after the first: ``times[1:]``).
    defects : array_like, shape (M, n)
        One row per collocation point, one column per equation.
    names : sequence of str
        The n equation names.

    Returns
    -------
    matplotlib.figure.Figure
        n axes, each with one line.

    Raises
    ------
    PlotInputError
        If the shapes or the number of names do not match (all problems listed).
    """
    problems: list[str] = []
    t = as_times(times, problems)
    values = as_columns(
        defects,
        t.size,
        problems,
        "defects",
        rows_meaning="len(times) (pass times[1:] when the first node has no defect)",
    )
    labels = check_names(names, values.shape[1], problems)
    raise_if_any(problems)
    figure = _stacked(t, values, labels, "Constraint violations")
    for axis in figure.axes:
        axis.ticklabel_format(axis="y", style="sci", scilimits=(-2, 2))
    return figure


def _numbers(value: Any, name: str, problems: list[str]) -> np.ndarray | None:
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        problems.append(f"{name}: expected an array of numbers, found {type(value).__name__}")
        return None


def _gain_names(shape: tuple[int, ...]) -> list[str]:
    if len(shape) == 2:
        return [f"K[{i},{j}]" for i in range(shape[0]) for j in range(shape[1])]
    return [f"p[{i}]" for i in range(int(np.prod(shape)))]


def plot_gains(
    known: Any,
    identified: Any,
    std_errors: Any = None,
    names: Sequence[str] | None = None,
    interval: float = 1.96,
) -> Figure:
    """Compare identified gains (with error bars) to the known ones.

    Parameters
    ----------
    known : array_like or None
        Known values, any shape (a gain matrix is flattened row by row); ``None`` when
        unknown (measured data). NaN entries are not drawn.
    identified : array_like
        Identified values, same shape as ``known``.
    std_errors : array_like or None, optional
        Standard errors of ``identified``, same shape; error bars are drawn as
        ``identified ± interval * std_errors``.
    names : sequence of str or None, optional
        One label per value; default ``K[i,j]`` for a matrix, ``p[i]`` otherwise.
    interval : float, optional
        Half-width of the error bars in standard errors (1.96: 95 % for a normal estimate).

    Returns
    -------
    matplotlib.figure.Figure
        One axis. Line 0 holds the identified values at x = 0, 1, ...; with
        ``known``, the last line holds the known values; with ``std_errors``, the
        error bars are the axis' first collection.

    Raises
    ------
    PlotInputError
        If the shapes or the number of names do not match (all problems listed).
    """
    problems: list[str] = []
    estimate = _numbers(identified, "identified", problems)
    if estimate is None:
        raise PlotInputError(problems)
    flat = estimate.ravel()
    others = {"known": known, "std_errors": std_errors}
    flattened = {}
    for name, value in others.items():
        if value is None:
            continue
        array = _numbers(value, name, problems)
        if array is None:
            continue
        if array.shape != estimate.shape:
            problems.append(
                f"{name}: expected the shape of identified {estimate.shape}, found {array.shape}"
            )
        else:
            flattened[name] = array.ravel()
    if "std_errors" in flattened and np.any(flattened["std_errors"] < 0):
        problems.append("std_errors: expected non-negative values, found negative ones")
    if not (isinstance(interval, int | float) and interval > 0):
        problems.append(f"interval: expected a positive number, found {interval!r}")
    labels = (
        _gain_names(estimate.shape) if names is None else check_names(names, flat.size, problems)
    )
    raise_if_any(problems)
    figure = Figure(figsize=(max(4.0, 0.45 * flat.size + 2.0), 4.0), layout="constrained")
    axis = figure.add_subplot()
    positions = np.arange(flat.size, dtype=float)
    if "std_errors" in flattened:
        axis.errorbar(
            positions,
            flat,
            yerr=interval * flattened["std_errors"],
            fmt="o",
            color="C0",
            capsize=3,
            label=f"identified ± {interval:g} SE",
        )
    else:
        axis.plot(positions, flat, "o", color="C0", label="identified")
    if "known" in flattened:
        axis.plot(positions, flattened["known"], "x", color="C3", markersize=8, label="known")
    axis.set_xticks(positions, labels, rotation=90 if flat.size > 8 else 0)
    axis.set_ylabel("value")
    axis.grid(True, axis="y", alpha=0.3)
    axis.legend()
    figure.suptitle("Gains")
    return figure


__all__ = [
    "PlotInputError",
    "plot_constraint_violations",
    "plot_force",
    "plot_gains",
    "plot_states",
    "plot_trajectory_comparison",
]
