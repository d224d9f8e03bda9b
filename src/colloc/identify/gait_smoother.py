"""The dynamically consistent smoother of a walking record: gait2d fully actuated.

The measured kinematics of a trial are noisy, and no controller guess makes them satisfy the
dynamics: measured states with a guessed controller violate the equations of motion by
about 3e3 and every Newton method diverges from there (``docs/gait.md``). The smoother
instead gives the model enough actuators to follow any motion — the six joint torques and
three residual forces on the trunk, all free trajectories — and finds the motion of the
model closest to the measurements (joint angles, trunk pose, joint torques, each weighted
by ``1 / sigma^2``; the residual forces penalised by their own ``sigma``). It is solved in
stages, each warm-started from the one before:

1. ``start``: the positions low-pass filtered (zero-lag Butterworth, 6 Hz as gait labs do),
   the rates the scheme's own differences of them, and the torques and residuals that make
   every defect zero (inverse dynamics through the scheme, :func:`consistent_completion`);
2. ``backward-euler``: backward Euler at a smoothed contact (friction slip scale
   ``v_s = 0.1`` m/s, where the model's ``0.01`` gives the horizontal contact force a time
   constant of about 5e-5 s against ``h = 0.01`` s and no Newton method converged);
3. ``midpoint``: the second-order midpoint rule from the backward-Euler solution (backward
   Euler is robust but biased at 100 Hz);
4. ``continuation``: the contact's slip scale stepped back to the model's own value, each
   step warm-started from the last; a step that fails is halved.

Each stage reports what it did (:class:`SmootherStage`); a stage that fails raises
:class:`SmootherError` naming it, its solver status and the stages before it.
"""

from __future__ import annotations

import copy
import os
import re
import socket
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import sympy as sm

from colloc.model.symbols import name_of
from colloc.transcription.base import Scheme
from colloc.transcription.midpoint import Midpoint

Progress = Callable[[str, str], None]

#: Slip scales [m/s] of the contact's friction law visited after the midpoint stage, from the
#: smoothed start value down; the model's own value is appended. Measured on 20 s of a noisy
#: trial: 4-10 iterations per step; straight from 0.1 to 0.01 diverged.
CONTINUATION: tuple[float, ...] = (0.05, 0.03, 0.02, 0.015)
#: Newton steps of the zero-defect start of a scheme with stage values inside the intervals,
#: which are nonlinear in them, and the largest defect they leave (Radau IIA on 20 s of a
#: noisy trial: 3.4e-9 after 20 steps, against the 1e-9 of the one-step schemes' start).
COMPLETION_STEPS, COMPLETION_TOL = 20, 1e-8
#: Slip scale [m/s] of the first two stages (what the gait2d authors use since 2026).
START_FRICTION_VELOCITY = 0.1
#: Standard deviation [N, N, N m] per sample of the residual forces on the trunk's x, y and
#: angle: large enough for the start's inverse dynamics, small enough that the fit removes
#: them where the joint torques can do the work.
RESIDUAL_STD: tuple[float, float, float] = (10.0, 10.0, 10.0)
#: IPOPT options of the smoother's solves. Without IPOPT's gradient-based scaling backward
#: Euler converged on 20 s of a noisy trial in 26 iterations; with it, it diverged
#: (regularisation 1e14, defects 1e3) from the same zero-defect start.
IPOPT_OPTIONS: dict[str, Any] = {"nlp_scaling_method": "none"}
#: A stage's solve is stopped as diverging once its objective exceeds this multiple of its
#: start's, or its dual infeasibility exceeds :data:`DIVERGED_DUAL_INFEASIBILITY`. Two
#: continuation steps from 0.015 to 0.01 m/s (27 s and 13 s windows of the seed-71 trial)
#: started at defects of 317 and 354, their objective rose 10-fold within 3 and 8
#: iterations and 70-1000-fold by the 14th, their dual infeasibility past 1e13, and the next
#: iteration's factorisation ran for minutes (over 15 in one case); a failed continuation
#: step is halved (0.0125, then 0.01 converged in 6 iterations each). A stop is recorded as
#: the stage's status ``User_Requested_Stop``.
DIVERGED_OBJECTIVE_FACTOR = 10.0
#: The iteration budget of the last stage at full weights, in continuation steps' budgets.
FULL_WEIGHTS_STEPS = 2
#: The same guard for the second-order scheme's stage, warm-started from backward Euler's
#: nodes: its defects start large (30-90 on 4 s of a marker smoother, whose objective at
#: backward Euler's solution is the markers' noise alone), and its objective rose more than
#: 10-fold in the first iteration before the solve converged (15-190 iterations).
DIVERGED_OBJECTIVE_FACTOR_WARM_START = 1e3
DIVERGED_DUAL_INFEASIBILITY = 1e10


