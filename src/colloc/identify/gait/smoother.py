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
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
import sympy as sm

from colloc.identify.gait.smoother_results import SmoothedGait, SmootherError, SmootherStage
from colloc.identify.gait.smoother_settings import (
    COMPLETION_STEPS,
    COMPLETION_TOL,
    DIVERGED_OBJECTIVE_FACTOR_WARM_START,
    FULL_WEIGHTS_STEPS,
    PARAMETER_PASSES,
    PARAMETER_TOL,
    Progress,
    SmootherSettings,
)
from colloc.identify.gait.smoother_solve import attempt_stage, stage_record
from colloc.identify.gait.smoother_start import consistent_completion, lowpass
from colloc.identify.gait.trial_noise import trial_noise_std
from colloc.model.symbols import name_of


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
        :func:`colloc.identify.gait.markers.marker_smoother`).
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
    output_parameters : mapping, optional
        Constants that only the ``tracked`` expressions hold, estimated with the motion:
        symbol -> ``(start, prior_std)``, each under a Gaussian prior about its start
        (:class:`colloc.nlp.objective.ParameterPrior`), e.g. where a marker sits in its
        segment. They stay at their starts (known) until the contact is the model's and
        every signal at its weight; then they are estimated by alternating passes
        (``parameter_update``, then the last stage solved again), and the result's
        :attr:`SmoothedGait.parameters` and ``parameter_sd`` hold the estimates and their
        posterior standard deviations. Estimated jointly with the motion instead, in one
        problem, they broke the solver on OpenSim's real walk (a 10 mm prior): free from
        the start, backward Euler ran its 300 iterations with defects of 27; free in a last
        stage only, 420 iterations (6 minutes) did not converge. On 3 s of a simulated walk
        both ways reach the same places.
    parameter_update : callable, optional
        With ``output_parameters``: ``parameter_update(states) -> {symbol: value}``, their
        maximum a posteriori values given the node states ``(N, 18)`` (for outputs linear in
        them, as a marker's place is, the weighted least squares with the prior).
    node_mean_inputs : bool
        The result's joint torques and residual forces are determined in pairs of nodes only
        (:attr:`~colloc.identify.gait.smoother_results.SmoothedGait.inputs_in_pairs`), for a
        smoother that measures no torques under the trapezoidal rule: its defects tie the
        node accelerations only in pairs (``u_(k+1) - u_k = h (a_k + a_(k+1)) / 2``), so an
        acceleration alternating node to node moves no state, and the torques that make it
        alternate with it. Measured on 4 s of a simulated walk's lab export: the node
        torques 5.1-8.2 N m RMS from the truth with successive differences changing sign at
        46-68 % of the nodes (the truth's 16-19 %), their node means 2.0-5.1 N m
        (:meth:`~colloc.identify.gait.smoother_results.SmoothedGait.node_mean_inputs`).
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
        node_mean_inputs: bool = False,
        output_parameters: Mapping[sm.Symbol, tuple[float, float]] | None = None,
        parameter_update: Callable[[np.ndarray], Mapping[sm.Symbol, float]] | None = None,
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
        extra = dict(output_parameters or {})
        if extra and parameter_update is None:
            problems.append(
                "output_parameters: expected a parameter_update (their values given the "
                "states) beside them, found none"
            )
        for symbol, pair in extra.items():
            try:
                start, spread = (float(v) for v in pair)
            except (TypeError, ValueError):
                start = spread = float("nan")
            if not (np.isfinite(start) and np.isfinite(spread) and spread > 0):
                problems.append(
                    f"output_parameters {symbol}: expected (start, prior_std) with a finite "
                    f"start and a positive prior_std, found {pair!r}"
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
        self.model = actuated.with_outputs(outputs, parameters=sorted(extra, key=name_of))
        self._parameter_start = {p: float(v[0]) for p, v in extra.items()}
        self._parameter_std = {p: float(v[1]) for p, v in extra.items()}
        self._parameter_update = parameter_update
        self._measured, self._weights = measured, weights
        self._constants = dict(constants or {})
        self._early = dict(early_weights or {})
        self._node_mean_inputs = bool(node_mean_inputs)
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

    def problem(
        self,
        scheme: Any,
        friction_velocity: float,
        free_parameters: bool = False,
        full_weights: bool = False,
    ) -> Any:
        """The smoother's collocation problem with ``scheme`` at a contact slip scale, the
        early stages' weights unless ``full_weights``; with ``free_parameters`` the output
        parameters are estimated under their prior (the last stage's problem), else known
        at their starts."""
        from colloc.nlp.problem import Problem

        constants = {**self.dynamics.constants, **self._constants}
        constants[self._friction] = float(friction_velocity)
        if not free_parameters:
            constants.update(self._parameter_start)
        return Problem(
            self.model,
            self.times,
            scheme=scheme,
            known_trajectories={self.dynamics.gait.belt_speed: self.belt_speed},
            known_parameters=constants,
            objective=self._tracking(final=full_weights, prior=free_parameters),
            process_noise=dict(zip(self.residual_inputs, self.settings.residual_std, strict=True)),
        )

    def _tracking(self, final: bool, prior: bool = False) -> Any:
        """The tracking term at full weights (``final``) or the early stages', and with
        ``prior`` the output parameters' prior (the problem that estimates them)."""
        from colloc.nlp.objective import ParameterPrior, Tracking

        factors = {} if final else self._early
        weights = {y: w * factors.get(y, 1.0) for y, w in self._weights.items()}
        tracking = Tracking(self._measured, weights)
        if not (prior and self._parameter_start):
            return tracking
        return [tracking, ParameterPrior(self._parameter_start, self._parameter_std)]

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
            stages.append(stage_record("start", midpoint, z, v0, "Consistent", True, 0, clock))
            say(name, f"from its own zero-defect start, v_s = {v0:g} m/s")
        z = self._solve(
            midpoint,
            z,
            name,
            v0,
            stages,
            ceiling_factor=DIVERGED_OBJECTIVE_FACTOR_WARM_START,
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
        full = not self._early
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
                z, full = z_full, True
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
        estimated = None
        if self._parameter_start:
            midpoint, z, *estimated = self._estimate_parameters(
                midpoint, z, current, full, stages, notes, say
            )
        result = self._result(midpoint, z, stages, started)
        if estimated is not None:
            result.parameters, result.parameter_sd = estimated
        if notes:
            result.notes.extend(notes)
        return result

    # ------------------------------------------------------------------ helpers
    def _estimate_parameters(
        self,
        problem: Any,
        z: np.ndarray,
        friction_velocity: float,
        full: bool,
        stages: list[SmootherStage],
        notes: list[str],
        say: Progress,
    ) -> tuple[Any, np.ndarray, dict[str, float], dict[str, float]]:
        """The output parameters estimated with the motion, by alternating: their maximum a
        posteriori values given the smoothed states (``parameter_update``, exact for outputs
        linear in them), then the smoother solved again with them known, until they move
        less than :data:`PARAMETER_TOL` (at most :data:`PARAMETER_PASSES` passes), each half
        lowering the same objective; then polished jointly (:meth:`_joint_polish`). Returns
        the problem the result is read from, its solution, the estimates by name and their
        posterior standard deviations by name (empty with a note when they cannot be
        computed)."""
        assert self._parameter_update is not None
        lay = problem.layout
        n = self.dynamics.model.num_states
        values = dict(self._parameter_start)
        moved = float("inf")
        for count in range(1, PARAMETER_PASSES + 1):
            states = lay.node_matrix(z)[:, :n]
            new = {p: float(v) for p, v in self._parameter_update(states).items()}
            moved = max(abs(new[p] - values[p]) for p in values)
            problem.replace_data(known_parameters={**problem.known_parameters, **new})
            stage, z_new = self._attempt(
                problem,
                z,
                f"output parameters {count}",
                friction_velocity,
                FULL_WEIGHTS_STEPS * self.settings.step_max_iter,
            )
            stages.append(stage)
            say("output parameters", f"{stage.describe()}; they moved up to {moved:.3g}")
            if not stage.success:
                problem.replace_data(known_parameters={**problem.known_parameters, **values})
                notes.append(
                    f"smoother: the output parameters' pass {count} did not converge "
                    f"({stage.describe()}): they are the previous pass's"
                )
                break
            z, values = z_new, new
            if moved < PARAMETER_TOL:
                break
        else:
            notes.append(
                f"smoother: the output parameters still moved up to {moved:.3g} in the last of "
                f"{PARAMETER_PASSES} passes"
            )
        by_name = {name_of(p): v for p, v in values.items()}
        return self._joint_polish(problem, z, by_name, friction_velocity, full, stages, notes, say)

    def _joint_polish(
        self,
        problem: Any,
        z: np.ndarray,
        values: dict[str, float],
        friction_velocity: float,
        full: bool,
        stages: list[SmootherStage],
        notes: list[str],
        say: Progress,
    ) -> tuple[Any, np.ndarray, dict[str, float], dict[str, float]]:
        """From the alternating passes' point, one solve of the problem that estimates the
        output parameters with the motion (the alternation crawls along a direction the
        record determines only weakly: on 3 s of a simulated walk the two shoulder markers'
        shared place stayed 5.5 mm off after six passes, 0.6 mm after this stage's five
        iterations), and the parameters' posterior standard deviations there (its
        Cramer-Rao bound). When it does not converge within a continuation step's budget the
        passes' point is kept, with a note (on OpenSim's real walk 120 iterations did not
        converge from it). Returns the problem the result is read from, its solution, the
        estimates and their standard deviations, by name."""
        from colloc.nlp.uncertainty import cramer_rao_bound

        joint = self.problem(
            self.settings.scheme, friction_velocity, free_parameters=True, full_weights=full
        )
        offset = problem.layout.parameter_offset
        if joint.layout.parameter_offset != offset:  # pragma: no cover - a layout invariant
            raise RuntimeError("smoother: the parameters' problem lays out other variables")
        point = np.concatenate([z[:offset], [values[n] for n in joint.layout.parameter_names]])
        stage, z_joint = self._attempt(
            joint,
            point,
            "output parameters, jointly",
            friction_velocity,
            self.settings.step_max_iter,
        )
        stages.append(stage)
        say("output parameters", stage.describe())
        if stage.success:
            point = z_joint
            values = joint.layout.parameters(z_joint)
        else:
            notes.append(
                f"smoother: the output parameters estimated jointly with the motion did not "
                f"converge ({stage.describe()}): they are the alternating passes'"
            )
        try:
            bound = cramer_rao_bound(joint, point)
            spread = {name_of(p): float(v) for p, v in bound.standard_errors.items()}
        except ValueError as error:
            notes.append(f"smoother: no standard deviations of the output parameters: {error}")
            spread = {}
        if stage.success:
            return joint, point, values, spread
        return problem, z, values, spread

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
            stages.append(stage_record("start" + label, euler, z, v0, "Consistent", True, 0, clock))
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
        """One stage's solve (:meth:`_attempt`), recorded in ``stages``; raises
        :class:`SmootherError` when it does not converge, naming it and the stages before."""
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
        """:func:`colloc.identify.gait.smoother_solve.attempt_stage` with these settings."""
        return attempt_stage(problem, z, name, v_s, self.settings, max_iter, ceiling_factor)

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
            inputs_in_pairs=self._node_mean_inputs,
        )
