"""Closed-loop walking: the gait model driven by a gain-scheduled controller on a moving belt.

The controller is ``T = T*(phi) - K(phi) s + n(t)`` with ``s`` the joint angles and rates,
``T*`` and ``K`` interpolated linearly and periodically between ``P`` points (exactly as
:meth:`colloc.control.gain_scheduled.GainScheduled.torque`), and ``n`` optional seeded motor
noise. Its phase is causal, as a real-time controller's would be: ``phi = phi_0`` at each
detected right heel strike (see below) and rises linearly at the rate of the cycle's stride duration (or,
with ``adaptive_rate``, of the previous stride's); if the next heel strike is late, ``phi``
holds at its end value (the schedule's point ``phi_0`` again) until it comes.

``phi`` is reset at a detected strike not to 0 but to ``phi_0``, the phase at which the same
detector fires on the designed cycle itself (:func:`strike_phase`): the cycle's ``phi = 0``
is its first node, and the force threshold is crossed a little later. Resetting to 0 would
shift the whole schedule by ``phi_0`` every stride, a torque the design never saw. The phase
then runs to ``1 + phi_0`` (the schedule repeats periodically).

Heel strikes are detected online, sample by sample, as upward crossings of a vertical
force threshold by a foot's total (heel plus toe) floor force that its heel makes
(:class:`colloc.gait.strikes.StrikeDetector`: a toe grazing the belt is not one); the
crossing time is interpolated between the two samples. The controller learns of a right
heel strike at the first sample after it (a one-sample detection delay).

Integration: the contact is stiff (cubic stiffness 5e7 N/m^3, friction slip scale 1 cm/s),
so the closed-loop right-hand side, with the controller and the belt speed inside, is one
CasADi SX expression integrated by SUNDIALS CVODES (BDF, exact Jacobian by AD) over chunks of
samples. A chunk restarts at each detected right heel strike, because the phase law changes
there. The belt speed and the motor noise are linear between samples. A long walk has that
expression compiled to C first (CasADi's just-in-time compiler with the machine's C compiler,
see :func:`c_compiler`): measured on a 60 s walk, compiling took 20-30 s and each second of
walking then cost about a third of the interpreted expression's.
"""

from __future__ import annotations

import logging
import os
import re
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import casadi as ca
import numpy as np

from colloc.data.belt import belt_position
from colloc.gait.design import JOINT_STATES
from colloc.gait.falls import describe_fall, describe_turn
from colloc.gait.orbit import NUM_STATES, NUM_TORQUES, GaitDynamics
from colloc.gait.strikes import (
    HEEL_STRIKE_THRESHOLD,
    MIN_STRIDE_INTERVAL,
    StrikeDetector,
    foot_ground_reactions,
    strike_phase,
    vertical_foot_forces,
)

logger = logging.getLogger(__name__)

#: Trunk or joint angle [rad] beyond which a walk is lost: a half turn (a simulation whose
#: ankle spun to 22 rad kept its hip in range and was caught only by the trial writer).
MAX_SEGMENT_ANGLE = np.pi

#: Samples per integrator call (a call restarts early at a right heel strike).
CHUNK_SAMPLES = 25

#: Walks at least this long [s] compile their right-hand side to C when a C compiler is
#: found: compiling costs 20-30 s, and interpreted walking about 0.6 s per second of walk
#: against 0.2 s compiled (2 cores, shared), so below a minute it does not pay.
COMPILE_MIN_SECONDS = 60.0
#: Optimisation flag for the compiled right-hand side: -O1 compiles the stiff contact's
#: large expression in a fraction of -O2's time for most of its speed.
COMPILE_FLAGS = ("-O1",)


def c_compiler() -> str | None:
    """The C compiler CasADi's JIT would call: ``$CC`` if set, else ``gcc`` or ``cc``.

    Returns
    -------
    str or None
        Its full path, or None if none is installed.
    """
    names = [os.environ["CC"]] if os.environ.get("CC") else ["gcc", "cc"]
    for name in names:
        path = shutil.which(name)
        if path:
            return path
    return None


