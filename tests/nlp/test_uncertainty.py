"""Standard errors from the KKT system (``parameter_uncertainty``) against independent references.

* The spread of the identified gains over many noise realisations of the seed's 1-link
  closed-loop study (the problem is built once; each realisation only swaps the data).
* Gauss-Newton covariance ``sigma^2 (S^T S)^-1`` with the sensitivities ``S`` of the measured
  outputs to the gains and the initial state taken by central differences of an ODE
  simulation (SciPy's integrator, not the collocation problem).
* The analytic Gauss-Newton covariance of an exponential decay.
* The Cramer-Rao bound at the truth (``cramer_rao_bound``) against the same spread over
  noise realisations, and against the analytic bound of the exponential decay.
* Every error path.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc import (
    DiscretisationWarning,
    Model,
    Problem,
    StateFeedback,
    Tracking,
    cramer_rao_bound,
    linearize,
    lqr,
    parameter_uncertainty,
)
from colloc.identify import smooth_with_derivatives
from colloc.models import pendulum_cart
from colloc.simulate import ImplicitODE, SumOfSines
from colloc.transcription import Midpoint

DURATION = 20.0
RATE = 50.0
AMPLITUDE = 10.0
SIGMA = float(
    np.deg2rad(0.25)
)  # rad for the angle; the same number in metres (4.4 mm) for the cart
NUM_REALISATIONS = 40
SPREAD_FACTOR = 1.5

t = dynamicsymbols._t


@dataclass
class Study:
    problem: Problem
    closed: Model
    coordinates: tuple
    gains: list
    known: np.ndarray
    constants: dict
    force_fn: SumOfSines
    times: np.ndarray
    true_states: np.ndarray

    def tracking(self, measured: np.ndarray) -> Tracking:
        return Tracking(dict(zip(self.coordinates, measured.T, strict=True)))

    def noisy(self, seed: int) -> np.ndarray:
        clean = self.true_states[:, :2]
        return clean + SIGMA * np.random.default_rng(seed).standard_normal(clean.shape)

    def solve(self, measured: np.ndarray):
        """Swap in ``measured`` (no rebuild) and solve from the smoothed data and true gains."""
        self.problem.replace_data(objective=self.tracking(measured))
        q, qd, _ = smooth_with_derivatives(self.times, measured, 0.15)
        z0 = self.problem.initial_guess(
            dict(zip(self.closed.states, np.hstack([q, qd]).T, strict=True)),
            dict(zip(self.gains, self.known, strict=True)),
        )
        solution = self.problem.solve(z0)
        assert solution.success, solution.stats["message"]
        return solution


@pytest.fixture(scope="module")
def study() -> Study:
    plant = pendulum_cart.derive(1)
    model = plant.to_model()
    constants = plant.default_constants()
    ss = linearize(
        model,
        dict.fromkeys(model.states, 0.0),
        inputs=plant.torques,
        constants=constants,
        equilibrium=True,
        numeric=True,
    )
    K = np.asarray(lqr(ss.A, ss.B, np.eye(4), np.eye(1)).K, dtype=float)
    feedback = StateFeedback.symbolic(1, 4)
    closed = model.close_loop(feedback)
    gains = list(feedback.K)
    known = K.ravel()
    times = np.arange(int(DURATION * RATE) + 1) / RATE
    force_fn = SumOfSines.from_seed(AMPLITUDE, 7)
    ode = ImplicitODE.from_model(
        closed, {**constants, **dict(zip(gains, known, strict=True))}, {plant.force: force_fn}
    )
    true_states = ode.simulate(np.zeros(4), times)
    problem = Problem(
        closed,
        times,
        scheme=Midpoint(),
        known_trajectories={plant.force: force_fn(times)},
        known_parameters=constants,
        objective=Tracking(dict(zip(plant.coordinates, true_states[:, :2].T, strict=True))),
        cache=False,
    )
    return Study(
        problem,
        closed,
        plant.coordinates,
        gains,
        known,
        constants,
        force_fn,
        times,
        true_states,
    )


#: The three Monte Carlo checks share 40 fits with two kinds of error bars each (46 s): run
#: by benchmarks/slow_tests.py; CI keeps the single-fit checks of the same errors below
#: (against Gauss-Newton of the ODE, an analytic decay, the bound's arguments).
MONTE_CARLO = pytest.mark.slow


@dataclass
class Realisations:
    estimates: np.ndarray  # (NUM_REALISATIONS, 4)
    std_errors: np.ndarray  # (NUM_REALISATIONS, 4)
    variances: np.ndarray  # (NUM_REALISATIONS,)
    sandwich: np.ndarray  # (NUM_REALISATIONS, 4) robust standard errors


@pytest.fixture(scope="module")
def realisations(study) -> Realisations:
    """The gains identified from NUM_REALISATIONS noisy copies of the study's data."""
    estimates, std_errors, variances, sandwich = [], [], [], []
    for seed in range(NUM_REALISATIONS):
        measured = study.noisy(1000 + seed)
        solution = study.solve(measured)
        unc = parameter_uncertainty(study.problem, solution, measured.size, method="kkt")
        # the problem counts its own measurements: every sample of both tracked signals
        assert parameter_uncertainty(study.problem, solution, method="kkt").degrees_of_freedom == (
            unc.degrees_of_freedom
        )
        robust = parameter_uncertainty(study.problem, solution, method="sandwich")
        assert (unc.method, robust.method) == ("kkt", "sandwich")
        assert robust.blocks == round(np.sqrt(study.times.size))
        estimates.append([solution.parameters[k] for k in study.gains])
        std_errors.append([unc.standard_errors[k] for k in study.gains])
        sandwich.append([robust.standard_errors[k] for k in study.gains])
        variances.append(unc.noise_variance)
        assert unc.degrees_of_freedom == measured.size - 8  # 4 gains + 4 initial states free
    return Realisations(
        np.array(estimates), np.array(std_errors), np.array(variances), np.array(sandwich)
    )