@dataclass(frozen=True)
class SmootherSettings:
    """What determines a smoother run.

    Attributes
    ----------
    cutoff_hz : float
        Cut-off of the zero-lag low-pass Butterworth filter of the start's positions.
    filter_order : int
        Order of that filter (applied forward and backward, so twice the attenuation).
    start_friction_velocity : float
        Contact slip scale ``v_s`` [m/s] of the backward-Euler and midpoint stages.
    continuation : tuple of float
        Intermediate slip scales of the continuation (decreasing, between the start value
        and the model's); the model's own value ends it.
    residual_std : tuple of float
        Standard deviations of the three trunk residual forces per sample.
    max_halvings : int
        How often a failed continuation step is halved before the smoother gives up.
    max_iter : int
        IPOPT iterations per stage.
    step_max_iter : int
        IPOPT iterations per continuation step: a step that needs more is halved (converged
        steps took 5-25; a 30 s window's last step was still iterating after 450 s).
    scheme : Scheme
        The scheme of the stages after backward Euler (default
        :class:`~colloc.transcription.Midpoint`).
    backward_euler_first : bool
        Solve backward Euler first and warm-start ``scheme`` from it (default). False:
        ``scheme`` starts from its own zero-defect start. Measured on 20 s of a motor-noise
        trial: :class:`~colloc.transcription.RadauIIA` so converged in 18 iterations and
        reached the midpoint rule's torques (0.59-0.69 N m rms from the truth against
        0.61-0.69), but took three times as long (126 s against 43 s, both beside another
        job on 2 cores); warm-started from backward Euler it needed 67 iterations.
    window_seconds, overlap_seconds : float
        The backward-Euler stage runs on windows of this length overlapping by this much
        (bounded work per solve, and no solve longer than the one measured to converge),
        stitched in the middle of each overlap for the midpoint stage.
    ipopt_options : mapping
        IPOPT options of every stage's solve (default :data:`IPOPT_OPTIONS`).
    """

    cutoff_hz: float = 6.0
    filter_order: int = 2
    start_friction_velocity: float = START_FRICTION_VELOCITY
    continuation: tuple[float, ...] = CONTINUATION
    residual_std: tuple[float, float, float] = RESIDUAL_STD
    max_halvings: int = 3
    max_iter: int = 300
    step_max_iter: int = 60
    scheme: Scheme = field(default_factory=Midpoint)
    backward_euler_first: bool = True
    window_seconds: float = 10.0
    overlap_seconds: float = 1.0
    ipopt_options: Mapping[str, Any] = field(default_factory=lambda: dict(IPOPT_OPTIONS))

    def problems(self) -> list[str]:
        """Every problem with the settings; empty when they are valid."""
        out = []

        def positive(name: str, value: Any) -> bool:
            ok = (
                isinstance(value, int | float)
                and not isinstance(value, bool)
                and np.isfinite(value)
                and value > 0
            )
            if not ok:
                out.append(f"{name}: expected a positive number, found {value!r}")
            return ok

        positive("cutoff_hz", self.cutoff_hz)
        positive("start_friction_velocity", self.start_friction_velocity)
        if positive("window_seconds", self.window_seconds) and positive(
            "overlap_seconds", self.overlap_seconds
        ):
            if self.overlap_seconds >= 0.5 * self.window_seconds:
                out.append(
                    f"overlap_seconds: expected less than half of window_seconds "
                    f"({self.window_seconds}), found {self.overlap_seconds}"
                )
        for i, s in enumerate(self.residual_std):
            positive(f"residual_std[{i}]", s)
        if len(self.residual_std) != 3:
            out.append(f"residual_std: expected 3 values, found {len(self.residual_std)}")
        for name, value, low in (
            ("filter_order", self.filter_order, 1),
            ("max_halvings", self.max_halvings, 0),
            ("max_iter", self.max_iter, 1),
            ("step_max_iter", self.step_max_iter, 1),
        ):
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                out.append(f"{name}: expected an integer >= {low}, found {value!r}")
        steps = [float(v) for v in self.continuation if positive("continuation", v)]
        if any(b >= a for a, b in zip(steps, steps[1:], strict=False)):
            out.append(f"continuation: expected decreasing slip scales, found {steps}")
        if not isinstance(self.backward_euler_first, bool):
            out.append(
                f"backward_euler_first: expected True or False, found {self.backward_euler_first!r}"
            )
        return out


@dataclass(frozen=True)
class SmootherStage:
    """What one stage of the smoother did.

    Attributes
    ----------
    name : str
        ``start``, ``backward-euler``, the second-order scheme's name (``midpoint``,
        ``trapezoidal``) or ``continuation``.
    scheme : str
        The collocation scheme's class name.
    friction_velocity : float
        The contact's slip scale in this stage [m/s].
    status : str
        IPOPT's status (``Consistent`` for the start).
    success : bool
    iterations : int
    seconds : float
    objective, max_defect : float
        At the stage's end.
    """

    name: str
    scheme: str
    friction_velocity: float
    status: str
    success: bool
    iterations: int
    seconds: float
    objective: float
    max_defect: float

    def describe(self) -> str:
        """One line for progress reports and notes."""
        return (
            f"{self.name} ({self.scheme}, v_s = {self.friction_velocity:g} m/s): "
            f"{self.status}, {self.iterations} iterations, {self.seconds:.1f} s, "
            f"max defect {self.max_defect:.1e}"
        )


class SmootherError(RuntimeError):
    """A smoother stage did not converge; the message names it and the stages before it."""

    def __init__(self, message: str, stages: Sequence[SmootherStage]) -> None:
        super().__init__(message)
        self.stages = tuple(stages)


