"""Stick-figure drawing and animation of the planar gait model on a treadmill.

The points drawn are the model's (:mod:`colloc.models.gait2d_points`).
"""

from __future__ import annotations

import os
import secrets
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.animation import PillowWriter
from matplotlib.figure import Figure

from colloc.models.gait2d_points import NUM_COORDINATES as _NUM_COORDINATES
from colloc.models.gait2d_points import StickFigureGeometry, stick_figure_points
from colloc.plot.animation import frame_coordinates
from colloc.plot.common import PlotInputError, raise_if_any


def _chains(points: dict[str, np.ndarray], side: str) -> np.ndarray:
    """Polyline hip -> knee -> ankle -> heel -> toe -> ankle of one leg."""
    names = ("knee", "ankle", "heel", "toe", "ankle")
    return np.stack([points["hip"], *(points[f"{side}_{n}"] for n in names)], axis=-2)


class _GaitScene:
    """Treadmill, belt markers and stick figure, with limits containing every frame."""

    def __init__(
        self,
        points: dict[str, np.ndarray],
        figsize: tuple[float, float],
        dpi: float,
        marker_spacing: float,
    ) -> None:
        every = np.concatenate([p.reshape(-1, 2) for p in points.values()])
        low, high = every.min(axis=0), every.max(axis=0)
        margin = 0.15 * max(high[1] - min(low[1], 0.0), 0.5)
        self.figure = Figure(figsize=figsize, dpi=dpi)
        # Fixed axes placement: a layout engine would re-solve the layout on every frame.
        self.axis = self.figure.add_axes((0.1, 0.12, 0.85, 0.83))
        self.x_range = (low[0] - margin, high[0] + margin)
        self.axis.set_xlim(*self.x_range)
        self.axis.set_ylim(min(low[1], 0.0) - margin, high[1] + margin)
        self.axis.set_aspect("equal", adjustable="box")
        self.axis.axhline(0.0, color="0.4", linewidth=1.5)
        self.axis.set_xlabel("x [m]")
        self.spacing = marker_spacing
        (self.markers,) = self.axis.plot([], [], "|", color="0.4", markersize=8)
        (self.trunk,) = self.axis.plot([], [], "-", color="k", linewidth=3.0)
        (self.right,) = self.axis.plot([], [], "-o", color="C3", linewidth=2.0, markersize=3)
        (self.left,) = self.axis.plot([], [], "-o", color="C0", linewidth=2.0, markersize=3)
        self.clock = self.axis.text(0.02, 0.95, "", transform=self.axis.transAxes, va="top")

    def update(self, frame: dict[str, np.ndarray], belt_position: float, moment: float) -> None:
        self.trunk.set_data(*np.stack([frame["hip"], frame["trunk_top"]]).T)
        self.right.set_data(*_chains(frame, "right").T)
        self.left.set_data(*_chains(frame, "left").T)
        # The belt surface moves backward, so its markers shift by -belt_position.
        first = self.x_range[0] + (-belt_position) % self.spacing
        xs = np.arange(first, self.x_range[1], self.spacing)
        self.markers.set_data(xs, np.zeros_like(xs))
        self.clock.set_text(f"t = {moment:.2f} s")


def animate_gait(
    times: Any,
    q: Any,
    geometry: StickFigureGeometry,
    path: str | os.PathLike[str],
    *,
    belt_position: Any = None,
    fps: int = 30,
    max_frames: int | None = 150,
    figsize: tuple[float, float] = (5.0, 5.0),
    dpi: float = 60.0,
    marker_spacing: float = 0.25,
) -> Path:
    """Write a GIF of the stick figure walking on the treadmill.

    Parameters
    ----------
    times : array_like, shape (N,)
        Increasing sample times [s].
    q : array_like, shape (N, 9)
        gait2d coordinates per sample.
    geometry : StickFigureGeometry
    path : path-like
        Output ``.gif``; written under a temporary name and renamed when complete.
    belt_position : array_like, shape (N,), optional
        Belt position [m]; moves the markers on the belt. Default: markers stand still.
    fps : int
        Frames per second; the GIF plays in real time.
    max_frames : int or None
        Keep at most this many frames (the start of the record).
    figsize : (float, float)
        Inches.
    dpi : float
        Pixels per inch.
    marker_spacing : float
        Distance between belt markers [m].

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    PlotInputError
        If the path does not end in ``.gif``, shapes disagree, or a number is unusable
        (all problems listed).
    """
    target = Path(path)
    problems: list[str] = []
    if target.suffix.lower() != ".gif":
        problems.append(f"path: expected a file ending in .gif, found {str(path)!r}")
    if not (np.isfinite(marker_spacing) and marker_spacing > 0):
        problems.append(f"marker_spacing: expected a positive number, found {marker_spacing!r}")
    q_array = np.asarray(q, dtype=float)
    if q_array.ndim != 2 or q_array.shape[1] != _NUM_COORDINATES:
        problems.append(f"q: expected shape (N, {_NUM_COORDINATES}), found {q_array.shape}")
    belt = np.zeros(q_array.shape[0] if q_array.ndim else 0)
    if belt_position is not None:
        belt = np.asarray(belt_position, dtype=float)
        if q_array.ndim == 2 and belt.shape != (q_array.shape[0],):
            problems.append(
                f"belt_position: expected shape ({q_array.shape[0]},) like q, found {belt.shape}"
            )
    raise_if_any(problems)
    frame_times, values = frame_coordinates(
        times, np.column_stack([q_array, belt]), fps, max_frames
    )
    points = stick_figure_points(values[:, :_NUM_COORDINATES], geometry)
    scene = _GaitScene(points, figsize, dpi, float(marker_spacing))
    writer = PillowWriter(fps=int(fps))
    temporary = target.with_name(f".{target.stem}.{secrets.token_hex(8)}{target.suffix}")
    target.parent.mkdir(parents=True, exist_ok=True)
    try:
        with writer.saving(scene.figure, str(temporary), dpi):
            for k, moment in enumerate(frame_times):
                scene.update({n: p[k] for n, p in points.items()}, values[k, -1], moment)
                writer.grab_frame()
        os.replace(temporary, target)
    finally:
        temporary.unlink(missing_ok=True)
    return target


def plot_stick_figure(q: Any, geometry: StickFigureGeometry, time: float = 0.0) -> Figure:
    """Draw one configuration (a still of :func:`animate_gait`).

    Parameters
    ----------
    q : array_like, shape (9,)
        gait2d coordinates.
    geometry : StickFigureGeometry
    time : float
        Time shown in the corner [s].

    Returns
    -------
    Figure
        ``axes[0].lines``: belt surface, belt markers, trunk, right leg (hip, knee, ankle,
        heel, toe, ankle), left leg, in that order.

    Raises
    ------
    PlotInputError
        If ``q`` is not one configuration of 9 coordinates.
    """
    if np.shape(q) != (_NUM_COORDINATES,):
        raise PlotInputError(
            [f"q: expected one configuration of shape (9,), found shape {np.shape(q)}"]
        )
    points = stick_figure_points(q, geometry)
    scene = _GaitScene(points, (5.0, 5.0), 100.0, 0.25)
    scene.update(points, 0.0, time)
    return scene.figure