@dataclass
class ClosedLoopRecord:
    """A simulated walking trial sampled at a fixed rate.

    Attributes
    ----------
    times : ndarray, shape (N,)
    states : ndarray, shape (N, 18)
        ``[q, u]`` of the gait model.
    torques : ndarray, shape (N, 6)
        Applied joint torques ``Tb .. Tg`` (controller output plus motor noise).
    contact_forces : ndarray, shape (N, 8)
        ``Fx, Fy`` on the right heel, right toe, left heel, left toe [N].
    belt_speed, belt_position : ndarray, shape (N,)
    right_heel_strikes, left_heel_strikes : ndarray
        Detected heel-strike times [s].
    phase : ndarray, shape (N,)
        The controller's unwrapped phase (strides since the start plus ``phi``).
    ground_reactions : ndarray, shape (N, 6) or None
        Each foot's forward and vertical force and centre of pressure
        (:func:`colloc.gait.strikes.foot_ground_reactions`).
    fine_times, fine_states, fine_contact_forces : ndarray or None
        With ``substeps`` > 1 in :func:`simulate_walking`: the same walk's states and contact
        forces at ``substeps`` times the sample rate (a lab's force plates run faster than
        its cameras), from the same integration.
    fell : bool
        True if the hip height left ``hip_height_range`` or the integration failed.
    message : str
    stats : dict
        ``wall_time`` [s], ``realtime_factor`` (simulated s per wall s), ``num_strides``,
        ``num_calls``.
    """

    times: np.ndarray
    states: np.ndarray
    torques: np.ndarray
    contact_forces: np.ndarray
    belt_speed: np.ndarray
    belt_position: np.ndarray
    right_heel_strikes: np.ndarray
    left_heel_strikes: np.ndarray
    phase: np.ndarray
    fell: bool
    message: str
    stats: dict[str, Any] = field(default_factory=dict)
    ground_reactions: np.ndarray | None = None
    fine_times: np.ndarray | None = None
    fine_states: np.ndarray | None = None
    fine_contact_forces: np.ndarray | None = None

    @property
    def vertical_grf(self) -> np.ndarray:
        """Total vertical floor force on the right and left foot, shape (N, 2) [N]."""
        return vertical_foot_forces(self.contact_forces)


def _schedule_window(P: int, chunk: int, h: float, nominal: float) -> int:
    """Schedule points one chunk can touch: its phase span at the fastest rate, plus 2."""
    fastest = 1.0 / (0.7 * nominal)  # the lower clip of _next_duration
    return min(2 * P + 1, int(np.ceil(fastest * chunk * h * P)) + 2)


