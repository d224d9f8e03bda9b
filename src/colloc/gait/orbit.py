"""Numeric gait dynamics in CasADi and the linearisation ``A(t), B(t)`` along a walking cycle.

Two CasADi forms of the planar gait model (:mod:`colloc.models.gait2d`) with numeric
constants are built once:

* the implicit residual ``F(x', x, r, p) = 0`` of the colloc model (the engine's own form,
  :func:`colloc.nlp.templates.residual_function`), from which the linearisation
  ``A = -F_x'^-1 F_x`` and ``B = -F_x'^-1 F_T`` follows with numeric linear solves;
* the explicit right-hand side ``x' = [u, M(q)^-1 f]`` (a symbolic 9 x 9 solve), which the
  closed-loop simulation integrates.

State ``x = [q, u]`` (18), torques ``T`` (6), belt speed ``v``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import casadi as ca
import numpy as np
import sympy as sm

from colloc.model.model import Model
from colloc.models.gait2d import CONTACT_POINT_NAMES, Gait2D, derive
from colloc.models.gait2d_params import Gait2DParameters, load_parameters
from colloc.nlp.templates import residual_function
from colloc.numeric.bridge import sympy_to_casadi

NUM_COORDINATES = 9
NUM_STATES = 18
NUM_TORQUES = 6


@lru_cache(maxsize=1)
def _plant() -> tuple[Gait2D, Model]:
    gait = derive()
    return gait, gait.to_model()


@dataclass(frozen=True, eq=False)
class GaitDynamics:
    """CasADi functions of the gait model with its constants fixed.

    Attributes
    ----------
    gait : Gait2D
    model : Model
        The open-loop colloc model of ``gait``.
    constants : dict
        Constant symbol -> value used.
    x, torque, belt : casadi.SX
        Symbols of the state (18), joint torques (6) and belt speed (scalar).
    xdot : casadi.SX
        Explicit right-hand side ``x' = [u, M^-1 f]`` in ``x, torque, belt``.
    contact : casadi.SX
        ``Fx, Fy`` at the right heel, right toe, left heel, left toe (8) in ``x, belt``.
    rhs : casadi.Function
        ``(x, T, v) -> x'``.
    contact_forces : casadi.Function
        ``(x, v) -> (8,)`` floor forces.
    contact_positions : casadi.Function
        ``x -> (4,)`` forward positions of the four contact points [m].
    residual_jacobians : casadi.Function
        ``(x', x, T, v) -> (F, dF/dx', dF/dx, dF/dT)`` of the implicit residual.
    """

    gait: Gait2D
    model: Model
    constants: dict[sm.Symbol, float]
    x: ca.SX
    torque: ca.SX
    belt: ca.SX
    xdot: ca.SX
    contact: ca.SX
    rhs: ca.Function
    contact_forces: ca.Function
    residual_jacobians: ca.Function
    contact_positions: ca.Function

    @classmethod
    def build(
        cls,
        params: Gait2DParameters | None = None,
        overrides: Mapping[sm.Symbol, float] | None = None,
    ) -> GaitDynamics:
        """Derive (once per process) and compile the gait model.

        Parameters
        ----------
        params : Gait2DParameters, optional
            Default :func:`colloc.models.gait2d_params.load_parameters` ``()``.
        overrides : mapping, optional
            Constant symbol -> value (see :meth:`Gait2D.constant_values`).

        Returns
        -------
        GaitDynamics
        """
        gait, model = _plant()
        values = gait.constant_values(params or load_parameters(), overrides)
        x, torque, belt = ca.SX.sym("x", NUM_STATES), ca.SX.sym("T", NUM_TORQUES), ca.SX.sym("v")
        leaves: dict[sm.Basic, Any] = dict(
            zip(gait.coordinates + gait.speeds, ca.vertsplit(x), strict=True)
        )
        leaves.update(zip(gait.torques, ca.vertsplit(torque), strict=True))
        leaves[gait.belt_speed] = belt
        leaves.update({s: ca.SX(v) for s, v in values.items()})
        mass = sympy_to_casadi(list(gait.kane.mass_matrix), leaves)
        forcing = sympy_to_casadi(list(gait.kane.forcing), leaves)
        n = NUM_COORDINATES
        mass_sx = ca.reshape(ca.vertcat(*mass), n, n).T
        xdot = ca.vertcat(x[n:], ca.solve(mass_sx, ca.vertcat(*forcing)))
        forces = [f for name in CONTACT_POINT_NAMES for f in gait.contact_forces[name]]
        contact = ca.vertcat(*sympy_to_casadi(forces, leaves))
        points_x = [gait.contact_points[name][0] for name in CONTACT_POINT_NAMES]
        positions = ca.vertcat(*sympy_to_casadi(points_x, leaves))

        F = residual_function(model)
        p = np.array([values[s] for s in model.parameters])
        xd_sym = ca.SX.sym("xd", NUM_STATES)
        r = ca.vertcat(*_model_inputs(gait, model, torque, belt))
        res = F(xd_sym, x, r, p, 0.0, ca.SX(0, 1))
        jacs = ca.Function(
            "F_jac",
            [xd_sym, x, torque, belt],
            [res, ca.jacobian(res, xd_sym), ca.jacobian(res, x), ca.jacobian(res, torque)],
        )
        return cls(
            gait=gait,
            model=model,
            constants=values,
            x=x,
            torque=torque,
            belt=belt,
            xdot=xdot,
            contact=contact,
            rhs=ca.Function("gait_rhs", [x, torque, belt], [xdot]),
            contact_forces=ca.Function("gait_contact", [x, belt], [contact]),
            residual_jacobians=jacs,
            contact_positions=ca.Function("gait_contact_x", [x], [positions]),
        )

    def linearize(
        self, states: np.ndarray, torques: np.ndarray, belt_speed: float | np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """``A = dx'/dx`` and ``B = dx'/dT`` at each of ``k`` operating points.

        Parameters
        ----------
        states : ndarray, shape (k, 18)
        torques : ndarray, shape (k, 6)
        belt_speed : float or ndarray, shape (k,)

        Returns
        -------
        A : ndarray, shape (k, 18, 18)
        B : ndarray, shape (k, 18, 6)

        Raises
        ------
        ValueError
            If the shapes do not match.
        """
        x, tq, v = _operating_points(states, torques, belt_speed)
        A = np.empty((x.shape[0], NUM_STATES, NUM_STATES))
        B = np.empty((x.shape[0], NUM_STATES, NUM_TORQUES))
        for k in range(x.shape[0]):
            xd = np.asarray(self.rhs(x[k], tq[k], v[k])).ravel()
            _, f_xd, f_x, f_r = (
                np.asarray(a) for a in self.residual_jacobians(xd, x[k], tq[k], v[k])
            )
            A[k] = -np.linalg.solve(f_xd, f_x)
            B[k] = -np.linalg.solve(f_xd, f_r)
        return A, B

    def belt_sensitivity(
        self, states: np.ndarray, torques: np.ndarray, belt_speed: float | np.ndarray
    ) -> np.ndarray:
        """``dx'/dv``, the response of the dynamics to the belt speed, at ``k`` points.

        Parameters
        ----------
        states : ndarray, shape (k, 18)
        torques : ndarray, shape (k, 6)
        belt_speed : float or ndarray, shape (k,)

        Returns
        -------
        ndarray, shape (k, 18)

        Raises
        ------
        ValueError
            If the shapes do not match.
        """
        x, tq, v = _operating_points(states, torques, belt_speed)
        fn = ca.Function(
            "belt_sensitivity",
            [self.x, self.torque, self.belt],
            [ca.jacobian(self.xdot, self.belt)],
        )
        return np.asarray(fn.map(x.shape[0])(x.T, tq.T, v[None, :])).T


def _operating_points(
    states: np.ndarray, torques: np.ndarray, belt_speed: float | np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    x = np.atleast_2d(np.asarray(states, float))
    tq = np.atleast_2d(np.asarray(torques, float))
    if x.shape[1:] != (NUM_STATES,) or tq.shape != (x.shape[0], NUM_TORQUES):
        raise ValueError(
            f"states, torques: expected shapes (k, {NUM_STATES}) and (k, {NUM_TORQUES}), "
            f"found {x.shape} and {tq.shape}"
        )
    return x, tq, np.broadcast_to(np.asarray(belt_speed, float), (x.shape[0],))


def _model_inputs(gait: Gait2D, model: Model, torque: ca.SX, belt: ca.SX) -> list[ca.SX]:
    by_symbol = dict(zip(gait.torques, ca.vertsplit(torque), strict=True))
    by_symbol[gait.belt_speed] = belt
    return [by_symbol[r] for r in model.inputs]


def cycle_linearization(
    dynamics: GaitDynamics, cycle: Any, num_samples: int | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``A(t), B(t)`` along a periodic walking cycle.

    Parameters
    ----------
    dynamics : GaitDynamics
    cycle : WalkingCycle
        From :func:`colloc.gait.cycle.find_walking_cycle` (``times``, ``states``,
        ``torques``, ``belt_speed``, ``duration``).
    num_samples : int, optional
        Linearise at this many equally spaced times over the stride (the last repeats the
        first) instead of at the cycle's nodes; states and torques are interpolated
        periodically (cubic, linear).

    Returns
    -------
    times : ndarray, shape (N,)
    A : ndarray, shape (N, 18, 18)
    B : ndarray, shape (N, 18, 6)
    """
    times, states, torques = cycle_samples(cycle, num_samples)
    return (times, *periodic_linearization(dynamics, states, torques, cycle.belt_speed))