@dataclass
class SmoothedGait:
    """The smoother's result on the grid of the measurements.

    Attributes
    ----------
    times : ndarray, shape (N,)
    states : ndarray, shape (N, 18)
        ``[q, u]`` in the order of :data:`colloc.gait.metadata.STATE_SIGNAL_NAMES`.
    torques : ndarray, shape (N, 6)
        Joint torques, in the order of :data:`colloc.data.columns.TORQUE_COLUMNS`.
    residuals : ndarray, shape (N, 3)
        Residual forces on the trunk's x [N], y [N] and angle [N m].
    stages : list of SmootherStage
    problem : Problem or None
        The last stage's problem (midpoint at the model's contact); None in a copy sent to
        another process (a CasADi problem does not travel; everything else does).
    z : ndarray
        Its free vector at the solution.
    notes : list of str
        Anything the caller should know about the result.
    scheme : Scheme or None
        The last stage's scheme.
    size : dict
        The last stage's problem's size (:attr:`colloc.Problem.size`).
    seconds : float
        Wall time of :meth:`GaitSmoother.run`, the problems' builds included (the stages'
        ``seconds`` count their solves only).
    process : str
        ``host:pid`` of the process that ran it (which worker, when windows are spread).
    tracking : dict
        What the smoother tracked and with which noise levels (the marker smoother's
        markers, their places in their segments, the plates).
    """

    times: np.ndarray
    states: np.ndarray
    torques: np.ndarray
    residuals: np.ndarray
    stages: list[SmootherStage]
    problem: Any
    z: np.ndarray
    notes: list[str] = field(default_factory=list)
    scheme: Scheme | None = None
    size: dict[str, int] = field(default_factory=dict)
    seconds: float = float("nan")
    process: str = ""
    tracking: dict[str, Any] = field(default_factory=dict)

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state["problem"] = None  # CasADi functions do not pickle
        return state

    def _last_scheme(self) -> Scheme:
        """The last stage's scheme (a result made before ``scheme`` was kept reads its
        problem's)."""
        return self.scheme if self.scheme is not None else self.problem.scheme

    def at_intervals(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Times, states and torques at the interval midpoints (averages of neighbouring
        nodes, which cancel the midpoint rule's odd-even mode in the node rates)."""
        mid = 0.5 * (self.times[1:] + self.times[:-1])
        return (
            mid,
            0.5 * (self.states[1:] + self.states[:-1]),
            0.5 * (self.torques[1:] + self.torques[:-1]),
        )

    def at_dynamics(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Times, states and torques where the last stage's scheme holds the dynamics: the
        nodes for a scheme whose nodes satisfy them (trapezoidal, Hermite-Simpson, Radau IIA),
        else the interval midpoints (:meth:`at_intervals`; the midpoint rule)."""
        if self._last_scheme().dynamics_at_nodes:
            return self.times, self.states, self.torques
        return self.at_intervals()

    def instrument_states(self) -> np.ndarray:
        """The node states for instruments: each speed replaced by its mean over the interval
        that ends at the node where the scheme holds the dynamics between nodes.

        Under the midpoint rule only those means are tied to the positions
        (``(u_(k-1) + u_k) / 2 = (q_k - q_(k-1)) / h``); the node speeds also carry the
        rule's odd-even mode, which costs the light foot almost no torque and so reaches
        0.3-0.6 rad/s in the ankle rates. A node speed lagged one or two samples shares that
        mode with the node speed it instruments; the interval mean does not (docs/gait.md,
        the 8-minute trial). The first node keeps its own speeds.

        Returns
        -------
        ndarray, shape (N, 18)
        """
        out = self.states.copy()
        if self._last_scheme().dynamics_at_nodes or out.shape[0] < 2:
            return out
        speeds = slice(out.shape[1] // 2, None)
        out[1:, speeds] = 0.5 * (self.states[1:, speeds] + self.states[:-1, speeds])
        return out


def lowpass(times: np.ndarray, values: np.ndarray, cutoff_hz: float, order: int = 2) -> np.ndarray:
    """Zero-lag Butterworth low-pass of uniformly sampled columns (forward and backward).

    Parameters
    ----------
    times : ndarray, shape (N,)
        Uniform sample times.
    values : ndarray, shape (N,) or (N, k)
    cutoff_hz : float
        Cut-off frequency, below the Nyquist frequency.
    order : int
        Order of the filter applied in each direction.

    Returns
    -------
    ndarray
        Same shape as ``values``.

    Raises
    ------
    ValueError
        When the sampling is not uniform, the cut-off is not below the Nyquist frequency, or
        the record is too short for the filter's edge padding.
    """
    from colloc.data.filtering import zero_lag_lowpass
    from colloc.identify.direct import uniform_step

    h = uniform_step(times, "the Butterworth filter")
    return zero_lag_lowpass(values, 1.0 / h, cutoff_hz, order, per_pass=True)


def consistent_completion(
    problem: Any,
    z: np.ndarray,
    free: np.ndarray,
    rows: np.ndarray | None = None,
    tol: float = 1e-9,
    max_steps: int = 5,
) -> np.ndarray:
    """Change only the variables ``free`` of ``z`` (least norm) until the defects ``rows``
    (default all) are zero.

    With ``free`` the rates and the actuation of a fully actuated model, this is the inverse
    dynamics of the scheme: the rates become the scheme's differences of the positions and
    the inputs whatever makes the dynamics hold. Each step solves ``J_f d = -c`` for the
    smallest ``d`` (``d = J_f^T (J_f J_f^T)^-1 (-c)``, one sparse factorisation); the
    defects are linear in the rates' kinematic rows and in the inputs, so a few steps do.

    Parameters
    ----------
    problem : Problem
    z : ndarray
        The free vector to complete (not changed).
    free : ndarray of int
        Indices of the variables that may change.
    rows : ndarray of int, optional
        Indices of the defects to zero (e.g. the kinematic rows, to make the rates the
        scheme's differences of the positions); default every defect.
    tol : float
        Largest defect accepted.
    max_steps : int

    Returns
    -------
    ndarray
        The completed free vector.

    Raises
    ------
    ValueError
        When ``free`` cannot zero the defects (``J_f`` has not full row rank, or the steps
        stall above ``tol``), naming the largest defect left.
    """
    nlp, lay = problem.nlp, problem.layout
    jac_rows, jac_cols = nlp.jacobianstructure()
    z = np.array(z, dtype=float)
    free = np.asarray(free)
    chosen = np.arange(lay.num_constraints) if rows is None else np.asarray(rows)
    for _ in range(max_steps):
        c = nlp.constraints(z)[chosen]
        if c.size == 0 or float(np.max(np.abs(c))) <= tol:
            return z
        J = sp.csc_matrix(
            (nlp.jacobian(z), (jac_rows, jac_cols)), shape=(lay.num_constraints, nlp.n)
        )
        Jf = J[chosen][:, free]
        try:
            y = spla.spsolve((Jf @ Jf.T).tocsc(), -c)
        except RuntimeError as exc:  # exactly singular factor
            raise ValueError(f"free variables cannot zero the defects: {exc}") from exc
        if not np.all(np.isfinite(y)):
            break
        z[free] += Jf.T @ y
    c = nlp.constraints(z)[chosen]
    worst = float(np.max(np.abs(c))) if c.size else 0.0
    if not worst <= tol:
        i = int(chosen[np.nanargmax(np.abs(c))])
        raise ValueError(
            f"free variables cannot zero the defects: {worst:.3g} left at "
            f"{lay.describe_constraint(i)}"
        )
    return z


def trial_noise_std(meta: Mapping[str, Any], column: str) -> float:
    """Noise standard deviation of a trial column: the trial's metadata records it
    (``noise: std: group: value``), else the default lab noise of its group
    (:data:`colloc.gait.trials.DEFAULT_NOISE_STD`)."""
    from colloc.gait.trials import COLUMN_NOISE_GROUP, DEFAULT_NOISE_STD

    group = COLUMN_NOISE_GROUP[column]
    noise = meta.get("noise")
    recorded = noise.get("std", {}) if isinstance(noise, Mapping) else {}
    value = recorded.get(group) if isinstance(recorded, Mapping) else None
    return float(value) if value else DEFAULT_NOISE_STD[group]


def torque_equation_noise(meta: Mapping[str, Any]) -> float | None:
    """The noise of each torque equation ``T = T*(phi) - K(phi) s``: the trial's torque
    measurement noise and its recorded motor noise combined (``hypot``), or None when the
    trial records no motor noise."""
    from colloc.data.columns import TORQUE_COLUMNS

    motor = meta.get("motor_noise")
    if not isinstance(motor, Mapping):
        return None
    torque_std = trial_noise_std(meta, TORQUE_COLUMNS[0])
    return float(np.hypot(torque_std, float(motor.get("std", 0.0))))


class GaitSmoother:
    """The fully actuated gait2d smoother of one record (see the module's description).

    Parameters
    ----------
    dynamics : GaitDynamics
        The plant with its constants (:meth:`colloc.gait.orbit.GaitDynamics.build`).
    times : ndarray, shape (N,)
        Uniform sample times.
    positions : ndarray, shape (N, 9)
        Measured trunk x, y, angle and the six joint angles (the model's coordinates).
    belt_speed : ndarray, shape (N,)
    noise_std : ndarray, shape (9,)
        Standard deviation of each position's noise.
    torques : ndarray, shape (N, 6), optional
        Measured joint torques (NaN where missing), tracked when given.
    torque_std : float
        Their noise's standard deviation.
    settings : SmootherSettings, optional
    ground_reactions : ndarray, shape (N, 4), optional
        Measured forward and vertical force on the right foot, then the left (NaN where
        missing), tracked against the contact model's when given.
    grf_std : float
        Their noise's standard deviation [N].
    rates : ndarray, shape (N, 9), optional
        Measured rates of the coordinates (a lab's differentiated markers), tracked when
        given; NaN where missing.
    rate_std : ndarray, shape (9,), optional
        Their noise's standard deviations (required with ``rates``).
    tracked : mapping, optional
        Further measured outputs: symbol -> ``(expression, values, std)``, the expression in
        the model's states and inputs, the values at the nodes (NaN where missing) and
        their noise's standard deviation (e.g. markers and plates,
        :func:`colloc.identify.gait_markers.marker_smoother`).
    track_positions : bool
        Track ``positions`` (default). False: they only make the start (a lab's inverse
        kinematics, when the markers themselves are tracked).
    constants : mapping, optional
        Constants of the plant replacing the dynamics' own (e.g. segment lengths measured
        from the markers).
    early_weights : mapping, optional
        Tracked symbol -> factor (< 1) on its weight in every stage but the last: the last
        stage (``full weights``, at the model's own contact) then tracks it at its full
        weight. Measurements the smoothed contact cannot match (a plate's forces at
        ``v_s = 0.1`` m/s) so guide the early stages without pulling them apart.
    """

    def __init__(
        self,
        dynamics: Any,
        times: np.ndarray,
        positions: np.ndarray,
        belt_speed: np.ndarray,
        noise_std: np.ndarray,
        torques: np.ndarray | None = None,
        torque_std: float = 1.0,
        settings: SmootherSettings | None = None,
        ground_reactions: np.ndarray | None = None,
        grf_std: float = 5.0,
        rates: np.ndarray | None = None,
        rate_std: np.ndarray | None = None,
        tracked: Mapping[sm.Basic, tuple[sm.Expr, np.ndarray, float]] | None = None,
        track_positions: bool = True,
        constants: Mapping[sm.Basic, float] | None = None,
        early_weights: Mapping[sm.Basic, float] | None = None,
    ) -> None:
        from sympy.physics.mechanics import dynamicsymbols

        self.settings = settings or SmootherSettings()
        problems = self.settings.problems()
        self.times = np.asarray(times, dtype=float)
        N = self.times.size
        arrays = {
            "positions": (np.asarray(positions, dtype=float), (N, 9)),
            "belt_speed": (np.asarray(belt_speed, dtype=float), (N,)),
            "noise_std": (np.asarray(noise_std, dtype=float), (9,)),
        }
        if torques is not None:
            arrays["torques"] = (np.asarray(torques, dtype=float), (N, 6))
        if ground_reactions is not None:
            arrays["ground_reactions"] = (np.asarray(ground_reactions, dtype=float), (N, 4))
        if rates is not None:
            arrays["rates"] = (np.asarray(rates, dtype=float), (N, 9))
            arrays["rate_std"] = (np.asarray(rate_std, dtype=float), (9,))
        for name, (value, shape) in arrays.items():
            if value.shape != shape:
                problems.append(f"{name}: expected shape {shape}, found {value.shape}")
            elif name not in ("torques", "ground_reactions", "rates") and not np.all(
                np.isfinite(value)
            ):
                problems.append(f"{name}: expected finite values, found NaN or inf")
        for label in ("noise_std", "rate_std"):
            if label in arrays and not problems and not np.all(arrays[label][0] > 0):
                problems.append(f"{label}: expected positive standard deviations")
        for label, std in (("torque_std", torque_std), ("grf_std", grf_std)):
            if not (np.isfinite(std) and std > 0):
                problems.append(f"{label}: expected a positive number, found {std!r}")
        for y, (_, values, std) in (tracked or {}).items():
            if np.shape(values) != (N,):
                problems.append(f"tracked {y}: expected shape {(N,)}, found {np.shape(values)}")
            if not (np.isfinite(std) and std > 0):
                problems.append(f"tracked {y}: expected a positive std, found {std!r}")
        if not track_positions and not tracked:
            problems.append("track_positions: False needs other outputs to track (tracked=)")
        unknown = [str(c) for c in (constants or {}) if c not in dynamics.constants]
        if unknown:
            problems.append(f"constants: not constants of the plant: {', '.join(unknown)}")
        for y, factor in (early_weights or {}).items():
            if y not in (tracked or {}) or not 0 < factor <= 1:
                problems.append(
                    f"early_weights: expected a factor in (0, 1] of a tracked output, found "
                    f"{y}: {factor!r}"
                )
        if problems:
            raise ValueError("smoother: " + "; ".join(problems))
        self.dynamics = dynamics
        gait, model = dynamics.gait, dynamics.model
        self.positions = arrays["positions"][0]
        self.belt_speed = arrays["belt_speed"][0]
        self.residual_inputs = tuple(dynamicsymbols(f"trunk_residual_{i}") for i in range(3))
        half = model.num_states // 2
        actuated = model.with_disturbances(
            {half + i: w for i, w in enumerate(self.residual_inputs)}
        )
        coordinates = list(model.states[:half])
        measured: dict[sm.Basic, np.ndarray] = {}
        weights: dict[sm.Basic, float] = {}
        if track_positions:
            measured.update(zip(coordinates, self.positions.T, strict=True))
            weights.update(
                {q: 1.0 / s**2 for q, s in zip(coordinates, arrays["noise_std"][0], strict=True)}
            )
        if rates is not None and not problems:
            speeds = list(model.states[half:])
            measured.update(zip(speeds, arrays["rates"][0].T, strict=True))
            weights.update(
                {u: 1.0 / s**2 for u, s in zip(speeds, arrays["rate_std"][0], strict=True)}
            )
        outputs: dict[sm.Basic, sm.Expr] = {y: y for y in measured}
        if torques is not None:
            measured.update(zip(gait.torques, arrays["torques"][0].T, strict=True))
            weights.update({T: 1.0 / torque_std**2 for T in gait.torques})
            outputs.update({T: T for T in gait.torques})
        if ground_reactions is not None:
            # each foot's force: heel plus toe of the contact model
            for j, (side, axis) in enumerate(
                (side, axis) for side in ("right", "left") for axis in (0, 1)
            ):
                values = arrays["ground_reactions"][0][:, j]
                if not np.isfinite(values).any():
                    continue  # a force not measured at all (all NaN) is not tracked
                y = dynamicsymbols(f"{side}_grf_{'xy'[axis]}")
                outputs[y] = sum(
                    (gait.contact_forces[f"{side}_{p}"][axis] for p in ("heel", "toe")),
                    sm.Integer(0),
                )
                measured[y] = values
                weights[y] = 1.0 / grf_std**2
        for y, (expression, values, std) in (tracked or {}).items():
            outputs[y] = expression
            measured[y] = np.asarray(values, dtype=float)
            weights[y] = 1.0 / float(std) ** 2
        self.model = actuated.with_outputs(outputs)
        self._measured, self._weights = measured, weights
        self._constants = dict(constants or {})
        self._early = dict(early_weights or {})
        self._friction = gait.contact_symbols.friction_velocity
        self.model_friction_velocity = float(dynamics.constants[self._friction])

    @classmethod
    def from_trial(
        cls,
        dynamics: Any,
        trial: Any,
        rows: np.ndarray,
        settings: SmootherSettings | None = None,
        use_ground_reactions: bool | None = None,
        use_rates: bool = False,
    ) -> GaitSmoother:
        """The smoother of the samples ``rows`` of a trial (:func:`colloc.data.read_trial`):
        its trunk pose and joint angles, belt speed and, when it has them, the rates, joint
        torques and each foot's ground reaction force, each weighted by its noise level
        (:func:`trial_noise_std`).

        Parameters
        ----------
        dynamics : GaitDynamics
        trial : Trial
        rows : ndarray of int
            Consecutive sample indices.
        settings : SmootherSettings, optional
        use_ground_reactions : bool, optional
            Track the trial's ground reaction forces. Default: when the scheme holds the
            dynamics at the nodes (trapezoidal), where the tracked forces are the ones the
            dynamics feel; with the midpoint rule, forces tracked at the nodes move the node
            states along the rule's odd-even mode, which the dynamics do not see (measured on
            20 s of a noisy trial: the controller's least squares went from 59 % to 83 % error
            in K with them, and from 55 % to 52 % with the trapezoidal rule).
        use_rates : bool
            Track the trial's rate columns (trunk and joint rates, as a lab differentiates its
            markers) when it has them. They pin the node rates, which the midpoint rule's
            odd-even mode otherwise leaves 3-22 deg/s from the truth (with them 2-7 deg/s),
            but the controller's least squares at the interval midpoints did not gain
            (40 s of a noisy trial: K error 53 % without, 55 % with; at the nodes 47 %), so
            they are left out by default.

        Returns
        -------
        GaitSmoother
        """
        from colloc.data.columns import JOINT_ANGLE_COLUMNS, TORQUE_COLUMNS, TRUNK_COLUMNS

        signals = trial.signals.iloc[np.asarray(rows)]
        positions = list(TRUNK_COLUMNS + JOINT_ANGLE_COLUMNS)
        has_torques = all(c in signals.columns for c in TORQUE_COLUMNS)
        forces = [f"{side}_grf_{axis}" for side in ("right", "left") for axis in "xy"]
        from colloc.data.columns import JOINT_RATE_COLUMNS, TRUNK_RATE_COLUMNS

        rate_columns = list(TRUNK_RATE_COLUMNS + JOINT_RATE_COLUMNS)
        has_rates = use_rates and all(c in signals.columns for c in rate_columns)
        chosen = settings or SmootherSettings()
        wanted = (
            chosen.scheme.dynamics_at_nodes
            if use_ground_reactions is None
            else use_ground_reactions
        )
        has_forces = wanted and all(c in signals.columns for c in forces)
        return cls(
            dynamics,
            trial.time[np.asarray(rows)],
            signals[positions].to_numpy(dtype=float),
            signals["belt_speed"].to_numpy(dtype=float),
            np.array([trial_noise_std(trial.metadata, c) for c in positions]),
            signals[list(TORQUE_COLUMNS)].to_numpy(dtype=float) if has_torques else None,
            trial_noise_std(trial.metadata, TORQUE_COLUMNS[0]),
            chosen,
            signals[forces].to_numpy(dtype=float) if has_forces else None,
            trial_noise_std(trial.metadata, forces[0]) if has_forces else 5.0,
            signals[rate_columns].to_numpy(dtype=float) if has_rates else None,
            np.array([trial_noise_std(trial.metadata, c) for c in rate_columns])
            if has_rates
            else None,
        )

    def problem(self, scheme: Any, friction_velocity: float) -> Any:
        """The smoother's collocation problem with ``scheme`` at a contact slip scale (the
        early stages' weights)."""
        from colloc.nlp.problem import Problem

        constants = {**self.dynamics.constants, **self._constants}
        constants[self._friction] = float(friction_velocity)
        return Problem(
            self.model,
            self.times,
            scheme=scheme,
            known_trajectories={self.dynamics.gait.belt_speed: self.belt_speed},
            known_parameters=constants,
            objective=self._tracking(final=False),
            process_noise=dict(zip(self.residual_inputs, self.settings.residual_std, strict=True)),
        )

    def _tracking(self, final: bool) -> Any:
        """The tracking term: at full weights (``final``) or the early stages'."""
        from colloc.nlp.objective import Tracking

        factors = {} if final else self._early
        weights = {y: w * factors.get(y, 1.0) for y, w in self._weights.items()}
        return Tracking(self._measured, weights)

    def start(self, problem: Any) -> np.ndarray:
        """The zero-defect start of ``problem``: filtered positions, the scheme's differences
        as rates, inverse-dynamics torques and residuals (:func:`consistent_completion`)."""
        s = self.settings
        q = lowpass(self.times, self.positions, s.cutoff_hz, s.filter_order)
        u = np.gradient(q, self.times, axis=0)
        z = problem.initial_guess(np.hstack([q, u]))
        lay = problem.layout
        n = self.dynamics.model.num_states
        half = n // 2

        def indices(names: list[str]) -> np.ndarray:
            return np.concatenate([np.asarray(lay.node_indices(name)) for name in names])

        # Kane's first half of the rows is q' - u: solved for the rates alone they make the
        # rates the scheme's differences of the positions; the dynamic rows are then linear
        # in the torques and residuals (inverse dynamics)
        if lay.num_interval_variables:
            # stage values inside the intervals (Radau IIA): completed with the node rates
            # and the actuation, every defect at once
            inside = np.arange(lay.interval_offset, lay.num_variables)
            free = np.concatenate([indices(lay.node_names[half:]), inside])
            return consistent_completion(
                problem, z, free, tol=COMPLETION_TOL, max_steps=COMPLETION_STEPS
            )
        kinematic = np.concatenate(
            [
                b.offset + np.flatnonzero(np.arange(b.size) % b.rows < half)
                for b in lay.blocks
                if b.item == "interval"
            ]
        )
        z = consistent_completion(problem, z, indices(lay.node_names[half:n]), kinematic)
        dynamic = np.setdiff1d(np.arange(lay.num_constraints), kinematic)
        return consistent_completion(problem, z, indices(lay.node_names[n:]), dynamic)

    def run(self, progress: Progress | None = None) -> SmoothedGait:
        """All stages; see the module's description.

        Parameters
        ----------
        progress : callable, optional
            ``progress(stage, detail)`` before and after each stage.

        Returns
        -------
        SmoothedGait

        Raises
        ------
        SmootherError
            When a stage does not converge (a continuation step after its halvings).
        """
        say = progress or (lambda stage, detail: None)
        started = time.perf_counter()
        s = self.settings
        stages: list[SmootherStage] = []
        v0 = s.start_friction_velocity
        midpoint = self.problem(s.scheme, v0)
        name = re.sub(r"(?<=[a-z])(?=[A-Z])", "-", s.scheme.name).lower()  # RadauIIA: radau-iia
        if s.backward_euler_first:
            nodes = self._backward_euler(say, stages)
            say(name, "warm-started from backward Euler")
            z = midpoint.initial_guess(nodes)
        else:
            clock = time.perf_counter()
            say("start", "filtered positions, inverse dynamics through the scheme")
            z = self.start(midpoint)
            stages.append(self._stage("start", midpoint, z, v0, "Consistent", True, 0, clock))
            say(name, f"from its own zero-defect start, v_s = {v0:g} m/s")
        z = self._solve(
            midpoint, z, name, v0, stages, ceiling_factor=DIVERGED_OBJECTIVE_FACTOR_WARM_START
        )
        say(name, stages[-1].describe())

        target = self.model_friction_velocity
        scheduled = [v for v in s.continuation if target < v < v0] + (
            [target] if target < v0 else []
        )
        # (goal, whether the schedule set it): a failed step inserts its halfway point, and
        # the halvings count until the scheduled goal is reached
        pending = [(v, True) for v in scheduled]
        current, halvings = v0, 0
        while pending:
            goal, planned = pending[0]
            say("continuation", f"v_s {current:g} -> {goal:g} m/s")
            self._set_friction(midpoint, goal)
            try:
                z = self._solve(midpoint, z, "continuation", goal, stages, s.step_max_iter)
            except SmootherError:
                if halvings >= s.max_halvings:
                    raise
                say("continuation", f"{stages[-1].describe()}: the step is halved")
                halvings += 1
                pending.insert(0, (0.5 * (current + goal), False))
                continue
            say("continuation", stages[-1].describe())
            pending.pop(0)
            current = goal
            if planned:
                halvings = 0
        notes = []
        if self._early:
            say("full weights", "every tracked signal at its own weight")
            midpoint.replace_data(objective=self._tracking(final=True))
            # a bounded budget: the stage converged in 47-97 iterations where it did, and one
            # that did not ran its 300 in 12 minutes on a 12 s window, its fallback at hand
            stage, z_full = self._attempt(
                midpoint, z, "full weights", current, FULL_WEIGHTS_STEPS * s.step_max_iter
            )
            stages.append(stage)
            say("full weights", stage.describe())
            if stage.success:
                z = z_full
            else:  # the early weights' solution, converged at the model's contact, is kept
                midpoint.replace_data(objective=self._tracking(final=False))
                factors = sorted({f"{f:g}" for f in self._early.values()})
                notes.append(
                    f"smoother: the last stage, every signal at its full weight, did not converge "
                    f"({stage.describe()}): the result is the stage before it, at the model's "
                    f"contact with {', '.join(name_of(y) for y in self._early)} at "
                    f"{' or '.join(factors)} of their weight (their noise taken larger, as the "
                    "model cannot follow them closer)"
                )
        result = self._result(midpoint, z, stages, started)
        if notes:
            result.notes.extend(notes)
        return result

    # ------------------------------------------------------------------ helpers
    def windows(self) -> list[tuple[int, int, int, int]]:
        """The backward-Euler stage's windows: ``(first, stop, keep_first, keep_stop)`` node
        ranges, overlapping by :attr:`SmootherSettings.overlap_seconds`; each window's
        solution is kept from the middle of one overlap to the middle of the next."""
        N = self.times.size
        h = float(np.median(np.diff(self.times)))
        width = int(round(self.settings.window_seconds / h)) + 1
        overlap = int(round(self.settings.overlap_seconds / h))
        if N <= width + overlap:
            return [(0, N, 0, N)]
        count = int(np.ceil((N - overlap) / (width - overlap)))
        firsts = np.round(np.linspace(0, N - width, count)).astype(int)
        stops = firsts + width
        cuts = [0] + [int((stops[k] + firsts[k + 1]) // 2) for k in range(count - 1)] + [N]
        return [
            (int(a), int(b), cuts[k], cuts[k + 1])
            for k, (a, b) in enumerate(zip(firsts, stops, strict=True))
        ]

    def _part(self, first: int, stop: int) -> GaitSmoother:
        """The smoother of nodes ``first:stop``: the same model and settings (derived and
        checked once), the arrays sliced."""
        window = slice(first, stop)
        part = copy.copy(self)
        part.times = self.times[window]
        part.positions = self.positions[window]
        part.belt_speed = self.belt_speed[window]
        part._measured = {y: values[window] for y, values in self._measured.items()}
        return part

    def _backward_euler(self, say: Progress, stages: list[SmootherStage]) -> np.ndarray:
        """The zero-defect start and backward Euler at the smoothed contact, window by
        window; the node values (states and free inputs) of the whole record."""
        from colloc.transcription import BackwardEuler

        v0 = self.settings.start_friction_velocity
        windows = self.windows()
        nodes: np.ndarray | None = None
        for k, (first, stop, keep, keep_stop) in enumerate(windows):
            part = self if len(windows) == 1 else self._part(first, stop)
            label = "" if len(windows) == 1 else f" {k + 1}/{len(windows)}"
            clock = time.perf_counter()
            say("start", f"window{label}: filtered positions, inverse dynamics")
            euler = part.problem(BackwardEuler(), v0)
            z = part.start(euler)
            stages.append(part._stage("start" + label, euler, z, v0, "Consistent", True, 0, clock))
            say("backward-euler", f"window{label}: {stop - first} nodes, v_s = {v0:g} m/s")
            z = part._solve(euler, z, "backward-euler" + label, v0, stages)
            say("backward-euler", stages[-1].describe())
            lay = euler.layout
            X = lay.node_matrix(z)[:, : len(lay.node_names)]
            if nodes is None:
                nodes = np.empty((self.times.size, X.shape[1]))
            nodes[keep:keep_stop] = X[keep - first : keep_stop - first]
        assert nodes is not None
        return nodes

    def _set_friction(self, problem: Any, value: float) -> None:
        constants = dict(problem.known_parameters)
        constants[self._friction] = float(value)
        problem.replace_data(known_parameters=constants)

    def _solve(
        self,
        problem: Any,
        z: np.ndarray,
        name: str,
        v_s: float,
        stages: list[SmootherStage],
        max_iter: int | None = None,
        ceiling_factor: float | None = None,
    ) -> np.ndarray:
        """One stage's solve, recorded in ``stages``; raises :class:`SmootherError` when it
        does not converge (within ``max_iter``, default the settings'), naming it and the
        stages before it. A solve whose objective passes ``ceiling_factor`` (default
        :data:`DIVERGED_OBJECTIVE_FACTOR`) times its start's is stopped as diverging."""
        stage, z_new = self._attempt(problem, z, name, v_s, max_iter, ceiling_factor)
        stages.append(stage)
        if not stage.success:
            done = "; ".join(s.describe() for s in stages[:-1])
            raise SmootherError(
                f"smoother: stage {stage.describe()} did not converge"
                + (f" (after {done})" if done else ""),
                stages,
            )
        return z_new

    def _attempt(
        self,
        problem: Any,
        z: np.ndarray,
        name: str,
        v_s: float,
        max_iter: int | None = None,
        ceiling_factor: float | None = None,
    ) -> tuple[SmootherStage, np.ndarray]:
        clock = time.perf_counter()
        limit = self.settings.max_iter if max_iter is None else max_iter
        factor = DIVERGED_OBJECTIVE_FACTOR if ceiling_factor is None else ceiling_factor
        ceiling = factor * max(float(problem.nlp.objective(z)), 1.0)

        def converging(row: dict[str, float]) -> bool:  # False stops the solve
            dual = row.get("dual_infeasibility", 0.0)
            return bool(row["objective"] <= ceiling and dual <= DIVERGED_DUAL_INFEASIBILITY)

        solution = problem.solve(
            z, progress=converging, **{"max_iter": limit, **self.settings.ipopt_options}
        )
        st = solution.stats
        stage = self._stage(
            name,
            problem,
            solution.z,
            v_s,
            str(st["status"]),
            bool(st["success"]),
            int(st["iterations"]),
            clock,
        )
        return stage, np.asarray(solution.z)

    @staticmethod
    def _stage(
        name: str,
        problem: Any,
        z: np.ndarray,
        v_s: float,
        status: str,
        success: bool,
        iterations: int,
        clock: float,
    ) -> SmootherStage:
        defects = problem.defects(z)
        return SmootherStage(
            name,
            problem.scheme.name,
            float(v_s),
            status,
            success,
            iterations,
            time.perf_counter() - clock,
            float(problem.nlp.objective(z)),
            float(np.max(np.abs(defects))) if defects.size else 0.0,
        )

    def _result(
        self, problem: Any, z: np.ndarray, stages: list[SmootherStage], started: float
    ) -> SmoothedGait:
        lay = problem.layout
        X = lay.node_matrix(z)
        n = self.dynamics.model.num_states

        names = [name_of(r) for r in problem.partition.free_inputs]
        inputs = X[:, n : n + len(names)]
        gait = self.dynamics.gait
        order = [names.index(name_of(T)) for T in gait.torques]
        residual = [names.index(name_of(w)) for w in self.residual_inputs]
        return SmoothedGait(
            self.times,
            X[:, :n].copy(),
            inputs[:, order].copy(),
            inputs[:, residual].copy(),
            stages,
            problem,
            np.asarray(z),
            scheme=problem.scheme,
            size=problem.size,
            seconds=time.perf_counter() - started,
            process=f"{socket.gethostname()}:{os.getpid()}",
        )
