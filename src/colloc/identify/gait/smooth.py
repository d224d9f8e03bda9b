"""The smoother on its own: a trial's dynamically consistent motion, joint moments and the
residual forces that remain (``colloc gait smooth``).

What a gait lab wants even without a controller: the motion of gait2d closest to the
record that the model makes with free joint torques (:mod:`colloc.identify.gait.smoother`),
read as joint angles, rates and moments, with the residual forces on the trunk that the
record still needs (what a residual reduction reports). The record is smoothed whole or in
windows of whole strides (:func:`colloc.data.split.stride_windows`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from colloc.data.columns import JOINT_ANGLE_COLUMNS, TORQUE_COLUMNS
from colloc.data.split import stride_windows
from colloc.data.trial import Trial, read_trial
from colloc.gait.metadata import STATE_SIGNAL_NAMES
from colloc.identify.gait.read import subject
from colloc.identify.gait.settings import SMOOTH_SOURCES
from colloc.identify.gait.windows import (
    SOURCES,
    WindowMap,
    prefixed,
    smooth_windows,
    smoothing_source,
    window_facts,
    window_jobs,
)

Progress = Callable[[str, str], None]

#: Columns of the residual forces on the trunk in the table: forward [N], vertical [N], the
#: moment about the trunk's angle [N m].
RESIDUAL_COLUMNS = ("residual_x", "residual_y", "residual_moment")


@dataclass
class SmoothedTrial:
    """A trial smoothed by :func:`smooth_trial`.

    Attributes
    ----------
    trial : Trial
        The record as read.
    rows : ndarray of int
        The samples smoothed.
    windows : list of SmoothedGait
        One per window, in time order.
    seconds : float
        Wall time of the smoothing.
    notes : list of str
    """

    trial: Trial
    rows: np.ndarray
    windows: list[Any]
    seconds: float
    notes: list[str] = field(default_factory=list)

    @property
    def success(self) -> bool:
        """Every window's last stage converged."""
        return all(w.stages[-1].success for w in self.windows)


def smooth_trial(
    path: str | Path,
    *,
    start: float = 0.0,
    duration: float | None = None,
    window_strides: int | None = None,
    smooth_from: str = "auto",
    noise_levels: tuple[tuple[str, float], ...] = (),
    fit_places: bool = False,
    progress: Progress | None = None,
    map_windows: WindowMap | None = None,
) -> SmoothedTrial:
    """Smooth a trial (or its part from ``start`` for ``duration`` seconds).

    Parameters
    ----------
    path : path-like
        A trial directory (:func:`colloc.data.read_trial`).
    start, duration : float
        The part smoothed [s from the record's start]; ``duration`` None: to the end.
    window_strides : int, optional
        Smooth in windows of this many whole strides (memory follows the window); None: one
        window.
    smooth_from : str
        What the smoother tracks: ``markers`` (a lab trial's raw markers and plates),
        ``angles`` (its angles, trunk pose and torques) or ``auto`` (default: markers when
        the trial has them; :data:`colloc.identify.gait.settings.SMOOTH_SOURCES`).
    noise_levels : tuple of (str, float)
        Smoothing from markers: noise levels replacing the trial's estimates
        (:class:`colloc.identify.gait.markers.MarkerNoise`).
    fit_places : bool
        Smoothing from markers: estimate each marker's place in its segment with the motion
        (each window its own; the JSON's ``windows`` give the estimates and how far the
        record determines each), instead of keeping the static trial's or the walk's
        least-squares places.
    progress : callable, optional
        ``progress(step, detail)``.
    map_windows : callable, optional
        ``map_windows(function, jobs)`` to spread the windows (e.g. over Dask workers).

    Returns
    -------
    SmoothedTrial

    Raises
    ------
    ValueError
        If the options are unusable or the part holds less than one stride (every problem at
        once).
    SmootherError
        If a window's smoother fails outright.
    """
    problems = []
    if not (isinstance(start, int | float) and np.isfinite(start) and start >= 0):
        problems.append(f"start: expected seconds >= 0, found {start!r}")
    if duration is not None and not (
        isinstance(duration, int | float) and np.isfinite(duration) and duration > 0
    ):
        problems.append(f"duration: expected seconds > 0 or None, found {duration!r}")
    if window_strides is not None and (
        isinstance(window_strides, bool)
        or not isinstance(window_strides, int)
        or window_strides < 1
    ):
        problems.append(f"window_strides: expected whole strides >= 1, found {window_strides!r}")
    if smooth_from not in SMOOTH_SOURCES:
        problems.append(
            f"smooth_from: expected one of {list(SMOOTH_SOURCES)}, found {smooth_from!r}"
        )
    if not isinstance(fit_places, bool):
        problems.append(f"fit_places: expected True or False, found {fit_places!r}")
    if problems:
        raise ValueError("smooth_trial: " + "; ".join(problems))
    trial = read_trial(path)
    t = trial.time - trial.time[0]
    stop = np.inf if duration is None else start + duration
    rows = np.flatnonzero((t >= start - 1e-9) & (t <= stop + 1e-9))
    strikes = trial.right_heel_strikes
    inside = (
        strikes[(strikes >= trial.time[rows[0]]) & (strikes <= trial.time[rows[-1]])]
        if rows.size
        else strikes[:0]
    )
    if rows.size < 2 or inside.size < 2:
        part = "to the end" if duration is None else f"for {duration:g} s"
        strides = np.diff(strikes)
        needs = (
            f"; this walk's strides last {np.median(strides):.2f} s (median), so a part of "
            f"{2 * np.max(strides):.2f} s (two of its longest) holds one wherever it starts"
            if strides.size
            else "; the trial has fewer than two right heel strikes, so no part of it does"
        )
        raise ValueError(
            f"smooth_trial: expected at least one whole stride (two right heel strikes) in "
            f"the part smoothed (from {start:g} s {part}), found {inside.size} right heel "
            f"strike(s) in {rows.size} samples{needs}"
        )
    if window_strides is None:
        windows = [(0, rows.size)]
    else:
        windows = stride_windows(trial.time[rows], strikes, window_strides)
    try:
        source = smoothing_source(smooth_from, trial)
    except ValueError as error:
        raise ValueError(f"smooth_trial: {error}") from None
    notes = [
        f"subject: {subject(trial.metadata)[0]:g} kg, {subject(trial.metadata)[1]:g} m",
        f"tracked: the {SOURCES[source].words}",
    ]
    if fit_places:
        notes.append("markers' places in their segments: estimated with the motion")
    jobs = window_jobs(
        trial,
        rows,
        windows,
        trial.metadata,
        "stride window",
        source,
        tuple(noise_levels),
        fit_places,
    )
    begin = time.perf_counter()
    say = progress or (lambda step, detail: None)
    results = smooth_windows(jobs, prefixed(say, "smooth"), map_windows)
    if any(result.inputs_in_pairs for result in results):
        notes.append(
            "torques and residual forces: each node's the mean of its two intervals' (the "
            "trapezoidal rule ties the node accelerations only in pairs, and the torques that "
            "no measurement pins alternate node to node)"
        )
    return SmoothedTrial(trial, rows, results, time.perf_counter() - begin, notes)


