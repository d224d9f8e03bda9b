"""A gain-scheduled controller that stabilises a periodic walking cycle.

1. Linearise the gait model along the cycle: ``x' = A(t) x + B(t) T`` (:mod:`.orbit`).
2. Periodic LQR on that linearisation, discretised exactly between the samples
   (:func:`colloc.control.periodic_lqr.sampled_periodic_lqr`; the Riccati ODE of
   :func:`~colloc.control.periodic_lqr.periodic_lqr` blows up numerically on the stiff,
   abruptly switching contact linearisation).
   The hip's forward position ``qax`` is left out: nothing in the dynamics depends on it
   (the floor is uniform), so it is a neutral mode with Floquet multiplier exactly 1 that no
   controller can or needs to remove; the remaining 17 states are regulated.
3. Feedback on fewer states (``s``, e.g. the seed's six joint angles and six joint rates):
   the LQR gains on the states left out are first folded onto the fed-back ones through
   the kinematic constraint of the loaded feet (:mod:`colloc.gait.stance`: a foot on the
   belt makes the stance leg's joint angles a measurement of the trunk angle and the hip's
   position), then the scheduled gains are tuned on the closed loop's LQ cost over a few
   strides (:func:`colloc.control.output_feedback.periodic_output_feedback`). Measured on
   a settled 1.2 m/s cycle with 1201 samples: dropping the columns gives a Floquet radius of
   about 1e5, folding about 5, tuning below 1.
4. Sample ``K_s`` at ``P`` equally spaced phases ``phi_p = p / P`` and choose ``T*`` so
   that ``T = T*(phi) - K_s(phi) s`` is ``T_cycle`` on the cycle (``s = s_cycle``): in
   least squares over the stride (:func:`fitted_tstar`), since between the points the
   product ``K_s(phi) s_cycle(phi)`` is not linear and no ``T*`` makes it exact.
5. Check the Floquet multipliers of the cycle closed with exactly that controller (gains
   linearly interpolated between the ``P`` points as :class:`GainScheduled` does), in
   :attr:`DesignInfo.multipliers`; callers must check :attr:`DesignInfo.spectral_radius`.

Weights (:data:`DEFAULT_STATE_WEIGHTS`): a deviation of 0.05 rad (about 3 deg) in an angle,
0.5 rad/s in a rate, 5 cm in hip height or 0.5 m/s in hip speed costs as much as
:data:`DEFAULT_TORQUE_SCALE` of torque (``R = I / scale^2``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from sympy.physics.mechanics import dynamicsymbols

from colloc.control.gain_scheduled import GainScheduled
from colloc.control.output_feedback import periodic_output_feedback
from colloc.control.periodic_lqr import discrete_monodromy, sampled_periodic_lqr
from colloc.gait.orbit import (
    NUM_COORDINATES,
    NUM_STATES,
    GaitDynamics,
    cycle_samples,
    periodic_linearization,
)
from colloc.gait.stance import substitution_matrices

#: Indices of ``s`` (joint angles ``qb..qg`` then joint rates ``ub..ug``) in ``x = [q, u]``.
JOINT_STATES: np.ndarray = np.r_[3:9, 12:18]
#: The states the LQR regulates: all but the hip's forward position ``qax`` (index 0),
#: unless ``qax`` is fed back too.
REGULATED: np.ndarray = np.arange(1, NUM_STATES)
#: Every state, the hip's forward position on the treadmill included (as vision senses it).
ALL_STATES: np.ndarray = np.arange(NUM_STATES)
#: Named sets of fed-back states (indices into ``[q, u]``): the issue's joint angles and
#: rates; those plus the trunk's orientation and rate (a vestibular sense); everything the
#: LQR regulates.
FEEDBACK_SETS: dict[str, np.ndarray] = {
    "joints": JOINT_STATES,
    "joints+trunk": np.r_[2:9, 11:18],
    "all": REGULATED,
}
#: L-BFGS-B iterations and horizon (strides) of the partial-state gain tuning.
TUNE_ITERATIONS = 150
TUNE_HORIZON = 3

#: Diagonal of ``Q`` over ``x = [q, u]`` (SI units); the ``qax`` entry (0.5 m on the
#: treadmill) counts only when ``qax`` is fed back.
DEFAULT_STATE_WEIGHTS: np.ndarray = np.r_[
    1 / 0.5**2,
    1 / 0.05**2,
    np.full(7, 1 / 0.05**2),
    1 / 0.5**2,
    1 / 0.5**2,
    np.full(7, 1 / 0.5**2),
]
#: Torque weight: ``R = I / DEFAULT_TORQUE_SCALE^2`` [N m]. Measured with full-state
#: feedback on a settled 1.2 m/s cycle and the perturbation record: 5 walks 480 s;
#: 0.5 and 0.16 (softer gains) fall within 3 s; 250 (gains up to 2e4) stalls CVODES.
DEFAULT_TORQUE_SCALE = 5.0


@dataclass(frozen=True, eq=False)
class DesignInfo:
    """What :func:`design_controller` computed on the way.

    Attributes
    ----------
    times : ndarray, shape (N,)
        Linearisation times over one stride.
    full_gain : ndarray, shape (N, 6, 18)
        Periodic LQR gain on all states (zero column for ``qax``).
    lqr_multipliers : ndarray
        Floquet multipliers (17, largest first) with the full-state LQR gain.
    multipliers : ndarray
        Floquet multipliers (17) with the joint-only controller as scheduled at ``P`` points.
    Q, R : ndarray
        The weights used (``Q`` over the 18 states).
    num_periods : int
        Riccati periods integrated.
    """

    times: np.ndarray
    full_gain: np.ndarray
    lqr_multipliers: np.ndarray
    multipliers: np.ndarray
    Q: np.ndarray
    R: np.ndarray
    num_periods: int
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def spectral_radius(self) -> float:
        """Largest multiplier magnitude of the joint-only closed loop (< 1: stable)."""
        return float(np.max(np.abs(self.multipliers)))


def design_controller(
    cycle: Any,
    num_points: int = 50,
    Q: np.ndarray | None = None,
    R: np.ndarray | None = None,
    structure: str | np.ndarray = "full",
    *,
    dynamics: GaitDynamics | None = None,
    num_samples: int | None = None,
    feedback: Sequence[int] | np.ndarray = JOINT_STATES,
    tune_iterations: int = TUNE_ITERATIONS,
    tune_horizon: int = TUNE_HORIZON,
    belt_noise: float = 0.0,
    fit_tstar: bool = True,
) -> tuple[GainScheduled, np.ndarray, np.ndarray, DesignInfo]:
    """Design the known controller for a walking cycle.

    Parameters
    ----------
    cycle : WalkingCycle
        ``times``, ``states (N, 18)``, ``torques (N, 6)``, ``belt_speed``, ``duration``,
        ``state_at(phase)``. Best a cycle the continuous model really follows
        (:func:`colloc.gait.settle.settle_cycle`).
    num_points : int
        ``P``, schedule points over the stride.
    Q : ndarray, shape (18, 18), optional
        State weight (row/column of ``qax`` ignored unless ``qax`` is fed back); default
        ``diag(DEFAULT_STATE_WEIGHTS)``.
    R : ndarray, shape (6, 6), optional
        Torque weight; default ``I / DEFAULT_TORQUE_SCALE^2``.
    structure : {"full", "joint-isolated"} or bool array (6, n_s)
        Gains kept in the controller; the others are zero.
    dynamics : GaitDynamics, optional
        Default :meth:`GaitDynamics.build` ``()``.
    num_samples : int, optional
        Linearise at this many uniform samples of the stride instead of the cycle's nodes.
        Partial-state tuning needs them to resolve heel strike (about 1 ms).
    feedback : sequence of int
        Indices (into the 18 states ``[q, u]``) of the fed-back states ``s``; default the six
        joint angles then the six joint rates (see :data:`FEEDBACK_SETS`). The hip's forward
        position ``qax`` (index 0) only together with every other state
        (:data:`ALL_STATES`): then the LQR regulates it too, holding the walker's place on
        the treadmill; otherwise it is a neutral mode left out of the design.
    tune_iterations, tune_horizon : int
        Iterations and horizon (strides) of the partial-state tuning (step 3 of the module
        description); unused for full-state feedback.
    belt_noise : float
        Intensity [(m/s)^2 s] of white noise on the belt speed that the partial-state tuning
        also rejects (0: tune on the response to initial deviations only).
    fit_tstar : bool
        ``T*`` fitted along the whole stride (:func:`fitted_tstar`, default), or exact at the
        ``P`` points only (``T*_p = T_cycle(phi_p) + K_p s_cycle(phi_p)``). The fit is what a
        coarse schedule needs; with many points on a collocation cycle the points are
        better (measured at 1.4 m/s, ``P`` = 200 on the 60- and 100-node cycles: the fitted
        ``T*`` lost a foot within 1 s, the pointwise one settled the 100-node cycle).

    Returns
    -------
    controller : GainScheduled
        Feedback ``s`` = the states named by ``feedback``, inputs the six joint torques.
    Tstar : ndarray, shape (P, 6)
    K : ndarray, shape (P, 6, n_s)
    info : DesignInfo
        ``extra["tuning"]``: the tuning's :class:`OutputFeedbackResult` fields (partial
        feedback only).

    Raises
    ------
    ValueError
        If ``num_points``, ``Q``, ``R``, ``structure``, ``feedback``, ``tune_iterations``,
        ``tune_horizon`` or ``belt_noise`` is unusable.
    """
    dyn = dynamics or GaitDynamics.build()
    gait = dyn.gait
    fb = np.asarray(feedback, dtype=int)
    if (
        fb.ndim != 1
        or fb.size == 0
        or np.any((fb < 0) | (fb >= NUM_STATES))
        or np.unique(fb).size != fb.size
        or (0 in fb and fb.size != NUM_STATES)
    ):
        raise ValueError(
            f"feedback: expected distinct state indices in [0, {NUM_STATES}), the hip's forward "
            f"position (index 0) only with every other state, found {fb.tolist()}"
        )
    regulated = ALL_STATES if 0 in fb else REGULATED
    states = gait.coordinates + gait.speeds
    controller = GainScheduled(
        num_points,
        feedback=[states[i] for i in fb],
        inputs=gait.torques,
        phase=dynamicsymbols("phi"),
        structure=structure,
    )
    q = np.diag(DEFAULT_STATE_WEIGHTS) if Q is None else np.asarray(Q, float)
    r = np.eye(6) / DEFAULT_TORQUE_SCALE**2 if R is None else np.asarray(R, float)
    problems = []
    if q.shape != (NUM_STATES, NUM_STATES):
        problems.append(f"Q: expected shape ({NUM_STATES}, {NUM_STATES}), found {q.shape}")
    if r.shape != (6, 6):
        problems.append(f"R: expected shape (6, 6), found {r.shape}")
    for name, value in (("tune_iterations", tune_iterations), ("tune_horizon", tune_horizon)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            problems.append(f"{name}: expected an integer >= 1, found {value!r}")
    if not (isinstance(belt_noise, int | float) and np.isfinite(belt_noise) and belt_noise >= 0):
        problems.append(f"belt_noise: expected a finite number >= 0, found {belt_noise!r}")
    if problems:
        raise ValueError("design_controller: " + "; ".join(problems))
    times, states_k, torques_k = cycle_samples(cycle, num_samples)
    A, B = periodic_linearization(dyn, states_k, torques_k, cycle.belt_speed)
    reg = np.ix_(regulated, regulated)
    res = sampled_periodic_lqr(A[:, regulated][:, :, regulated], B[:, regulated], times, q[reg], r)
    full = np.zeros((times.size, 6, NUM_STATES))
    full[:, :, regulated] = res.K

    partial = not np.all(np.isin(regulated, fb))
    folded = (
        _folded_gains(dyn, states_k, float(cycle.belt_speed), times, full, fb)
        if partial
        else full[:, :, fb]
    )
    P = controller.num_points
    phases = np.arange(P) / P
    cphase = times / times[-1]
    K = np.empty((P, 6, fb.size))
    for i, j in np.ndindex(6, fb.size):
        K[:, i, j] = np.interp(phases, cphase, folded[:, i, j])
    K[:, ~controller.mask] = 0.0
    extra: dict[str, Any] = {}
    if partial:
        start = joint_feedback_multipliers(times, A, B, K, fb)
        disturbance = None
        if belt_noise > 0:
            sens = dyn.belt_sensitivity(states_k, torques_k, cycle.belt_speed)
            disturbance = np.sqrt(belt_noise) * sens[:, regulated, None]
        tuned = periodic_output_feedback(
            A[:, regulated][:, :, regulated],
            B[:, regulated],
            times,
            q[reg],
            r,
            np.searchsorted(regulated, fb),  # indices among the regulated states
            K,
            mask=controller.mask,
            horizon=tune_horizon,
            max_iter=tune_iterations,
            disturbance=disturbance,
        )
        K = tuned.K
        extra["tuning"] = {
            "start_spectral_radius": float(np.max(np.abs(start))),
            "log_cost": tuned.log_cost,
            "initial_log_cost": tuned.initial_log_cost,
            "iterations": tuned.iterations,
            "evaluations": tuned.evaluations,
            "message": tuned.message,
            "wall_time": tuned.wall_time,
        }
    if fit_tstar:
        Tstar = fitted_tstar(controller, cycle, K, fb)
    else:
        Tstar = _cycle_torques(cycle, phases) + np.einsum(
            "pij,pj->pi", K, cycle.state_at(phases)[:, fb]
        )

    multipliers = joint_feedback_multipliers(times, A, B, K, fb)
    info = DesignInfo(
        times=times,
        full_gain=full,
        lqr_multipliers=res.floquet_multipliers,
        multipliers=multipliers,
        Q=q,
        R=r,
        num_periods=res.num_periods,
        extra=extra,
    )
    return controller, Tstar, K, info


def fitted_tstar(
    controller: GainScheduled,
    cycle: Any,
    K: np.ndarray,
    feedback: np.ndarray,
    num_phases: int | None = None,
) -> np.ndarray:
    """``T*`` whose schedule reproduces the cycle's torques along the cycle, in least squares.

    The scheduled torque on the cycle, ``T*(phi) - K(phi) s_cycle(phi)`` with ``T*`` and
    ``K`` linear between the ``P`` points, should equal ``T_cycle(phi)`` at every phase.
    Setting ``T*_p = T_cycle(phi_p) + K_p s_cycle(phi_p)`` makes it exact only at the points;
    between them ``K(phi) s_cycle(phi)`` is not linear, and with the LQR's gains and a
    20-point schedule the difference is a torque the cycle never had (measured on a settled
    0.8 m/s cycle: 5-12 N m rms per joint, up to 44 N m, and the walker fell within a stride
    on a constant belt). Here ``T*`` (linear in the points' values) minimises the squared
    difference over ``num_phases`` uniform phases: on that cycle 4-8 N m rms, and it walks.

    Parameters
    ----------
    controller : GainScheduled
        Its schedule's interpolation (:meth:`GainScheduled.interpolate`).
    cycle : WalkingCycle
    K : ndarray, shape (P, 6, n_s)
    feedback : ndarray of int
        Indices of ``s`` in ``[q, u]``.
    num_phases : int, optional
        Phases compared; default ``max(4000, 40 P)``.

    Returns
    -------
    ndarray, shape (P, 6)
    """
    P = controller.num_points
    count = max(4000, 40 * P) if num_phases is None else int(num_phases)
    phases = np.arange(count) / count
    t_cycle = _cycle_torques(cycle, phases)
    s_cycle = cycle.state_at(phases)[:, feedback]
    _, gains = controller.interpolate(phases, np.zeros((P, t_cycle.shape[1])), K)
    target = t_cycle + np.einsum("nij,nj->ni", gains, s_cycle)
    a, b, w = controller.schedule.bracket(phases)
    hats = np.zeros((count, P))
    rows = np.arange(count)
    np.add.at(hats, (rows, a), 1.0 - w)
    np.add.at(hats, (rows, b), w)
    tstar, *_ = np.linalg.lstsq(hats, target, rcond=None)
    return np.asarray(tstar)


def _cycle_torques(cycle: Any, phases: np.ndarray) -> np.ndarray:
    """The cycle's torques at ``phases``, linear between its nodes and periodic."""
    tq = np.asarray(cycle.torques, float).copy()
    tq[-1] = tq[0]
    ccphase = np.asarray(cycle.times, float) / cycle.duration
    return np.column_stack([np.interp(phases, ccphase, tq[:, j]) for j in range(tq.shape[1])])


def _folded_gains(
    dyn: GaitDynamics,
    states: np.ndarray,
    belt_speed: float,
    times: np.ndarray,
    full: np.ndarray,
    fb: np.ndarray,
) -> np.ndarray:
    """Full-state gains folded onto the fed-back states through the stance constraint.

    With ``dq_u = C dq_m`` and ``du_u = C du_m + C' dq_m`` for the unmeasured coordinates
    (:func:`colloc.gait.stance.substitution_matrices`), ``K_x dx`` becomes
    ``(K_qm + K_qu C + K_uu C') dq_m + (K_um + K_uu C) du_m``. Needs each fed-back angle's
    rate fed back too (and no rate without its angle); otherwise the unmeasured columns are
    simply dropped.
    """
    angles = fb[fb < NUM_COORDINATES]
    rates = fb[fb >= NUM_COORDINATES] - NUM_COORDINATES
    if not np.array_equal(np.sort(angles), np.sort(rates)):
        return full[:, :, fb]
    measured = np.sort(angles)
    unmeasured = np.setdiff1d(np.arange(NUM_COORDINATES), measured)
    C = substitution_matrices(dyn, states, belt_speed, measured)
    Cdot = np.gradient(C, times, axis=0)
    kq_u, ku_u = full[:, :, unmeasured], full[:, :, NUM_COORDINATES + unmeasured]
    gain_q = full[:, :, measured] + kq_u @ C + ku_u @ Cdot
    gain_u = full[:, :, NUM_COORDINATES + measured] + ku_u @ C
    by_state = dict(zip(measured.tolist(), np.moveaxis(gain_q, 2, 0), strict=True))
    by_state.update(
        zip((NUM_COORDINATES + measured).tolist(), np.moveaxis(gain_u, 2, 0), strict=True)
    )
    return np.stack([by_state[int(i)] for i in fb], axis=2)


def joint_feedback_multipliers(
    times: np.ndarray,
    A: np.ndarray,
    B: np.ndarray,
    K: np.ndarray,
    feedback: Sequence[int] | np.ndarray = JOINT_STATES,
) -> np.ndarray:
    """Floquet multipliers of ``x' = (A - B K(phi) E) x``.

    Without the hip's forward position ``qax`` (a neutral mode, multiplier exactly 1) unless
    ``feedback`` includes it.

    Parameters
    ----------
    times : ndarray, shape (N,)
        One stride; ``phi = (t - t_0) / (t_N - t_0)``.
    A, B : ndarray, shapes (N, 18, 18), (N, 18, 6)
    K : ndarray, shape (P, 6, n_s)
        Gains at ``phi_p = p / P``, interpolated linearly and periodically like
        :meth:`GainScheduled.interpolate`; ``E`` selects the ``feedback`` states.
    feedback : sequence of int
        Indices of the fed-back states in ``[q, u]``.

    Returns
    -------
    ndarray, shape (17,) or (18,)
        Largest magnitude first.
    """
    P = K.shape[0]
    phi = (times - times[0]) / (times[-1] - times[0]) * P
    a = np.floor(phi).astype(int) % P
    w = phi - np.floor(phi)
    Kt = (1 - w)[:, None, None] * K[a] + w[:, None, None] * K[(a + 1) % P]
    full = np.zeros((times.size, 6, NUM_STATES))
    full[:, :, np.asarray(feedback, dtype=int)] = Kt
    acl = A - B @ full
    acl[-1] = acl[0]
    kept = ALL_STATES if 0 in np.asarray(feedback) else REGULATED
    mu = np.linalg.eigvals(discrete_monodromy(acl[:, kept][:, :, kept], times))
    return mu[np.argsort(-np.abs(mu), kind="stable")]


__all__ = [
    "DEFAULT_STATE_WEIGHTS",
    "DEFAULT_TORQUE_SCALE",
    "ALL_STATES",
    "JOINT_STATES",
    "FEEDBACK_SETS",
    "DesignInfo",
    "design_controller",
    "fitted_tstar",
    "joint_feedback_multipliers",
]