@MONTE_CARLO
def test_standard_errors_match_spread_over_noise_realisations(study, realisations):
    estimates, std_errors = realisations.estimates, realisations.std_errors
    variances = realisations.variances
    spread = estimates.std(axis=0, ddof=1)
    reported = std_errors.mean(axis=0)
    ratio = spread / reported
    assert np.all(ratio < SPREAD_FACTOR) and np.all(ratio > 1 / SPREAD_FACTOR), ratio
    # sigma^2 from the residuals against the noise actually drawn (chi^2 with ~2000 dof).
    assert np.mean(variances) == pytest.approx(SIGMA**2, rel=0.05)
    # Noise costs precision, not accuracy: the mean estimate sits on the noise-free one.
    clean = study.solve(study.true_states[:, :2])
    noise_free = np.array([clean.parameters[k] for k in study.gains])
    standard_error_of_mean = spread / np.sqrt(NUM_REALISATIONS)
    assert np.all(np.abs(estimates.mean(axis=0) - noise_free) < 4 * standard_error_of_mean)


@MONTE_CARLO
def test_sandwich_standard_errors_match_the_spread_when_the_noise_model_is_right(realisations):
    # white noise of the assumed kind: the robust estimate must agree with the spread too
    # (it pays for its robustness with a noisier estimate of the standard error)
    spread = realisations.estimates.std(axis=0, ddof=1)
    ratio = spread / realisations.sandwich.mean(axis=0)
    assert np.all(ratio < SPREAD_FACTOR) and np.all(ratio > 1 / SPREAD_FACTOR), ratio
    agreement = realisations.sandwich.mean(axis=0) / realisations.std_errors.mean(axis=0)
    assert np.all(np.abs(agreement - 1) < 0.15), agreement


@MONTE_CARLO
def test_cramer_rao_bound_at_the_truth_matches_the_spread(study, realisations):
    # the bound is computed before any fit, from the true states and gains and the noise
    # actually drawn; the efficient estimator's spread over the realisations must meet it
    study.problem.replace_data(objective=study.tracking(study.true_states[:, :2]))
    z = study.problem.initial_guess(
        dict(zip(study.closed.states, study.true_states.T, strict=True)),
        dict(zip(study.gains, study.known, strict=True)),
    )
    bound = cramer_rao_bound(study.problem, z, noise_variance=SIGMA**2)
    assert bound.degrees_of_freedom is None
    assert bound.noise_variance == SIGMA**2
    spread = realisations.estimates.std(axis=0, ddof=1)
    ratio = spread / np.array([bound.standard_errors[k] for k in study.gains])
    assert np.all(ratio < SPREAD_FACTOR) and np.all(ratio > 1 / SPREAD_FACTOR), ratio
    np.testing.assert_allclose(
        np.sqrt(np.diag(bound.covariance)), list(bound.standard_errors.values())
    )


