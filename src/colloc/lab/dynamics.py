"""Planar inverse dynamics of one leg, from the foot up (Winter's Newton-Euler method).

Each segment's mass, moment of inertia and centre of mass are gait2d's (Winter's fractions
scaled by body mass and height, :func:`colloc.models.gait2d_params.load_parameters`), placed
on the measured markers: the thigh's and shank's centres of mass at the model's fraction of
the hip-knee and knee-ankle lines, the foot's at the model's offset from the ankle in the frame
of the heel-toe line. Their accelerations and the segments' angular accelerations are second
central differences of the filtered positions and orientations.

The foot carries the ground reaction: force ``(Fx, Fy)`` and moment ``Mz`` about the lab's
origin, as a force plate reports them. Working up, each joint's force and moment follow from
the segment's Newton-Euler equations; the joint torque is the moment the proximal segment
exerts on the distal one, counter-clockwise positive, which is gait2d's torque (hip flexing,
knee extending, ankle dorsiflexing positive; see :mod:`colloc.models.gait2d`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from colloc.data.filtering import time_derivative
from colloc.models.gait2d_params import Gait2DParameters


@dataclass(frozen=True)
class LegInertia:
    """Mass properties of one leg's thigh, shank and foot.

    Attributes
    ----------
    masses : (float, float, float)
        Thigh, shank, foot [kg].
    inertias : (float, float, float)
        About each centre of mass [kg m^2].
    thigh_com, shank_com : float
        Centre of mass as a fraction of the hip-knee and knee-ankle lines from their
        proximal end.
    foot_com : (float, float)
        The foot's centre of mass from the ankle, forward along the sole and up [m].
    gravity : float
        [m/s^2].
    """

    masses: tuple[float, float, float]
    inertias: tuple[float, float, float]
    thigh_com: float
    shank_com: float
    foot_com: tuple[float, float]
    gravity: float

    @classmethod
    def from_parameters(cls, params: Gait2DParameters) -> LegInertia:
        """gait2d's segments for a subject (:func:`colloc.models.gait2d_params.load_parameters`)."""
        return cls(
            masses=(params.thigh.mass, params.shank.mass, params.foot.mass),
            inertias=(params.thigh.inertia, params.shank.inertia, params.foot.inertia),
            thigh_com=params.thigh.com / params.thigh.length,
            shank_com=params.shank.com / params.shank.length,
            foot_com=(params.foot_com_x, -params.foot_com_y),
            gravity=params.gravity,
        )


@dataclass(frozen=True)
class JointLoads:
    """Joint torques and forces of one leg.

    Attributes
    ----------
    torques : ndarray, shape (N, 3)
        Hip, knee, ankle [N m], gait2d's signs.
    forces : ndarray, shape (N, 3, 2)
        Force of the proximal segment on the distal one at the hip, knee, ankle (x, y) [N].
    """

    torques: np.ndarray
    forces: np.ndarray


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z-component of the cross product of planar vectors (..., 2)."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _rotate(angle: np.ndarray, vector: tuple[float, float]) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.column_stack([c * vector[0] - s * vector[1], s * vector[0] + c * vector[1]])


def leg_inverse_dynamics(
    landmarks: Mapping[str, np.ndarray],
    orientations: Mapping[str, np.ndarray],
    ground_load: np.ndarray,
    inertia: LegInertia,
    sample_rate: float,
) -> JointLoads:
    """Hip, knee and ankle torques of one leg from its motion and the load under its foot.

    Parameters
    ----------
    landmarks : mapping
        ``hip``, ``knee``, ``ankle`` -> filtered positions (N, 2) [m].
    orientations : mapping
        ``thigh``, ``shank``, ``foot`` -> filtered orientations (N,) [rad]
        (:func:`colloc.lab.kinematics.segment_orientations`).
    ground_load : ndarray, shape (N, 3)
        The ground's force on the foot ``Fx, Fy`` [N] and its moment about the lab's origin
        ``Mz`` [N m], filtered like the markers.
    inertia : LegInertia
    sample_rate : float
        [Hz].

    Returns
    -------
    JointLoads
    """
    hip, knee, ankle = (np.asarray(landmarks[n], float) for n in ("hip", "knee", "ankle"))
    load = np.asarray(ground_load, float)
    centres = (
        hip + inertia.thigh_com * (knee - hip),
        knee + inertia.shank_com * (ankle - knee),
        ankle + _rotate(np.asarray(orientations["foot"], float), inertia.foot_com),
    )
    angles = [np.asarray(orientations[s], float) for s in ("thigh", "shank", "foot")]
    joints = (hip, knee, ankle)
    # the distal load of the foot: the ground's force, applied at the origin with its moment
    force, moment, point = load[:, :2], load[:, 2], np.zeros_like(ankle)
    torques, forces = [], []
    for segment in (2, 1, 0):  # foot, shank, thigh
        centre = centres[segment]
        acceleration = time_derivative(time_derivative(centre, sample_rate), sample_rate)
        alpha = time_derivative(time_derivative(angles[segment], sample_rate), sample_rate)
        mass = inertia.masses[segment]
        weight = np.column_stack(
            [np.zeros(len(centre)), np.full(len(centre), -mass * inertia.gravity)]
        )
        proximal_force = mass * acceleration - force - weight
        proximal_moment = (
            inertia.inertias[segment] * alpha
            - moment
            - _cross(point - centre, force)
            - _cross(joints[segment] - centre, proximal_force)
        )
        torques.append(proximal_moment)
        forces.append(proximal_force)
        # the next segment up carries the reaction at this joint
        force, moment, point = -proximal_force, -proximal_moment, joints[segment]
    return JointLoads(torques=np.column_stack(torques[::-1]), forces=np.stack(forces[::-1], axis=1))