def _closed_loop_integrator(
    dyn: GaitDynamics,
    P: int,
    h: float,
    chunk: int,
    rtol: float,
    feedback: np.ndarray,
    phi0: float,
    window: int,
    substeps: int = 1,
    compiler: str | None = None,
) -> tuple[ca.Function, ca.Function]:
    """CVODES over ``chunk`` samples.

    Parameters ``[a, b, p0, v_0..v_C, n_0..n_C, T*_window, K_window]``: the schedule enters
    as the ``window`` points ``p0 .. p0 + window - 1`` the chunk's phase can reach, not the
    whole table, so the cost of the right-hand side does not grow with ``P``. With a
    ``compiler`` (a path) the right-hand side and its Jacobian are compiled to C.
    """
    nk = NUM_TORQUES * feedback.size
    tau = ca.SX.sym("tau")
    a, b, p0 = ca.SX.sym("a"), ca.SX.sym("b"), ca.SX.sym("p0")
    v = ca.SX.sym("v", chunk + 1)
    noise = ca.SX.sym("n", NUM_TORQUES, chunk + 1)
    tstar_table = ca.SX.sym("Tstar", NUM_TORQUES, window)
    k_table = ca.SX.sym("K", nk, window)
    phi = ca.fmin(a + b * tau, 1.0 + phi0)
    # Hat functions: weight of schedule point p0 + j.
    hats = ca.fmax(0, 1 - ca.fabs(phi * P - p0 - ca.DM(np.arange(window))))
    t_star = ca.mtimes(tstar_table, hats)
    gain = ca.reshape(ca.mtimes(k_table, hats), feedback.size, NUM_TORQUES).T
    sample_hats = ca.fmax(0, 1 - ca.fabs(tau / h - ca.DM(np.arange(chunk + 1))))
    belt = ca.dot(v, sample_hats)
    s = dyn.x[feedback.tolist()]
    torque = t_star - ca.mtimes(gain, s) + ca.mtimes(noise, sample_hats)
    ode = ca.substitute(dyn.xdot, ca.vertcat(dyn.torque, dyn.belt), ca.vertcat(torque, belt))
    p = ca.vertcat(a, b, p0, v, ca.vec(noise), ca.vec(tstar_table), ca.vec(k_table))
    grid = list(h / substeps * np.arange(1, chunk * substeps + 1))
    opts: dict[str, Any] = {"abstol": rtol * 1e-2, "reltol": rtol, "max_num_steps": 100000}
    if compiler is not None:
        opts |= {
            "jit": True,
            "compiler": "shell",
            "jit_options": {"compiler": compiler, "flags": list(COMPILE_FLAGS)},
        }
    integ = ca.integrator(
        "walk", "cvodes", {"x": dyn.x, "p": p, "t": tau, "ode": ode}, 0.0, grid, opts
    )
    torque_fn = ca.Function("torque", [dyn.x, tau, p], [torque])
    return integ, torque_fn


def _window_values(
    Tstar: np.ndarray, K: np.ndarray, phase: float, window: int
) -> tuple[float, np.ndarray]:
    """First point ``p0`` and the (periodic) schedule values at ``p0 .. p0 + window - 1``."""
    P = Tstar.shape[0]
    p0 = int(np.floor(phase * P))
    rows = np.arange(p0, p0 + window) % P
    return float(p0), np.concatenate([Tstar[rows].ravel(), K.reshape(P, -1)[rows].ravel()])


