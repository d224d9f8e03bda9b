"""Skin markers on gait2d's segments, placed as a gait lab places them.

A lab does not put markers on joint centres. It puts clusters of three markers on the thigh
and shank, markers on the pelvis from which a regression places the hip, and marks the
femoral epicondyles and malleoli only in the standing (static) trial. :data:`SKIN_MARKERS`
is such a set, named as OpenSim's example walk names its markers (``R.Thigh.Upper``, ...,
the convention :mod:`colloc.lab.landmarks` reads), on gait2d's segments:

- each marker is fixed in its segment's frame (origin at a landmark of the segment, the
  frame's ``x`` forward and ``y`` up when the segment's absolute angle is zero, as in
  :mod:`colloc.models.gait2d_markers`), at an offset in the sagittal plane and a distance
  from it (to the marker's side; on the mid-line for the sacrum);
- the cluster markers sit off their bones (no three in a line), so that a landmark is
  found only through the cluster's pose and the static trial;
- the anterior iliac spines and the sacral marker are placed so that Harrington's regression
  (:mod:`colloc.lab.hip_centre`) puts the hip joint centre on gait2d's hip, for a pelvis
  :data:`PELVIS_WIDTH` wide and :data:`PELVIS_DEPTH` deep;
- the epicondyles and malleoli straddle their joints (their midpoint is the joint centre);
- heel and toe markers lie on the sole's contact points, as the planar model's sole is
  defined by them.

Coordinates are (forward, up, right) [m]: OpenSim's X, Y, Z.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from colloc.data.columns import SIDES
from colloc.lab.hip_centre import HARRINGTON
from colloc.models.gait2d_points import StickFigureGeometry, stick_figure_points

#: Distance [m] between the anterior superior iliac spines.
PELVIS_WIDTH = 0.24
#: Distance [m] from the spines' midpoint back to the sacral marker.
PELVIS_DEPTH = 0.16

#: Each segment's absolute angle: the gait2d coordinates summed (``{side}``'s first index).
_SEGMENT_COORDINATES: dict[str, tuple[int, ...]] = {
    "trunk": (2,),
    "thigh": (2, 0),
    "shank": (2, 0, 1),
    "foot": (2, 0, 1, 2),
}
_FIRST_JOINT = {"right": 3, "left": 6}


@dataclass(frozen=True)
class SkinMarker:
    """One marker fixed in a gait2d segment.

    Attributes
    ----------
    name : str
        Without the side's prefix (with it for a mid-line marker).
    segment : str
        ``trunk``, ``thigh``, ``shank`` or ``foot``.
    anchor : str
        The stick figure's point (:func:`colloc.plot.gait_animation.stick_figure_points`)
        the offset starts from, with ``{side}`` for the side's.
    offset : (float, float)
        Forward and up in the segment's frame [m].
    lateral : float
        Distance from the sagittal plane [m], towards the marker's side (negative: the
        medial side); ignored for a mid-line marker.
    standing_only : bool
        Marked only in the static trial (epicondyles, malleoli).
    midline : bool
        One marker on the body's mid-line, not one per side.
    """

    name: str
    segment: str
    anchor: str
    offset: tuple[float, float] = (0.0, 0.0)
    lateral: float = 0.0
    standing_only: bool = False
    midline: bool = False


def _pelvis_offset() -> tuple[float, float]:
    """Where the spines' midpoint lies from the hip, in the trunk's frame, for Harrington's
    regression to give back the hip [m]."""
    width, depth = 1000.0 * PELVIS_WIDTH, 1000.0 * PELVIS_DEPTH

    def along(name: str) -> float:
        per_depth, per_width, offset = HARRINGTON[name]
        return (per_depth * depth + per_width * width + offset) / 1000.0

    return -along("anterior"), -along("superior")


_ASIS = _pelvis_offset()

#: The synthetic lab's marker set (OpenSim's example names, side prefixes ``R.`` / ``L.``).
SKIN_MARKERS: tuple[SkinMarker, ...] = (
    SkinMarker("Acromium", "trunk", "trunk_top", (0.0, 0.0), 0.18),
    SkinMarker("ASIS", "trunk", "hip", _ASIS, PELVIS_WIDTH / 2),
    SkinMarker("V.Sacral", "trunk", "hip", (_ASIS[0] - PELVIS_DEPTH, _ASIS[1]), midline=True),
    SkinMarker("Thigh.Upper", "thigh", "hip", (0.035, -0.13), 0.10),
    SkinMarker("Thigh.Front", "thigh", "hip", (0.075, -0.26), 0.08),
    SkinMarker("Thigh.Rear", "thigh", "hip", (-0.05, -0.23), 0.09),
    SkinMarker("Knee.Lat", "thigh", "{side}_knee", (0.0, 0.0), 0.05, standing_only=True),
    SkinMarker("Knee.Med", "thigh", "{side}_knee", (0.0, 0.0), -0.05, standing_only=True),
    SkinMarker("Shank.Upper", "shank", "{side}_knee", (0.025, -0.11), 0.07),
    SkinMarker("Shank.Front", "shank", "{side}_knee", (0.055, -0.23), 0.06),
    SkinMarker("Shank.Rear", "shank", "{side}_knee", (-0.045, -0.20), 0.065),
    SkinMarker("Ankle.Lat", "shank", "{side}_ankle", (0.0, 0.0), 0.035, standing_only=True),
    SkinMarker("Ankle.Med", "shank", "{side}_ankle", (0.0, 0.0), -0.035, standing_only=True),
    SkinMarker("Heel", "foot", "{side}_heel", (0.0, 0.0), 0.02),
    SkinMarker("Toe.Lat", "foot", "{side}_toe", (0.0, 0.0), 0.04),
)

#: Side prefixes of :data:`SKIN_MARKERS` (OpenSim's example).
SKIN_PREFIXES: dict[str, str] = {"right": "R.", "left": "L."}


def segment_angle(q: np.ndarray, segment: str, side: str) -> np.ndarray:
    """A segment's absolute angle from gait2d's coordinates ``q (..., 9)`` [rad]."""
    first = _FIRST_JOINT[side]
    trunk, *joints = _SEGMENT_COORDINATES[segment]
    return q[..., trunk] + sum((q[..., first + j] for j in joints), np.zeros(q.shape[:-1]))


def skin_marker_positions(
    q: np.ndarray, geometry: StickFigureGeometry, *, standing: bool = False
) -> dict[str, np.ndarray]:
    """Every skin marker's position at each frame.

    Parameters
    ----------
    q : ndarray, shape (N, 9)
        gait2d's coordinates.
    geometry : StickFigureGeometry
    standing : bool
        Include the markers placed only for the static trial.

    Returns
    -------
    dict
        Marker name (with its side's prefix) -> array (N, 3): forward, up, right [m].
    """
    q = np.asarray(q, float)
    points = stick_figure_points(q, geometry)
    out: dict[str, np.ndarray] = {}
    for marker in SKIN_MARKERS:
        if marker.standing_only and not standing:
            continue
        for side in SIDES[:1] if marker.midline else SIDES:
            angle = segment_angle(q, marker.segment, side)
            c, s = np.cos(angle), np.sin(angle)
            a, b = marker.offset
            xy = points[marker.anchor.format(side=side)] + np.column_stack(
                [a * c - b * s, a * s + b * c]
            )
            lateral = 0.0 if marker.midline else marker.lateral * (1.0 if side == "right" else -1)
            name = marker.name if marker.midline else f"{SKIN_PREFIXES[side]}{marker.name}"
            out[name] = np.column_stack([xy, np.full(len(q), lateral)])
    return out


def standing_pose(geometry: StickFigureGeometry) -> np.ndarray:
    """gait2d's coordinates of the subject standing upright, soles on the floor."""
    q = np.zeros(9)
    q[1] = geometry.thigh_length + geometry.shank_length + geometry.ankle_height
    return q


__all__ = [
    "PELVIS_DEPTH",
    "PELVIS_WIDTH",
    "SKIN_MARKERS",
    "SKIN_PREFIXES",
    "SkinMarker",
    "segment_angle",
    "skin_marker_positions",
    "standing_pose",
]