def test_standard_errors_match_gauss_newton_of_the_ode(study):
    measured = study.noisy(5)
    solution = study.solve(measured)
    unc = parameter_uncertainty(study.problem, solution, measured.size, method="kkt")

    def outputs(theta: np.ndarray) -> np.ndarray:
        values = {**study.constants, **dict(zip(study.gains, theta[:4], strict=True))}
        force = dict.fromkeys(study.closed.inputs, study.force_fn)
        ode = ImplicitODE.from_model(study.closed, values, force)
        return ode.simulate(theta[4:], study.times)[:, :2].ravel()

    theta = np.concatenate([study.known, np.zeros(4)])
    columns = []
    for j in range(theta.size):
        step = 1e-5 * max(1.0, abs(theta[j]))
        e = np.zeros_like(theta)
        e[j] = step
        columns.append((outputs(theta + e) - outputs(theta - e)) / (2 * step))
    S = np.column_stack(columns)
    gauss_newton = SIGMA * np.sqrt(np.diag(np.linalg.inv(S.T @ S)))[:4]
    # Rescale from the residual-based sigma to the true one so only the matrix part is compared.
    kkt = np.array([unc.standard_errors[k] for k in study.gains])
    kkt_known_sigma = kkt * SIGMA / np.sqrt(unc.noise_variance)
    np.testing.assert_allclose(kkt_known_sigma, gauss_newton, rtol=0.02)
    # The covariance is symmetric and its diagonal gives the standard errors.
    np.testing.assert_allclose(unc.covariance, unc.covariance.T)
    np.testing.assert_allclose(np.sqrt(np.diag(unc.covariance)), kkt)
    assert unc.parameters == tuple(study.gains)


def test_scalar_decay_against_analytic_gauss_newton():
    # x' = -a x, y = x: dy/da = -t x0 exp(-a t), dy/dx0 = exp(-a t).
    x = dynamicsymbols("x")
    a = sm.Symbol("a")
    model = Model.from_equations([x.diff(t) + a * x], [x], outputs=[x])
    a_true, x0_true, sigma = 0.8, 2.0, 0.02
    times = np.linspace(0.0, 3.0, 301)
    clean = x0_true * np.exp(-a_true * times)
    measured = clean + sigma * np.random.default_rng(3).standard_normal(times.size)
    problem = Problem(model, times, objective=Tracking({x: measured}), cache=False)
    solution = problem.solve(problem.initial_guess({x: measured}, {a: 1.0}))
    assert solution.success
    unc = parameter_uncertainty(problem, solution, times.size, method="kkt")
    a_hat = solution.parameters[a]
    x0_hat = solution.trajectories[x][0]
    S = np.column_stack(
        [-times * x0_hat * np.exp(-a_hat * times), np.exp(-a_hat * times)],
    )
    expected = np.sqrt(unc.noise_variance * np.linalg.inv(S.T @ S)[0, 0])
    assert unc.standard_errors[a] == pytest.approx(expected, rel=0.02)
    # the bound at the truth, from the true sensitivities and the true sigma
    truth = problem.initial_guess({x: clean}, {a: a_true})
    bound = cramer_rao_bound(problem, truth, noise_variance=sigma**2)
    S_true = np.column_stack(
        [-times * x0_true * np.exp(-a_true * times), np.exp(-a_true * times)],
    )
    analytic = sigma * np.sqrt(np.linalg.inv(S_true.T @ S_true)[0, 0])
    assert bound.standard_errors[a] == pytest.approx(analytic, rel=0.02)


def test_cramer_rao_bound_rejects_bad_arguments(study):
    z = study.problem.initial_guess(
        dict(zip(study.closed.states, study.true_states.T, strict=True)),
        dict(zip(study.gains, study.known, strict=True)),
    )
    with pytest.raises(ValueError, match=r"z: expected shape \(\d+,\), found \(3,\)"):
        cramer_rao_bound(study.problem, np.zeros(3))
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="noise_variance: expected a number > 0"):
            cramer_rao_bound(study.problem, z, noise_variance=bad)


# ----------------------------------------------------------------------------- error paths


def test_no_unknown_parameters_is_an_error(study):
    measured = study.noisy(1)
    fixed = Problem(
        study.closed,
        study.times,
        known_trajectories={r: study.force_fn(study.times) for r in study.closed.inputs},
        known_parameters={**study.constants, **dict(zip(study.gains, study.known, strict=True))},
        objective=study.tracking(measured),
        cache=False,
    )
    guess = dict(zip(study.closed.states, study.true_states.T, strict=True))
    solution = fixed.solve(fixed.initial_guess(guess))
    with pytest.raises(ValueError, match="problem: has no unknown parameters"):
        parameter_uncertainty(fixed, solution, measured.size)
    with pytest.raises(ValueError, match="problem: has no unknown parameters"):
        cramer_rao_bound(fixed, solution.z)


