"""The seed's study: identify the LQR gains of an n-link pendulum on a cart from noisy motion.

Steps: derive the plant (Kane), design LQR about upright, simulate the closed loop under a
sum-of-sines cart force, add sensor noise, then recover the gains by direct collocation.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc.control.lqr import lqr
from colloc.control.state_feedback import StateFeedback
from colloc.identify.direct import direct_estimate, smooth_with_derivatives
from colloc.identify.guesses import GAIN_GUESSES
from colloc.identify.pendulum.settings import SCHEME_NAMES, PendulumSettings
from colloc.model.linearize import linearize
from colloc.model.model import Model
from colloc.model.symbols import name_of
from colloc.models import pendulum_cart
from colloc.nlp.marginal import MarginalCorrection, marginal_correction
from colloc.nlp.objective import Tracking
from colloc.nlp.problem import Problem
from colloc.nlp.residuals import ResidualDiagnostics, residual_diagnostics
from colloc.nlp.solution import Solution
from colloc.nlp.uncertainty import (
    DiscretisationWarning,
    ParameterUncertainty,
    parameter_uncertainty,
)
from colloc.simulate import ImplicitODE, SampledNoise, SumOfSines, add_sensor_noise
from colloc.transcription import BackwardEuler, HermiteSimpson, Midpoint, Scheme, Trapezoidal

SCHEMES: dict[str, type[Scheme]] = dict(
    zip(SCHEME_NAMES, (Midpoint, BackwardEuler, Trapezoidal, HermiteSimpson), strict=True)
)
"""The schemes by their command-line names (:data:`SCHEME_NAMES`)."""

Progress = Callable[[str, str], None]


@dataclass
class PendulumRun:
    """Everything a pendulum run produced."""

    settings: PendulumSettings
    gain_symbols: list[sm.Symbol]
    known_gains: np.ndarray
    initial_gains: np.ndarray
    identified_gains: np.ndarray
    standard_errors: np.ndarray
    times: np.ndarray
    force: np.ndarray
    true_states: np.ndarray
    measurements: np.ndarray
    identified_states: np.ndarray
    defects: np.ndarray
    solution: Solution
    problem: Problem
    uncertainty: ParameterUncertainty | None
    timings: dict[str, float]
    lengths: np.ndarray
    objective_at_true_gains: float | None = None
    notes: list[str] = field(default_factory=list)
    force_measured: np.ndarray | None = None
    diagnostics: ResidualDiagnostics | None = None
    marginal: MarginalCorrection | None = None

    @property
    def discretisation_errors(self) -> np.ndarray:
        """The scheme's estimated error in each gain (NaN where not estimated)."""
        found = {} if self.uncertainty is None else self.uncertainty.discretisation_errors
        return np.array([found.get(k, np.nan) for k in self.gain_symbols], dtype=float)

    @property
    def gain_names(self) -> list[str]:
        """``k_i_j`` names in row-major order."""
        return [name_of(k) for k in self.gain_symbols]

    @property
    def max_rel_gain_error(self) -> float:
        """``max |identified - known| / |known|``."""
        return float(
            np.max(np.abs(self.identified_gains - self.known_gains) / np.abs(self.known_gains))
        )

    @property
    def max_gain_error_in_se(self) -> float:
        """``max |identified - known| / standard error``."""
        return float(
            np.max(np.abs(self.identified_gains - self.known_gains) / self.standard_errors)
        )


