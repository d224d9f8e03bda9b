"""Unmeasured body states from measured joints through the feet that carry the weight.

A foot loaded on the belt does not move relative to it, so its contact points give
kinematic constraints ``G(q) dq = 0`` on a perturbation ``dq`` (and ``G(q) du = 0`` on a
speed perturbation). With a foot flat on the belt they fix the three body coordinates (hip
position, trunk angle) given the six joint angles: the stance leg's joint angles *are* a
measurement of the trunk's orientation and the hip's position. :func:`substitution_matrices`
solves the constraints of all loaded contact points, each weighted by its vertical force,
for the unmeasured coordinates in terms of the measured ones (regularised least squares, so
a foot rolling over its toe, which leaves one direction free, stays well posed).

Used by :func:`colloc.gait.design.design_controller` to fold the full-state LQR gains on
unmeasured states into gains on measured ones (``K_m + K_u C``), the starting point from
which partial-state gains are tuned.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from colloc.gait.orbit import NUM_COORDINATES, GaitDynamics
from colloc.models.gait2d import CONTACT_POINT_NAMES
from colloc.numeric.bridge import sympy_to_casadi

#: Vertical force [N] at which a contact point's constraint counts fully (body weight
#: scale); lighter contacts count in proportion.
FORCE_SCALE = 700.0
#: Regularisation of the least-squares solve (relative to a fully loaded point's weight).
REGULARISATION = 1e-2


def contact_point_jacobian(dynamics: GaitDynamics) -> ca.Function:
    """``x -> d(contact point positions)/dq``, shape (8, 9): ``x, y`` of each contact point.

    Parameters
    ----------
    dynamics : GaitDynamics

    Returns
    -------
    casadi.Function
    """
    gait = dynamics.gait
    q = dynamics.x[:NUM_COORDINATES]
    leaves: dict[Any, Any] = dict(zip(gait.coordinates, ca.vertsplit(q), strict=True))
    leaves.update({s: ca.SX(v) for s, v in dynamics.constants.items()})
    points = [e for name in CONTACT_POINT_NAMES for e in gait.contact_points[name]]
    positions = ca.vertcat(*sympy_to_casadi(points, leaves))
    return ca.Function("contact_jacobian", [dynamics.x], [ca.jacobian(positions, q)])


def substitution_matrices(
    dynamics: GaitDynamics,
    states: np.ndarray,
    belt_speed: float,
    measured: np.ndarray,
    *,
    regularisation: float = REGULARISATION,
) -> np.ndarray:
    """``C_k`` with ``dq_unmeasured = C_k dq_measured`` at each state along a cycle.

    Parameters
    ----------
    dynamics : GaitDynamics
    states : ndarray, shape (N, 18)
    belt_speed : float
        [m/s], for the contact forces that weight the constraints.
    measured : ndarray of int
        Indices of the measured coordinates (into the 9 of ``q``); the rest are unmeasured.
    regularisation : float
        Tikhonov weight of the solve, > 0.

    Returns
    -------
    ndarray, shape (N, n_unmeasured, n_measured)
    """
    x = np.asarray(states, dtype=float)
    meas = np.asarray(measured, dtype=int)
    unmeas = np.setdiff1d(np.arange(NUM_COORDINATES), meas)
    num = x.shape[0]
    jac = np.asarray(contact_point_jacobian(dynamics).map(num)(x.T)).T.reshape(num, 9, 8)
    jac = jac.transpose(0, 2, 1)  # (N, 8 rows: x, y of each point, 9 coordinates)
    forces = np.asarray(dynamics.contact_forces.map(num)(x.T, belt_speed)).T  # (N, 8)
    weights = np.repeat(np.clip(forces[:, 1::2], 0.0, None) / FORCE_SCALE, 2, axis=1)
    root = np.sqrt(weights)[:, :, None]
    gu, gm = root * jac[:, :, unmeas], root * jac[:, :, meas]
    normal = gu.transpose(0, 2, 1) @ gu + regularisation * np.eye(unmeas.size)
    return -np.linalg.solve(normal, gu.transpose(0, 2, 1) @ gm)


__all__ = ["FORCE_SCALE", "REGULARISATION", "contact_point_jacobian", "substitution_matrices"]