def test_too_few_measurements_is_an_error(study):
    measured = study.noisy(2)
    solution = study.solve(measured)
    # 4 gains + 4 initial states are free; 8 measurements leave no residual degrees of freedom.
    with pytest.raises(ValueError, match=r"num_measurements: expected more than the 8 .*found 8"):
        parameter_uncertainty(study.problem, solution, 8)


def _decays(times, rng):
    x, v, u = dynamicsymbols("x v u")
    mx = np.exp(-0.7 * times) + 0.01 * rng.standard_normal(times.size)
    mv = np.exp(-times) + 0.01 * rng.standard_normal(times.size)
    return x, v, u, mx, mv


def test_parameter_without_effect_on_the_data_is_unidentifiable():
    # b multiplies an input that is zero throughout, so the data say nothing about it.
    times = np.linspace(0.0, 2.0, 41)
    x, v, u, mx, mv = _decays(times, np.random.default_rng(0))
    a, b, c = sm.symbols("a b c")
    model = Model.from_equations(
        [x.diff(t) + a * x - b * u, v.diff(t) + c * v], [x, v], known_inputs=[u], outputs=[x, v]
    )
    problem = Problem(
        model,
        times,
        known_trajectories={u: np.zeros(times.size)},
        objective=Tracking({x: mx, v: mv}),
        cache=False,
    )
    solution = problem.solve(problem.initial_guess({x: mx, v: mv}, {a: 0.5, b: 0.0, c: 1.0}))
    assert solution.success
    with pytest.raises(ValueError, match="reduced Hessian .* singular.*cannot be identified"):
        parameter_uncertainty(problem, solution, 2 * times.size, method="kkt")
    # a planned experiment with the zero input says so before any fit
    with pytest.raises(ValueError, match="reduced Hessian .* singular.*cannot be identified"):
        cramer_rao_bound(problem, solution.z, noise_variance=1e-4)


def test_state_not_seen_by_the_data_makes_the_kkt_matrix_singular():
    # v is neither measured nor coupled to x, so its initial value is free and undetermined.
    times = np.linspace(0.0, 2.0, 41)
    x, v, _, mx, _ = _decays(times, np.random.default_rng(1))
    a = sm.Symbol("a")
    model = Model.from_equations([x.diff(t) + a * x, v.diff(t) + v], [x, v], outputs=[x])
    problem = Problem(model, times, objective=Tracking({x: mx}), cache=False)
    solution = problem.solve(problem.initial_guess({x: mx, v: 1.0}, {a: 0.5}))
    assert solution.success
    with pytest.raises(ValueError, match="KKT matrix at the solution is singular"):
        parameter_uncertainty(problem, solution, times.size, method="kkt")


def test_uncertainty_method_and_blocks_are_checked(study):
    solution = study.solve(study.noisy(5))
    with pytest.raises(ValueError, match="method: expected one of"):
        parameter_uncertainty(study.problem, solution, method="bootstrap")
    with pytest.raises(ValueError, match="blocks: expected between 2 and"):
        parameter_uncertainty(study.problem, solution, method="sandwich", blocks=1)
    with pytest.raises(ValueError, match="increasing first nodes starting at 0"):
        parameter_uncertainty(study.problem, solution, method="sandwich", blocks=[5, 100])
    with pytest.raises(ValueError, match="beyond the"):
        parameter_uncertainty(study.problem, solution, method="sandwich", blocks=[0, 10**6])
    # blocks given by their first nodes: the same as the equal split they describe
    N = study.times.size
    starts = np.linspace(0, N, 20, endpoint=False).astype(int)
    by_count = parameter_uncertainty(study.problem, solution, method="sandwich", blocks=20)
    by_start = parameter_uncertainty(study.problem, solution, method="sandwich", blocks=starts)
    np.testing.assert_allclose(by_count.covariance, by_start.covariance, rtol=1e-12)


def test_errors_of_a_solve_that_did_not_converge_come_with_a_warning(study):
    measured = study.noisy(3)
    study.problem.replace_data(objective=study.tracking(measured))
    q, qd, _ = smooth_with_derivatives(study.times, measured, 0.15)
    z0 = study.problem.initial_guess(
        dict(zip(study.closed.states, np.hstack([q, qd]).T, strict=True)),
        dict(zip(study.gains, study.known, strict=True)),
    )
    unconverged = study.problem.solve(z0, max_iter=0)
    assert not unconverged.status.success
    with pytest.warns(UserWarning, match=r"the solve did not converge \(Maximum_Iterations"):
        parameter_uncertainty(study.problem, unconverged)
    converged = study.solve(measured)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a converged solve's errors come without one
        # (at 50 Hz the midpoint rule's own error in two gains is 0.6 of their standard
        # error, said by a DiscretisationWarning: tests/nlp/test_refinement.py)
        warnings.simplefilter("ignore", DiscretisationWarning)
        parameter_uncertainty(study.problem, converged)


