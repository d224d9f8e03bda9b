"""Where gait2d's joints and contact points are, for any coordinates: the model's landmarks.

The markers a synthetic lab places (:mod:`colloc.lab.synthetic`, :mod:`colloc.lab.skin_markers`)
and the stick figures :mod:`colloc.plot.gait_animation` draws read the same points from here.
Geometry follows :mod:`colloc.models.gait2d`: the hip is at ``(qax, qay)``; a frame rotated by
angle ``theta`` has x axis ``(cos theta, sin theta)`` and y axis ``(-sin theta, cos theta)``.
The trunk frame is at ``qa``, each thigh at ``qa + hip``, shank at ``qa + hip + knee``, foot at
``qa + hip + knee + ankle``. The trunk runs up its y axis from the hip; thigh and shank run down
theirs (knee = hip - l_thigh * y_thigh, ankle = knee - l_shank * y_shank); heel and toe lie
``ankle_height`` below the ankle along the foot's y axis and ``heel_x``/``toe_x`` along its x
axis.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from colloc.models.gait2d_params import Gait2DParameters

#: gait2d's generalised coordinates ``[qax, qay, qa, qb, qc, qd, qe, qf, qg]``.
NUM_COORDINATES = 9


def _raise_if_any(problems: list[str]) -> None:
    if problems:
        lines = "\n".join(f"  - {p}" for p in problems)
        raise ValueError(f"{len(problems)} problem(s):\n{lines}")


#: Names of the points returned by :func:`stick_figure_points`.
POINT_NAMES: tuple[str, ...] = (
    "hip",
    "trunk_top",
    *(f"{side}_{part}" for side in ("right", "left") for part in ("knee", "ankle", "heel", "toe")),
)


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
        _raise_if_any(problems)

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
    ValueError
        If ``q`` does not end in 9 finite values or ``geometry`` has the wrong type.
    """
    problems: list[str] = []
    coordinates = np.asarray(q, dtype=float)
    if coordinates.ndim == 0 or coordinates.shape[-1] != NUM_COORDINATES:
        problems.append(
            f"q: expected a last dimension of {NUM_COORDINATES} gait2d coordinates, "
            f"found shape {coordinates.shape}"
        )
    elif not np.all(np.isfinite(coordinates)):
        problems.append("q: expected finite values, found NaN or infinity")
    if not isinstance(geometry, StickFigureGeometry):
        problems.append(
            f"geometry: expected a StickFigureGeometry, found {type(geometry).__name__}"
        )
    _raise_if_any(problems)
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


__all__ = ["NUM_COORDINATES", "POINT_NAMES", "StickFigureGeometry", "stick_figure_points"]
