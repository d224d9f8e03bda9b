"""Where gait2d's segments are, and so where a marker fixed in one of them is.

Each segment has a frame: its origin at the proximal joint (the trunk's and both thighs' at
the hip, ``(qax, qay)``; a shank's at its knee; a foot's at its ankle) and its absolute
angle in the plane (the trunk ``qa``; a thigh ``qa + qb``; a shank ``qa + qb + qc``; a foot
``qa + qb + qc + qd``; the left side with ``qe, qf, qg``). The frame's ``x`` axis points
forward and its ``y`` axis up when the angle is zero, as in :mod:`colloc.models.gait2d`. A
marker at ``(a, b)`` in a segment's frame is at ``origin + a x_axis + b y_axis`` in the
ground frame.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import sympy as sm

from colloc.models.gait2d import Gait2D

#: The segments, each as ``<side>_<segment>`` but the trunk.
SEGMENTS: tuple[str, ...] = (
    "trunk",
    "right_thigh",
    "right_shank",
    "right_foot",
    "left_thigh",
    "left_shank",
    "left_foot",
)

_CHAIN = ("thigh", "shank", "foot")


def segment_frames(gait: Gait2D) -> dict[str, tuple[sm.Expr, sm.Expr, sm.Expr]]:
    """Each segment's origin ``(x, y)`` and absolute angle in gait2d's coordinates.

    Parameters
    ----------
    gait : Gait2D
        :func:`colloc.models.gait2d.derive`.

    Returns
    -------
    dict
        Segment name (:data:`SEGMENTS`) -> ``(x, y, angle)``.
    """
    q = gait.coordinates
    s = gait.segment_symbols
    hip_x, hip_y, trunk = q[0], q[1], q[2]
    out: dict[str, tuple[sm.Expr, sm.Expr, sm.Expr]] = {"trunk": (hip_x, hip_y, trunk)}
    for side, first in (("right", 3), ("left", 6)):
        x, y, angle = hip_x, hip_y, trunk
        lengths = (s.l_thigh, s.l_shank, None)
        for k, (name, length) in enumerate(zip(_CHAIN, lengths, strict=True)):
            angle = angle + q[first + k]
            out[f"{side}_{name}"] = (x, y, angle)
            if length is not None:  # the next segment's origin: down the segment's y axis
                x, y = x + length * sm.sin(angle), y - length * sm.cos(angle)
    return out


def marker_position(
    gait: Gait2D, segment: str, local: tuple[sm.Expr | float, sm.Expr | float]
) -> tuple[sm.Expr, sm.Expr]:
    """The ground-frame position of a point fixed in a segment.

    Parameters
    ----------
    gait : Gait2D
    segment : str
        One of :data:`SEGMENTS`.
    local : (a, b)
        The point in the segment's frame [m] (numbers or symbols).

    Returns
    -------
    (x, y) : sympy expressions

    Raises
    ------
    ValueError
        When ``segment`` is not one of gait2d's.
    """
    frames = segment_frames(gait)
    if segment not in frames:
        raise ValueError(f"segment: expected one of {list(SEGMENTS)}, found {segment!r}")
    x, y, angle = frames[segment]
    a, b = (sm.sympify(v) for v in local)
    c, s = sm.cos(angle), sm.sin(angle)
    return x + a * c - b * s, y + a * s + b * c


def local_positions(
    gait: Gait2D,
    constants: np.ndarray,
    coordinates: np.ndarray,
    markers: Mapping[str, np.ndarray],
    segments: Mapping[str, str],
) -> dict[str, np.ndarray]:
    """Each marker's position in its segment's frame that best fits the record: the mean
    over the samples where it was seen of ``R(angle)^T (marker - origin)`` (the least-squares
    fixed point of a rigid segment whose pose is given).

    Parameters
    ----------
    gait : Gait2D
    constants : ndarray
        :meth:`Gait2D.constant_array` (the segment lengths the frames use).
    coordinates : ndarray, shape (N, 9)
        The segments' pose over the record.
    markers : mapping
        Marker name -> (N, 2) ground-frame positions, NaN where not seen.
    segments : mapping
        Marker name -> its segment.

    Returns
    -------
    dict
        Marker name -> ``(a, b)`` [m].

    Raises
    ------
    ValueError
        When a marker is never seen, or names an unknown segment.
    """
    frames = segment_frames(gait)
    unknown = sorted({s for s in segments.values() if s not in frames})
    if unknown:
        raise ValueError(f"segments: expected among {list(SEGMENTS)}, found {unknown}")
    pose = gait.lambdify([list(frames[s]) for s in SEGMENTS])
    coordinates = np.asarray(coordinates, dtype=float)
    zeros_u, zeros_t = np.zeros(9), np.zeros(6)
    poses = np.array([pose(q, zeros_u, zeros_t, 0.0, constants) for q in coordinates], dtype=float)
    out = {}
    for name, xy in markers.items():
        x, y, angle = poses[:, SEGMENTS.index(segments[name])].T
        seen = np.all(np.isfinite(xy), axis=1)
        if not seen.any():
            raise ValueError(f"marker {name}: never seen in the record")
        dx, dy = xy[seen, 0] - x[seen], xy[seen, 1] - y[seen]
        c, s = np.cos(angle[seen]), np.sin(angle[seen])
        out[name] = np.array([np.mean(c * dx + s * dy), np.mean(-s * dx + c * dy)])
    return out