def _decay(num_nodes, correlated=False):
    """x' = -a x tracked on noisy data (white, or a random walk: correlated residuals)."""
    x = dynamicsymbols("x")
    a = sm.Symbol("a")
    model = Model.from_equations([x.diff(t) + a * x], [x], outputs=[x])
    times = np.linspace(0.0, 3.0, num_nodes)
    rng = np.random.default_rng(7)
    noise = 0.02 * rng.standard_normal(times.size)
    if correlated:
        noise = 0.005 * np.cumsum(rng.standard_normal(times.size))
    measured = 2.0 * np.exp(-0.8 * times) + noise
    problem = Problem(model, times, objective=Tracking({x: measured}), cache=False)
    solution = problem.solve(problem.initial_guess({x: measured}, {a: 1.0}))
    assert solution.success
    return problem, solution, a


def test_the_default_chooses_the_honest_method_and_says_why():
    """Without a noise model the default is robust (KKT errors were 3-12 times too small on
    the gallery's problems): the autoregressive errors on a uniform grid; with too few nodes,
    or per_output, the KKT form. The choice and its grounds are on the result."""
    problem, solution, a = _decay(301, correlated=True)
    chosen = parameter_uncertainty(problem, solution)
    assert chosen.method == "autoregressive" and "noise is not modelled" in chosen.reason
    asked = parameter_uncertainty(problem, solution, method="autoregressive")
    assert chosen.standard_errors[a] == asked.standard_errors[a]
    assert asked.reason == "asked for"
    sandwich = parameter_uncertainty(problem, solution, method="sandwich")
    assert sandwich.reason == "asked for"
    kkt = parameter_uncertainty(problem, solution, method="kkt")
    # random-walk residuals: the KKT form, which takes them as white, is far too small
    assert kkt.standard_errors[a] < 0.5 * sandwich.standard_errors[a]
    assert kkt.standard_errors[a] < 0.5 * asked.standard_errors[a]
    per_output = parameter_uncertainty(problem, solution, per_output=True)
    assert per_output.method == "kkt per output" and "per_output" in per_output.reason
    short_problem, short_solution, _ = _decay(15)
    short = parameter_uncertainty(short_problem, short_solution)
    assert short.method == "kkt" and "too few for the sandwich" in short.reason


@pytest.mark.parametrize("method", ["kkt", "sandwich", "auto"])
def test_a_parameter_held_by_a_bound_gets_no_standard_error(method):
    """Data of ``x' = -0.8 x + 0.3`` fitted with the rate bounded by 0.5: the solve ends on
    the bound, which ``status.reliable`` and ``at_bounds`` say; its standard error is NaN
    (neither a zero nor a large number that reads as precision), the free offset keeps its
    own, and the reason says why."""
    t = dynamicsymbols._t
    x = dynamicsymbols("x")
    a, b = sm.symbols("a b")
    model = Model.from_equations([x.diff(t) + a * x - b], [x])
    times = np.linspace(0.0, 6.0, 301)
    exact = 0.3 / 0.8 + (2.0 - 0.3 / 0.8) * np.exp(-0.8 * times)
    measured = exact + 0.01 * np.random.default_rng(4).standard_normal(times.size)
    results = {}
    for name, bounds in (("free", {}), ("held", {a: (0.0, 0.5)})):
        problem = Problem(
            model, times, objective=Tracking({x: measured}), bounds=bounds, cache=False
        )
        solution = problem.solve(problem.initial_guess({x: measured}, {a: 0.3, b: 0.1}))
        assert solution.success
        results[name] = (solution, parameter_uncertainty(problem, solution, method=method))
    free_solution, free = results["free"]
    assert free_solution.status.reliable and free.at_bounds == ()
    assert all(np.isfinite(se) and se > 0 for se in free.standard_errors.values())
    held_solution, held = results["held"]
    assert held_solution.parameters[a] == pytest.approx(0.5, abs=1e-6)
    assert held_solution.status.at_bounds == ("a",) and not held_solution.status.reliable
    assert held.at_bounds == (a,) and np.isnan(held.standard_errors[a])
    assert np.isfinite(held.standard_errors[b]) and held.standard_errors[b] > 0
    assert np.all(np.isnan(held.covariance[0])) and np.isfinite(held.covariance[1, 1])
    assert "a at a bound: no standard error" in held.reason