def smoothed_table(run: SmoothedTrial) -> pd.DataFrame:
    """The smoothed record as a table: ``time``, the trunk's pose and every joint's angle and
    rate (the trial's column names, rad and rad/s), each joint's torque (N m) and the
    residual forces (:data:`RESIDUAL_COLUMNS`), one row per node of every window."""
    frames = []
    for window in run.windows:
        frame = pd.DataFrame(window.states, columns=list(STATE_SIGNAL_NAMES))
        torques, residuals = window.node_mean_inputs()
        frame[list(TORQUE_COLUMNS)] = torques
        frame[list(RESIDUAL_COLUMNS)] = residuals
        frame.insert(0, "time", window.times)
        frames.append(frame)
    return pd.concat(frames, ignore_index=True)


def smooth_summary(run: SmoothedTrial, table: pd.DataFrame | None = None) -> dict[str, Any]:
    """What a reader needs of the fit: how close it came to the record (angles and, when
    recorded, torques, RMS per joint), the residual forces (RMS and largest), each window's
    stages and cost, and the notes. ``table``: :func:`smoothed_table` of ``run`` when the
    caller has it already."""
    table = smoothed_table(run) if table is None else table
    measured = run.trial.signals.iloc[run.rows].reset_index(drop=True)
    times = run.trial.time[run.rows]
    # the record at the nodes (every window starts at one of its samples)
    at_nodes = {
        column: np.interp(table["time"], times, measured[column].to_numpy(dtype=float))
        for column in (*JOINT_ANGLE_COLUMNS, *TORQUE_COLUMNS)
        if column in measured
    }
    angle_rms = {
        column.removesuffix("_angle"): float(
            np.degrees(np.sqrt(np.mean((table[column] - at_nodes[column]) ** 2)))
        )
        for column in JOINT_ANGLE_COLUMNS
    }
    torque_rms = {
        column.removesuffix("_torque"): float(
            np.sqrt(np.nanmean((table[column] - at_nodes[column]) ** 2))
        )
        for column in TORQUE_COLUMNS
        if column in at_nodes
    }
    residuals = table[list(RESIDUAL_COLUMNS)].to_numpy()
    return {
        "success": run.success,
        "samples": int(run.rows.size),
        "window": [float(times[0]), float(times[-1])],
        "angle_rms_deg": angle_rms,
        "torque_rms_from_record": torque_rms or None,
        "residual_rms": dict(
            zip(RESIDUAL_COLUMNS, np.sqrt(np.mean(residuals**2, axis=0)).tolist(), strict=True)
        ),
        "residual_max": dict(
            zip(RESIDUAL_COLUMNS, np.abs(residuals).max(axis=0).tolist(), strict=True)
        ),
        "windows": [
            {**window_facts(w), "stages": [s.describe() for s in w.stages]} for w in run.windows
        ],
        "seconds": run.seconds,
        "notes": [*run.notes, *(n for w in run.windows for n in w.notes)],
        "units": {
            "angles": "rad",
            "rates": "rad/s",
            "torques": "N m",
            "residual_x, residual_y": "N",
            "residual_moment": "N m",
        },
    }


__all__ = ["RESIDUAL_COLUMNS", "SmoothedTrial", "smooth_summary", "smooth_trial", "smoothed_table"]