def simulate_walking(
    cycle: Any,
    Tstar: np.ndarray,
    K: np.ndarray,
    duration: float,
    belt_speed: tuple[np.ndarray, np.ndarray] | None = None,
    *,
    dynamics: GaitDynamics | None = None,
    seed: int | None = 0,
    sample_rate: float = 100.0,
    torque_noise: float = 0.0,
    hip_height_range: tuple[float, float] | None = None,
    threshold: float = HEEL_STRIKE_THRESHOLD,
    rtol: float = 1e-6,
    initial_state: np.ndarray | None = None,
    feedback: np.ndarray | None = None,
    adaptive_rate: bool = False,
    stride_duration: float | None = None,
    phase_at_strike: float | None = None,
    initial_phase: float = 0.0,
    substeps: int = 1,
    jit: bool | None = None,
) -> ClosedLoopRecord:
    """Simulate walking on a treadmill under the gain-scheduled controller.

    Parameters
    ----------
    cycle : WalkingCycle or None
        The periodic cycle the controller was designed for (initial state at phase 0, first
        stride duration, belt speed when ``belt_speed`` is None). None for a controller
        identified from a trial: then ``belt_speed``, ``initial_state``,
        ``hip_height_range``, ``stride_duration`` and ``phase_at_strike`` are required.
    Tstar : ndarray, shape (P, 6)
    K : ndarray, shape (P, 6, n_s)
        The controller schedule (e.g. from :func:`colloc.gait.design.design_controller`).
    duration : float
        Simulated time [s].
    belt_speed : (times, speed), optional
        Belt speed samples, linearly interpolated (e.g. :func:`perturbation_belt_speed`);
        must cover ``[0, duration]``. Default: constant ``cycle.belt_speed``.
    dynamics : GaitDynamics, optional
    seed : int, optional
        Seeds the motor noise.
    sample_rate : float
        [Hz] of the record and of the online heel-strike detection.
    torque_noise : float
        Standard deviation [N m] of independent Gaussian motor noise on each joint torque,
        drawn at every sample and linear in between (0: none).
    hip_height_range : (low, high), optional
        Walking range of ``qay`` [m]; leaving it counts as a fall. Default: the cycle's
        hip-height range widened by 0.15 m each way.
    threshold : float
        Heel-strike force threshold [N].
    rtol : float
        Relative tolerance of CVODES.
    initial_state : ndarray, shape (18,), optional
        Default: the cycle's state at phase 0.
    feedback : ndarray of int, optional
        Indices of the fed-back states ``s`` in ``[q, u]``, as given to the design; default
        the joint angles then rates.
    adaptive_rate : bool
        Let ``phi`` rise at the rate of the previous stride's duration (clipped to 0.7-1.3
        times the cycle's) instead of the cycle's. Off by default: measured on a 60-node
        cycle, a stride 1 % long made the next schedule 1 % slower, and the strides grew by
        1.5 % each until the walker fell after 8 strides; at the fixed rate it walks on.
    stride_duration : float, optional
        [s] at whose rate ``phi`` rises; default the cycle's duration.
    phase_at_strike : float, optional
        ``phi_0`` in ``[0, 1)``, the phase the controller resets to at a detected right heel
        strike; default where the detector fires on the cycle
        (:func:`colloc.gait.strikes.strike_phase`); 0 for a controller scheduled on the
        phase a gait lab computes from heel strikes.
    initial_phase : float
        ``phi`` at time 0 (default 0, the cycle's start).
    substeps : int
        Also keep the states and contact forces at ``substeps`` times the sample rate
        (``fine_*`` in the record), read from the same integration: CVODES steps as its error
        control asks and interpolates at each output time, so the walk at the samples is the
        same for any ``substeps`` (checked in ``tests/gait/test_closed_loop.py``). The
        controller's phase, the noise, the belt and the heel-strike detection stay at the
        sample rate.
    jit : bool, optional
        Compile the right-hand side to C first (the same expression, evaluated faster; the
        walks agree to CVODES' tolerance). Default: when ``duration`` is at least
        :data:`COMPILE_MIN_SECONDS` and :func:`c_compiler` finds a compiler. True without a
        compiler is an error; a compilation that fails falls back to the interpreted
        expression with a warning. ``stats["compiled"]`` of the record says which ran.

    Returns
    -------
    ClosedLoopRecord

    Raises
    ------
    ValueError
        On unusable arguments (all reported at once).
    """
    Tstar, K = np.asarray(Tstar, float), np.asarray(K, float)
    _check(Tstar, K, duration, sample_rate, torque_noise, belt_speed)
    if cycle is None:
        missing = [
            name
            for name, value in (
                ("belt_speed", belt_speed),
                ("initial_state", initial_state),
                ("hip_height_range", hip_height_range),
                ("stride_duration", stride_duration),
                ("phase_at_strike", phase_at_strike),
            )
            if value is None
        ]
        if missing:
            raise ValueError(f"cycle: None needs {missing} given instead, found them missing")
    nominal = float(cycle.duration if stride_duration is None else stride_duration)
    if not (np.isfinite(nominal) and nominal > 0):
        raise ValueError(f"stride_duration: expected a positive number, found {nominal}")
    dyn = dynamics or GaitDynamics.build()
    h = 1.0 / sample_rate
    num = int(round(duration * sample_rate)) + 1
    times = np.arange(num) * h
    if belt_speed is None:
        v_all = np.full(num, float(cycle.belt_speed))
    else:
        v_all = np.interp(times, *belt_speed)
    # the speed the walk was made for, against which the belt's excursions are told
    walking_speed = float(np.median(v_all) if cycle is None else cycle.belt_speed)
    rng = np.random.default_rng(seed)
    noise_all = torque_noise * rng.standard_normal((num + CHUNK_SAMPLES, NUM_TORQUES))
    if hip_height_range is None:
        qay = np.asarray(cycle.states)[:, 1]
        hip_height_range = (float(qay.min()) - 0.15, float(qay.max()) + 0.15)
    fb = JOINT_STATES if feedback is None else np.asarray(feedback, dtype=int)
    if K.shape[2] != fb.size:
        raise ValueError(f"K: has {K.shape[2]} gain columns but feedback names {fb.size} states")
    phi0 = strike_phase(cycle, threshold) if phase_at_strike is None else float(phase_at_strike)
    window = _schedule_window(Tstar.shape[0], CHUNK_SAMPLES, h, nominal)
    if isinstance(substeps, bool) or not isinstance(substeps, int | np.integer) or substeps < 1:
        raise ValueError(f"substeps: expected a positive int, found {substeps!r}")
    integ, torque_fn, compiled = _integrator(
        partial(
            _closed_loop_integrator,
            dyn,
            Tstar.shape[0],
            h,
            CHUNK_SAMPLES,
            rtol,
            fb,
            phi0,
            window,
            int(substeps),
        ),
        _compiler_for(jit, duration),
    )

    x0 = cycle.state_at(0.0) if initial_state is None else np.asarray(initial_state, float)
    states = np.empty((num, NUM_STATES))
    states[0] = x0
    phase = np.zeros(num)
    torques = np.zeros((num, NUM_TORQUES))
    stride_duration, stride_count = nominal, 0
    stride_start = -float(initial_phase) * stride_duration
    strikes: dict[str, list[float]] = {"right": [], "left": []}
    detectors = {side: StrikeDetector(threshold) for side in strikes}
    fy = np.zeros((num, 4))  # right and left foot, right and left heel
    fy[0] = _foot_forces(dyn, x0, v_all[0])
    fine: list[np.ndarray] = [x0[None, :]]
    fell, message, calls = False, "walked the whole duration", 0
    start_wall = time.perf_counter()
    i = 0  # last accepted sample
    while i < num - 1:
        a = (times[i] - stride_start) / stride_duration
        b = 1.0 / stride_duration
        seg_v = _padded(v_all, i, CHUNK_SAMPLES + 1)
        seg_n = _padded(noise_all, i, CHUNK_SAMPLES + 1)
        p0, table = _window_values(Tstar, K, min(a, 1.0 + phi0), window)
        p = np.concatenate([[a, b, p0], seg_v, seg_n.T.ravel(order="F"), table])
        try:
            out = np.asarray(integ(x0=states[i], p=p)["xf"]).T
        except RuntimeError as exc:
            fell, message = True, f"integration failed at t = {times[i]:.3f} s: {_solver_says(exc)}"
            break
        calls += 1
        torques[i] = np.asarray(torque_fn(states[i], 0.0, p)).ravel()
        phase[i] = stride_count + min(a, 1.0 + phi0)
        restart, base = False, i
        for j in range(1, min(CHUNK_SAMPLES, num - 1 - base) + 1):
            k = base + j
            states[k] = out[j * substeps - 1]
            tau = j * h
            torques[k] = np.asarray(torque_fn(states[k], tau, p)).ravel()
            phase[k] = stride_count + min(a + b * tau, 1.0 + phi0)
            fy[k] = _foot_forces(dyn, states[k], v_all[k])
            cause = _lost(states[k], hip_height_range)
            if cause is not None:
                fell = True
                message = describe_fall(
                    cause, times, v_all, k, len(strikes["right"]), walking_speed
                )
                i = k
                break
            for col, side in enumerate(("right", "left")):
                crossing = detectors[side].update(
                    times[k - 1], times[k], fy[k - 1, col], fy[k, col], fy[k, 2 + col]
                )
                if crossing is None or (
                    strikes[side] and crossing - strikes[side][-1] < MIN_STRIDE_INTERVAL
                ):
                    continue
                strikes[side].append(crossing)
                if side == "right":
                    # The first strike ends a stride that began before the record did.
                    measured = crossing - strikes[side][-2] if len(strikes[side]) > 1 else np.inf
                    if adaptive_rate:
                        stride_duration = _next_duration(measured, nominal)
                    # stride_start: when phi was 0, so that phi = phi0 at the crossing.
                    stride_start = crossing - phi0 * stride_duration
                    stride_count += 1
                    phase[k] = stride_count + (times[k] - stride_start) / stride_duration
                    restart = True
            i = k
            if restart:
                break
        if substeps > 1:
            fine.append(out[: (i - base) * substeps])
        if fell:
            break
    wall = time.perf_counter() - start_wall
    last = i + 1
    contact = np.asarray(dyn.contact_forces.map(last)(states[:last].T, v_all[:last])).T
    contact_x = np.asarray(dyn.contact_positions.map(last)(states[:last].T)).T
    fine_parts = {}
    if substeps > 1:
        fine_states = np.concatenate(fine)
        fine_times = np.arange(len(fine_states)) * (h / substeps)
        fine_v = np.interp(fine_times, times, v_all)
        fine_parts = {
            "fine_times": fine_times,
            "fine_states": fine_states,
            "fine_contact_forces": np.asarray(
                dyn.contact_forces.map(fine_times.size)(fine_states.T, fine_v[None, :])
            ).T,
        }
    record = ClosedLoopRecord(
        times=times[:last],
        states=states[:last],
        torques=torques[:last],
        contact_forces=contact,
        ground_reactions=foot_ground_reactions(contact, contact_x),
        belt_speed=v_all[:last],
        belt_position=belt_position(times[:last], v_all[:last]),
        right_heel_strikes=np.array(strikes["right"]),
        left_heel_strikes=np.array(strikes["left"]),
        phase=phase[:last],
        fell=fell,
        message=message,
        **fine_parts,
        stats={
            "wall_time": wall,
            "realtime_factor": times[last - 1] / wall if wall > 0 else float("inf"),
            "num_strides": len(strikes["right"]),
            "num_calls": calls,
            "compiled": compiled,
        },
    )
    logger.info("simulate_walking: %s (%.1f s wall)", message, wall)
    return record