def run_pendulum(
    settings: PendulumSettings,
    progress: Progress | None = None,
    cache: Any = True,
    iterations: Callable[[dict[str, float]], None] | None = None,
) -> PendulumRun:
    """Run the whole study (derive, control design, simulate, build, solve, uncertainty).

    Parameters
    ----------
    settings : PendulumSettings
    progress : callable, optional
        ``progress(step, detail)`` as each step starts or ends.
    cache : bool or path
        Build cache for :class:`colloc.Problem`.
    iterations : callable, optional
        Called after every IPOPT iteration (see :meth:`colloc.Problem.solve`).

    Returns
    -------
    PendulumRun
    """
    settings.validate()
    say = progress or (lambda step, detail: None)
    timings: dict[str, float] = {}
    t_all = time.perf_counter()
    # children 0-2 as before the noise options, so their runs draw the same numbers
    children = np.random.SeedSequence(settings.seed).spawn(5)
    phase_rng, noise_rng, guess_rng, motor_rng, force_rng = (
        np.random.default_rng(s) for s in children
    )
    n = settings.num_links

    say("derive", f"{n}-link pendulum on a cart by Kane's method")
    t0 = time.perf_counter()
    plant = pendulum_cart.derive(n)
    model = plant.to_model()
    constants = plant.default_constants()
    timings["derive"] = time.perf_counter() - t0

    say("control design", "LQR about upright (Q = I, R = I)")
    t0 = time.perf_counter()
    op = dict.fromkeys(model.states, 0.0)
    ss = linearize(
        model, op, inputs=plant.torques, constants=constants, equilibrium=True, numeric=True
    )
    num_states = model.num_states
    K = np.asarray(lqr(ss.A, ss.B, np.eye(num_states), np.eye(n)).K, dtype=float)
    feedback = StateFeedback.symbolic(n, num_states)
    closed = model.close_loop(feedback)
    assert feedback.K is not None  # sized by close_loop
    gain_symbols = list(feedback.K)
    known = K.ravel()
    timings["derive"] += time.perf_counter() - t0

    say("simulate", f"{settings.duration:g} s at {settings.sample_rate:g} Hz")
    t0 = time.perf_counter()
    force_fn = SumOfSines.from_seed(settings.force_amplitude, int(phase_rng.integers(2**31)))
    times = np.arange(settings.num_nodes) / settings.sample_rate
    motor = dict(zip(plant.torques, dynamicsymbols(f"w1:{n + 1}"), strict=True))
    gain_values = dict(zip(gain_symbols, known, strict=True))
    # the closed loop with motor noise on every torque: simulated, and identified when the
    # noise is modelled
    disturbed = closed
    noise_fns = {}
    if settings.process_noise:
        noise_fns = {
            w: SampledNoise.draw(times, settings.process_noise, int(motor_rng.integers(2**31)))
            for w in motor.values()
        }
        disturbed = model.with_disturbances(motor).close_loop(feedback)
    ode = ImplicitODE.from_model(
        disturbed, {**constants, **gain_values}, {plant.force: force_fn, **noise_fns}
    )
    true_states = ode.simulate(np.zeros(num_states), times)
    force = force_fn(times)
    force_measured = force
    if settings.input_noise:
        force_measured = add_sensor_noise(
            force, settings.input_noise, int(force_rng.integers(2**31))
        )
    coords = true_states[:, : n + 1]
    angle_std = np.deg2rad(settings.noise_std_deg)
    if settings.sensor_noise:
        std = [settings.cart_noise_std] + [angle_std] * n
        measured = add_sensor_noise(coords, np.asarray(std), int(noise_rng.integers(2**31)))
    else:
        measured = coords.copy()
    timings["simulate"] = time.perf_counter() - t0

    say("build", f"{settings.scheme} collocation, N = {settings.num_nodes}")
    t0 = time.perf_counter()
    setup = _identification_setup(
        settings, closed, disturbed, plant, measured, force_measured, angle_std
    )
    problem = setup.problem(times, constants, cache)
    timings["build"] = time.perf_counter() - t0
    q_s, qd_s, qdd_s = smooth_with_derivatives(times, measured, settings.smoothing_window)
    x_guess = np.hstack([q_s, qd_s])
    xd_guess = np.hstack([qd_s, qdd_s])

    def direct() -> np.ndarray:
        estimate = direct_estimate(
            closed, gain_symbols, times, x_guess, xd_guess, {plant.force: force_measured}, constants
        )
        return np.array([estimate[k] for k in gain_symbols])

    initial = GAIN_GUESSES[settings.initial_guess](known, guess_rng, direct)
    state_guess = dict(zip(closed.states, x_guess.T, strict=True))
    z0 = problem.initial_guess(state_guess, dict(zip(gain_symbols, initial, strict=True)))

    say("solve", f"IPOPT, {settings.hessian} Hessian, {len(gain_symbols)} gains")
    solution = problem.solve(z0, hessian=settings.hessian, progress=iterations)
    timings["solve"] = solution.stats["solve_time"]
    identified = np.array([solution.parameters[k] for k in gain_symbols])
    uncertainty = None
    se = np.full(len(gain_symbols), np.nan)
    notes = []
    if not solution.success:
        notes.append(
            f"no standard errors: the solve did not succeed ({solution.status.name}); errors "
            "away from an optimum mean nothing"
        )
    else:
        t0 = time.perf_counter()
        say("uncertainty", "standard errors, and the scheme's error on a grid twice as fine")
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", DiscretisationWarning)
                uncertainty = parameter_uncertainty(problem, solution, method=settings.uncertainty)
            notes += [str(w.message) for w in caught if w.category is DiscretisationWarning]
            se = np.array([uncertainty.standard_errors[k] for k in gain_symbols])
        except ValueError as exc:
            notes.append(f"no standard errors: {exc}")
        timings["uncertainty"] = time.perf_counter() - t0
    marginal = None
    if solution.success and (setup.process_noise or setup.measured_inputs):
        # the noise model's estimate: the joint maximum a posteriori one moved to the Laplace
        # marginal likelihood's optimum (the joint one is biased where the gains shape how
        # the disturbances propagate: 9.7 % on 2 links; docs/process-noise.md)
        t0 = time.perf_counter()
        say("marginal", "the marginal likelihood's correction of the joint estimate")
        try:
            marginal = marginal_correction(
                problem, solution, None if uncertainty is None else uncertainty.noise_variance
            )
            identified = np.array([marginal.parameters[k] for k in gain_symbols])
            largest = max(marginal.shift_in_se.values(), key=abs)
            notes.append(
                "gains: the marginal likelihood's (Laplace) correction of the joint estimate, "
                f"at most {largest:+.2f} KKT standard errors"
            )
        except ValueError as exc:
            notes.append(f"gains: the joint estimate, not corrected ({exc})")
        timings["marginal"] = time.perf_counter() - t0
    diagnostics = residual_diagnostics(problem, solution.z, setup.reference_std**2)
    if settings.sensor_noise:  # without noise the size check states the obvious
        notes.extend(diagnostics.warnings)
    identified_states = np.column_stack([solution.trajectories[x] for x in closed.states])
    defects = problem.defects(solution.z)
    timings["total"] = time.perf_counter() - t_all
    true_objective = None
    if settings.check_true_gains:
        t0 = time.perf_counter()
        say("check", "objective with the gains fixed at the truth")
        fixed = setup.problem(times, {**constants, **gain_values}, cache)
        ref = fixed.solve(fixed.initial_guess(dict(zip(closed.states, true_states.T, strict=True))))
        true_objective = float(ref.stats["objective"])
        timings["check"] = time.perf_counter() - t0
    lengths = np.array([constants[length] for length in plant.lengths()])
    return PendulumRun(
        settings,
        gain_symbols,
        known,
        initial,
        identified,
        se,
        times,
        force,
        true_states,
        measured,
        identified_states,
        defects,
        solution,
        problem,
        uncertainty,
        timings,
        lengths,
        true_objective,
        notes,
        force_measured,
        diagnostics,
        marginal,
    )


