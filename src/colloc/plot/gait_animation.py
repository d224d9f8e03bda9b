"""Stick-figure drawing and animation of the planar gait model on a treadmill.

Geometry follows :mod:`colloc.models.gait2d`: the hip is at ``(qax, qay)``; a frame
rotated by angle ``theta`` has x axis ``(cos theta, sin theta)`` and y axis
``(-sin theta, cos theta)``. The trunk frame is at ``qa``, each thigh at ``qa + hip``,
shank at ``qa + hip + knee``, foot at ``qa + hip + knee + ankle``. The trunk runs up its
y axis from the hip; thigh and shank run down theirs (knee = hip - l_thigh * y_thigh,
ankle = knee - l_shank * y_shank); heel and toe lie ``ankle_height`` below the ankle
along the foot's y axis and ``heel_x``/``toe_x`` along its x axis.
"""

from __future__ import annotations

import os
import secrets
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.animation import PillowWriter
from matplotlib.figure import Figure

from colloc.models.gait2d_params import Gait2DParameters
from colloc.plot.animation import frame_coordinates
from colloc.plot.common import PlotInputError, raise_if_any

#: Names of the points returned by :func:`stick_figure_points`.
POINT_NAMES: tuple[str, ...] = (
    "hip",
    "trunk_top",
    *(f"{side}_{part}" for side in ("right", "left") for part in ("knee", "ankle", "heel", "toe")),
)

_NUM_COORDINATES = 9


@dataclass(frozen=True)
class StickFigureGeometry:
    """Segment lengths and foot geometry of the stick figure [m].

    Attributes
    ----------
    trunk_length, thigh_length, shank_length : float
        Segment lengths (trunk from the hip up).
    ankle_height : float
        Height of the ankle above the sole.
    heel_x, toe_x : float
        Heel and toe contact points along the sole, forward of the ankle (heel negative).
    """

    trunk_length: float
    thigh_length: float
    shank_length: float
    ankle_height: float
    heel_x: float
    toe_x: float

    def __post_init__(self) -> None:
        problems = [
            f"{name}: expected a positive finite number, found {getattr(self, name)!r}"
            for name in ("trunk_length", "thigh_length", "shank_length", "ankle_height")
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) > 0)
        ]
        if not (np.isfinite(self.heel_x) and np.isfinite(self.toe_x) and self.heel_x < self.toe_x):
            problems.append(
                f"heel_x, toe_x: expected finite numbers with heel_x < toe_x, "
                f"found {self.heel_x!r}, {self.toe_x!r}"
            )
        raise_if_any(problems)

    @classmethod
    def from_parameters(cls, params: Gait2DParameters) -> StickFigureGeometry:
        """The geometry of a gait2d subject (:func:`colloc.models.gait2d_params.load_parameters`)."""
        return cls(
            trunk_length=params.trunk.length,
            thigh_length=params.thigh.length,
            shank_length=params.shank.length,
            ankle_height=params.ankle_height,
            heel_x=params.heel_x,
            toe_x=params.toe_x,
        )


def _axes(angle: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c, s], axis=-1), np.stack([-s, c], axis=-1)


def stick_figure_points(q: Any, geometry: StickFigureGeometry) -> dict[str, np.ndarray]:
    """Positions of the joints and contact points for gait2d coordinates.

    Parameters
    ----------
    q : array_like, shape (..., 9)
        ``[qax, qay, qa, qb, qc, qd, qe, qf, qg]``; leading dimensions (frames) are kept.
    geometry : StickFigureGeometry

    Returns
    -------
    dict
        Name (see :data:`POINT_NAMES`) -> array of shape ``(..., 2)`` (x forward, y up).

    Raises
    ------
    PlotInputError
        If ``q`` does not end in 9 finite values or ``geometry`` has the wrong type.
    """
    problems: list[str] = []
    coordinates = np.asarray(q, dtype=float)
    if coordinates.ndim == 0 or coordinates.shape[-1] != _NUM_COORDINATES:
        problems.append(
            f"q: expected a last dimension of {_NUM_COORDINATES} gait2d coordinates, "
            f"found shape {coordinates.shape}"
        )
    elif not np.all(np.isfinite(coordinates)):
        problems.append("q: expected finite values, found NaN or infinity")
    if not isinstance(geometry, StickFigureGeometry):
        problems.append(
            f"geometry: expected a StickFigureGeometry, found {type(geometry).__name__}"
        )
    raise_if_any(problems)
    g = geometry
    hip = coordinates[..., 0:2]
    trunk_angle = coordinates[..., 2]
    _, trunk_y = _axes(trunk_angle)
    points = {"hip": hip, "trunk_top": hip + g.trunk_length * trunk_y}
    for side, start in (("right", 3), ("left", 6)):
        thigh = trunk_angle + coordinates[..., start]
        shank = thigh + coordinates[..., start + 1]
        foot = shank + coordinates[..., start + 2]
        knee = hip - g.thigh_length * _axes(thigh)[1]
        ankle = knee - g.shank_length * _axes(shank)[1]
        foot_x, foot_y = _axes(foot)
        points[f"{side}_knee"] = knee
        points[f"{side}_ankle"] = ankle
        points[f"{side}_heel"] = ankle + g.heel_x * foot_x - g.ankle_height * foot_y
        points[f"{side}_toe"] = ankle + g.toe_x * foot_x - g.ankle_height * foot_y
    return points


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