def _compiler_for(jit: bool | None, duration: float) -> str | None:
    """The compiler to use, None for the interpreted right-hand side (see ``jit``)."""
    if jit is not None and not isinstance(jit, bool):
        raise ValueError(f"jit: expected True, False or None, found {jit!r}")
    if jit is False:
        return None
    compiler = c_compiler()
    if jit and compiler is None:
        raise ValueError(
            "jit: True needs a C compiler, found none ($CC, gcc or cc on the PATH); "
            "install one or pass jit=None"
        )
    if jit is None and duration < COMPILE_MIN_SECONDS:
        return None
    return compiler


def _integrator(
    build: Callable[..., tuple[ca.Function, ca.Function]], compiler: str | None
) -> tuple[ca.Function, ca.Function, bool]:
    """The chunk integrator from ``build`` (:func:`_closed_loop_integrator` with all but
    ``compiler`` given), compiled with ``compiler`` if given and it works."""
    if compiler is not None:
        try:
            return (*build(compiler=compiler), True)
        except RuntimeError as error:
            logger.warning(
                "simulate_walking: compiling the right-hand side with %s failed (%s); "
                "walking with the interpreted expression",
                compiler,
                str(error).strip().splitlines()[-1][:200],
            )
    return (*build(), False)


def _lost(state: np.ndarray, hip_height_range: tuple[float, float]) -> str | None:
    """What of ``state`` says the walk is lost, in words (None while it is walking)."""
    low, high = hip_height_range
    if not low <= state[1] <= high:
        where = "dropped" if state[1] < low else "rose"
        return f"the hip {where} to {state[1]:.3f} m (walking range {low:.3f}-{high:.3f} m)"
    spun = np.flatnonzero(np.abs(state[2:9]) > MAX_SEGMENT_ANGLE)
    if spun.size:  # a joint that turned over: the walk is lost even if the hip held
        index = int(spun[0]) + 2
        return describe_turn(index, float(state[index]), MAX_SEGMENT_ANGLE)
    return None