def periodic_linearization(
    dynamics: GaitDynamics, states: np.ndarray, torques: np.ndarray, belt_speed: float
) -> tuple[np.ndarray, np.ndarray]:
    """``A, B`` at samples of one period whose last sample repeats the first.

    Parameters
    ----------
    dynamics : GaitDynamics
    states : ndarray, shape (N, 18)
    torques : ndarray, shape (N, 6)
    belt_speed : float

    Returns
    -------
    A : ndarray, shape (N, 18, 18)
    B : ndarray, shape (N, 18, 6)
        With ``A[-1] = A[0]`` and ``B[-1] = B[0]`` exactly.
    """
    A, B = dynamics.linearize(states, torques, belt_speed)
    A[-1], B[-1] = A[0], B[0]
    return A, B


def cycle_samples(
    cycle: Any, num_samples: int | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times, states and torques of a cycle, at its nodes or resampled uniformly."""
    if num_samples is None:
        return np.asarray(cycle.times, float), np.asarray(cycle.states), np.asarray(cycle.torques)
    if isinstance(num_samples, bool) or not isinstance(num_samples, int) or num_samples < 3:
        raise ValueError(f"num_samples: expected an integer >= 3, found {num_samples!r}")
    phase = np.linspace(0.0, 1.0, num_samples)
    tq = np.asarray(cycle.torques, float).copy()
    tq[-1] = tq[0]
    cphase = np.asarray(cycle.times, float) / cycle.duration
    torques = np.column_stack([np.interp(phase, cphase, tq[:, j]) for j in range(NUM_TORQUES)])
    return phase * cycle.duration, cycle.state_at(phase), torques
