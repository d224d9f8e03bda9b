"""Planar inverse kinematics: segment orientations and joint angles in gait2d's conventions.

Each segment's orientation is that of a line between two markers (Winter's 2-D model, as
GaitAnalysisToolKit's leg2d does it), measured counter-clockwise (x forward, y up) from the
segment's pose in upright standing, so that gait2d's coordinates are differences of them
(see :mod:`colloc.models.gait2d`):

=======  ===========================  ======================================================
segment  line                         orientation, zero when
=======  ===========================  ======================================================
trunk    hip -> shoulder              the line is vertical (gait2d ``qa``, leaning back +)
thigh    hip -> knee                  the line hangs vertically down
shank    knee -> ankle                the line hangs vertically down
foot     heel -> toe                  the sole line is horizontal
=======  ===========================  ======================================================

hip = thigh - trunk (flexion +), knee = shank - thigh (extension +, so flexion is negative),
ankle = foot - shank (dorsiflexion +, zero with the sole at right angles to the shank). In
GaitAnalysisToolKit's leg2d convention (hip, knee flexion and ankle plantarflexion positive,
the ankle at -pi/2 standing) the same angles are ``hip``, ``-knee`` and ``-ankle - pi/2``.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

#: Segment -> (proximal landmark, distal landmark, the line's direction at zero as (x, y)).
SEGMENT_LINES: dict[str, tuple[str, str, tuple[float, float]]] = {
    "trunk": ("hip", "shoulder", (0.0, 1.0)),
    "thigh": ("hip", "knee", (0.0, -1.0)),
    "shank": ("knee", "ankle", (0.0, -1.0)),
    "foot": ("heel", "toe", (1.0, 0.0)),
}

#: Joint -> (proximal segment, distal segment); the joint angle is distal minus proximal.
JOINT_SEGMENTS: dict[str, tuple[str, str]] = {
    "hip": ("trunk", "thigh"),
    "knee": ("thigh", "shank"),
    "ankle": ("shank", "foot"),
}


def _in_first_turn(angle: np.ndarray) -> np.ndarray:
    """A continuous angle shifted by whole turns so that its first sample is in (-pi, pi]."""
    turns = np.round(angle[0] / (2.0 * np.pi))
    return angle - 2.0 * np.pi * turns


def segment_orientation(
    proximal: np.ndarray, distal: np.ndarray, zero: tuple[float, float]
) -> np.ndarray:
    """Counter-clockwise angle of the line ``proximal -> distal`` from its zero direction.

    Parameters
    ----------
    proximal, distal : ndarray, shape (N, 2)
        Marker positions, x forward and y up [m].
    zero : (float, float)
        The unit direction of the line at zero angle.

    Returns
    -------
    ndarray, shape (N,)
        [rad], continuous in time (no jumps of 2 pi), the first sample in (-pi, pi].
    """
    line = np.asarray(distal, float) - np.asarray(proximal, float)
    cos = line[:, 0] * zero[0] + line[:, 1] * zero[1]
    sin = zero[0] * line[:, 1] - zero[1] * line[:, 0]
    return _in_first_turn(np.unwrap(np.arctan2(sin, cos)))


def segment_orientations(landmarks: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Orientations of the trunk, thigh, shank and foot of one side.

    Parameters
    ----------
    landmarks : mapping
        ``shoulder``, ``hip``, ``knee``, ``ankle``, ``heel``, ``toe`` -> array (N, 2).

    Returns
    -------
    dict
        Segment name -> orientation (N,) [rad] (see the module's table).
    """
    return {
        segment: segment_orientation(landmarks[a], landmarks[b], zero)
        for segment, (a, b, zero) in SEGMENT_LINES.items()
    }


def joint_angles(orientations: Mapping[str, np.ndarray]) -> np.ndarray:
    """Hip, knee and ankle angles of one side in gait2d's conventions.

    Parameters
    ----------
    orientations : mapping
        From :func:`segment_orientations`.

    Returns
    -------
    ndarray, shape (N, 3)
        Hip (flexion +), knee (extension +), ankle (dorsiflexion +) [rad], each with its first
        sample in (-pi, pi].
    """
    return np.column_stack(
        [
            _in_first_turn(orientations[distal] - orientations[proximal])
            for proximal, distal in JOINT_SEGMENTS.values()
        ]
    )


#: Signs taking leg2d's hip, knee and ankle rates or moments to gait2d's.
LEG2D_SIGNS: tuple[float, float, float] = (1.0, -1.0, -1.0)


def angles_from_leg2d(angles: np.ndarray) -> np.ndarray:
    """GaitAnalysisToolKit leg2d's hip, knee and ankle angles in gait2d's conventions.

    Parameters
    ----------
    angles : ndarray, shape (N, 3)
        leg2d's hip flexion, knee flexion, ankle plantarflexion (-pi/2 standing) [rad].

    Returns
    -------
    ndarray, shape (N, 3)
        ``hip, -knee, -ankle - pi/2``. Rates and moments take only the signs
        (:data:`LEG2D_SIGNS`).
    """
    return np.asarray(angles, float) * np.array(LEG2D_SIGNS) - np.array([0.0, 0.0, np.pi / 2])