def _next_duration(measured: float, nominal: float) -> float:
    if not np.isfinite(measured):
        return nominal
    # A stride far from nominal is a detection artefact or a stumble; do not let it
    # distort the next stride's phase rate beyond a plausible range.
    return float(np.clip(measured, 0.7 * nominal, 1.3 * nominal))


def _foot_forces(dyn: GaitDynamics, x: np.ndarray, v: float) -> np.ndarray:
    """Vertical force on the right and left foot, then on the right and left heel."""
    f = np.asarray(dyn.contact_forces(x, v)).ravel()
    return np.array([f[1] + f[3], f[5] + f[7], f[1], f[5]])


def _padded(values: np.ndarray, start: int, count: int) -> np.ndarray:
    seg = values[start : start + count]
    if seg.shape[0] < count:
        pad = np.repeat(seg[-1:], count - seg.shape[0], axis=0)
        seg = np.concatenate([seg, pad], axis=0)
    return seg


def _check(
    Tstar: np.ndarray,
    K: np.ndarray,
    duration: Any,
    sample_rate: Any,
    torque_noise: Any,
    belt_speed: Any,
) -> None:
    problems = []
    if Tstar.ndim != 2 or Tstar.shape[1] != NUM_TORQUES or Tstar.shape[0] < 2:
        problems.append(
            f"Tstar: expected shape (P, {NUM_TORQUES}) with P >= 2, found {Tstar.shape}"
        )
    elif K.ndim != 3 or K.shape[:2] != (Tstar.shape[0], NUM_TORQUES):
        problems.append(
            f"K: expected shape ({Tstar.shape[0]}, {NUM_TORQUES}, n_s), found {K.shape}"
        )
    for name, value in (("duration", duration), ("sample_rate", sample_rate)):
        if not (isinstance(value, int | float) and np.isfinite(value) and value > 0):
            problems.append(f"{name}: expected a positive finite number, found {value!r}")
    if not (
        isinstance(torque_noise, int | float) and np.isfinite(torque_noise) and torque_noise >= 0
    ):
        problems.append(f"torque_noise: expected a non-negative number, found {torque_noise!r}")
    if belt_speed is not None:
        t, v = (np.asarray(a, float) for a in belt_speed)
        if t.ndim != 1 or t.shape != v.shape or t.size < 2:
            problems.append(
                f"belt_speed: expected (times, speed) of equal 1-D shapes, found {t.shape}, {v.shape}"
            )
        elif isinstance(duration, int | float) and (t[0] > 0 or t[-1] < duration):
            problems.append(
                f"belt_speed: expected samples covering [0, {duration}] s, found "
                f"[{t[0]}, {t[-1]}] s"
            )
    if problems:
        raise ValueError("simulate_walking: " + "; ".join(problems))


__all__ = ["ClosedLoopRecord", "simulate_walking"]


def _solver_says(error: Exception) -> str:
    """The integrator's own words from a CasADi error (its last line: CasADi's call chain
    above it names source files, not the problem)."""
    lines = [line.strip() for line in str(error).splitlines() if line.strip()]
    last = lines[-1] if lines else repr(error)
    quoted = re.search(r'returned "([A-Z_]+)"', last)
    if quoted and quoted.group(1) == "CV_TOO_MUCH_WORK":
        return "CVODES took too many steps (CV_TOO_MUCH_WORK): the closed loop diverged"
    return f"CVODES: {quoted.group(1)}" if quoted else last