@dataclass(frozen=True)
class _Setup:
    """The identification's model, data and noise model (shared by the check's problem)."""

    model: Model
    tracking: Tracking
    known_trajectories: dict[sm.Basic, np.ndarray]
    measured_inputs: dict[sm.Basic, tuple[np.ndarray, float]]
    process_noise: dict[sm.Basic, float]
    scheme: str
    reference_std: float

    def problem(self, times: np.ndarray, known: dict[sm.Symbol, float], cache: Any) -> Problem:
        return Problem(
            self.model,
            times,
            scheme=SCHEMES[self.scheme](),
            known_trajectories=self.known_trajectories,
            known_parameters=known,
            objective=self.tracking,
            cache=cache,
            process_noise=self.process_noise,
            measured_inputs=self.measured_inputs,
        )


def _identification_setup(
    settings: PendulumSettings,
    closed: Model,
    disturbed: Model,
    plant: pendulum_cart.PendulumCart,
    measured: np.ndarray,
    force_measured: np.ndarray,
    angle_std: float,
) -> _Setup:
    """Today's exact-dynamics fit, or the noise model's maximum a posteriori one.

    Weights are relative to the angle noise's variance (1 for the angles, as without a
    noise model), so every standard deviation of the noise model is divided by it.
    """
    ref = angle_std if angle_std > 0 else 1.0
    cart_weight = (ref / settings.cart_noise_std) ** 2 if settings.cart_noise_std > 0 else 1.0
    modelled = settings.noise_model
    weights = None
    if modelled and (settings.process_noise or settings.input_noise):
        weights = {plant.coordinates[0]: cart_weight}
    tracking = Tracking(dict(zip(plant.coordinates, measured.T, strict=True)), weights)
    identified, process_noise = closed, {}
    if modelled and settings.process_noise:
        identified = disturbed
        process_noise = {w: settings.process_noise / ref for w in disturbed.unknown_inputs}
    if modelled and settings.input_noise:
        known: dict[sm.Basic, np.ndarray] = {}
        inputs = {plant.force: (force_measured, settings.input_noise / ref)}
    else:
        known, inputs = {plant.force: force_measured}, {}
    return _Setup(identified, tracking, known, inputs, process_noise, settings.scheme, ref)
