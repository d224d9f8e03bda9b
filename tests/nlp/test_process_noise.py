"""Process noise and measured inputs in the identification, residual diagnostics, sandwich errors.

A mass-spring-damper pushed by a known force and by white process noise, its position
measured with white noise. The data are made by the midpoint recursion itself (the exact
discrete model), so the truth of every realisation is known exactly. Checked:

* the maximum a posteriori fit with the disturbance modelled: estimates centred on the
  truth, their spread over realisations matching the reported standard errors, and >= 85 %
  of them within 3 of them; today's exact-dynamics fit with KKT errors: most estimates
  many standard errors away (the failure the noise model repairs), and the residual
  diagnostics saying so;
* the residuals recovered from the built objective against ``y - measured`` computed from the
  solution's trajectories;
* a measured input with a vanishing noise level gives the known-input estimate, and starts at
  its measurement;
* every validation message.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc import Model, Problem, Tracking, parameter_uncertainty
from colloc.model.errors import ProblemDefinitionError
from colloc.nlp.residuals import residual_diagnostics, tracking_residuals
from colloc.nlp.uncertainty import count_measurements
from colloc.transcription import BackwardEuler

t = dynamicsymbols._t
MASS, DAMPING, STIFFNESS = 1.0, 0.5, 20.0
H, N = 0.02, 1001
SIGMA_Y, SIGMA_W = 0.002, 2.0
REALISATIONS = 24

x, v, F, w = dynamicsymbols("x v F w")
m, c, k = sm.symbols("m c k")
TIMES = np.arange(N) * H
FORCE = 3.0 * np.sin(2.0 * TIMES) + 2.0 * np.sin(5.3 * TIMES)


def plant() -> Model:
    return Model.from_equations(
        [x.diff(t) - v, m * v.diff(t) + c * v + k * x - F],
        [x, v],
        outputs=[x],
        known_inputs=[F],
    )


FORCE_MID = 3.0 * np.sin(2.0 * (TIMES[:-1] + H / 2)) + 2.0 * np.sin(5.3 * (TIMES[:-1] + H / 2))


def midpoint_motion(noise: np.ndarray) -> np.ndarray:
    """Positions of the midpoint recursion from rest, driven by the force and ``noise``.

    The force is taken at each interval's middle (colloc interpolates its nodes there, which
    differs by far less than the noise); the disturbance, a free trajectory, enters the
    midpoint residual as the mean of its two nodes.
    """
    A = np.array([[1.0, -H / 2], [STIFFNESS * H / 2, MASS + DAMPING * H / 2]])
    B = np.array([[1.0, H / 2], [-STIFFNESS * H / 2, MASS - DAMPING * H / 2]])
    state = np.zeros((N, 2))
    for j in range(N - 1):
        f_mid = FORCE_MID[j] + 0.5 * (noise[j] + noise[j + 1])
        state[j + 1] = np.linalg.solve(A, B @ state[j] + [0.0, H * f_mid])
    return state[:, 0]


def realisation(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    motion = midpoint_motion(rng.normal(0.0, SIGMA_W, N))
    return motion + rng.normal(0.0, SIGMA_Y, N)


def problem(measured: np.ndarray, modelled: bool, scheme=None) -> Problem:
    model = plant().with_disturbances({F: w}) if modelled else plant()
    return Problem(
        model,
        TIMES,
        scheme=scheme,
        known_trajectories={F: FORCE},
        known_parameters={m: MASS},
        objective=Tracking({x: measured}, 1.0 / SIGMA_Y**2),
        process_noise={w: SIGMA_W} if modelled else None,
        cache=False,
    )


def state_guess(measured: np.ndarray) -> dict:
    ok = np.isfinite(measured)
    filled = np.interp(TIMES, TIMES[ok], measured[ok])
    return {x: filled, v: np.gradient(filled, TIMES)}


def fit(measured: np.ndarray, modelled: bool, scheme=None):
    prob = problem(measured, modelled, scheme)
    z0 = prob.initial_guess(state_guess(measured), {c: 1.0, k: 10.0})
    solution = prob.solve(z0, print_level=0)
    assert solution.success, solution.stats["message"]
    return prob, solution


#: The calibration's repeated fits (21 s) run with benchmarks/slow_tests.py; CI keeps the
#: single-fit checks of the process-noise model below.
MONTE_CARLO = pytest.mark.slow


@pytest.fixture(scope="module")
def calibration():
    """Estimates and standard errors of (c, k) over realisations, by both methods."""
    out = {"map": ([], [], []), "today": ([], [], [])}
    for seed in range(REALISATIONS):
        measured = realisation(seed)
        for name, modelled, method in (("map", True, "sandwich"), ("today", False, "kkt")):
            prob, solution = fit(measured, modelled)
            unc = parameter_uncertainty(prob, solution, method=method)
            out[name][0].append([solution.parameters[c], solution.parameters[k]])
            out[name][1].append([unc.standard_errors[c], unc.standard_errors[k]])
            out[name][2].append(residual_diagnostics(prob, solution.z).warnings)
    return {key: (np.array(e), np.array(s), d) for key, (e, s, d) in out.items()}


@MONTE_CARLO
def test_modelled_process_noise_gives_honest_error_bars(calibration):
    estimates, errors, warnings = calibration["map"]
    truth = np.array([DAMPING, STIFFNESS])
    z = np.abs(estimates - truth) / errors
    assert np.mean(z <= 3) >= 0.85, z
    spread = estimates.std(axis=0, ddof=1)
    ratio = spread / errors.mean(axis=0)
    assert np.all((ratio > 1 / 1.6) & (ratio < 1.6)), ratio
    # centred on the truth: the mean within 4 standard errors of the mean
    assert np.all(np.abs(estimates.mean(axis=0) - truth) < 4 * spread / np.sqrt(REALISATIONS))
    # a right noise model raises no warning in most realisations
    assert sum(bool(w) for w in warnings) <= REALISATIONS // 4, warnings


@MONTE_CARLO
def test_exact_dynamics_with_kkt_errors_is_overconfident_and_diagnosed(calibration):
    estimates, errors, warnings = calibration["today"]
    z = np.abs(estimates - np.array([DAMPING, STIFFNESS])) / errors
    assert np.mean(z <= 3) < 0.5, z
    # every realisation's residuals are flagged as not white
    assert all(any("not white" in text for text in w) for w in warnings)


def test_residuals_from_the_objective_equal_output_minus_measurement():
    measured = realisation(99)
    measured[[3, 50]] = np.nan  # left-out samples stay out
    prob, solution = fit(measured, modelled=True)
    found = {r.name: r for r in tracking_residuals(prob, solution.z)}
    assert [r.kind for r in found.values()] == ["tracking", "process noise"]
    expected = solution.trajectories[x] - measured
    np.testing.assert_allclose(found["x"].residuals, expected, rtol=1e-7, atol=1e-12)
    assert np.isnan(found["x"].residuals[[3, 50]]).all()
    np.testing.assert_allclose(found["w"].residuals, solution.trajectories[w], atol=1e-10)
    np.testing.assert_allclose(found["w"].weights, 1.0 / SIGMA_W**2)
    # the problem counts the tracked samples (N - 2) and the disturbance's N pseudo-samples;
    # the noise is read over the tracked samples less what the data determine of the free
    # quantities (the prior holds the rest of the disturbance)
    assert count_measurements(prob) == (N - 2) + N
    unc = parameter_uncertainty(prob, solution)
    free = prob.nlp.n - prob.nlp.m
    assert unc.effective_parameters is not None and 2 < unc.effective_parameters < free
    assert unc.degrees_of_freedom == pytest.approx((N - 2) - unc.effective_parameters)


def test_a_precisely_measured_input_gives_the_known_input_estimate():
    # backward Euler evaluates known and free inputs alike, at each interval's end (midpoint
    # interpolates a known input and averages a free one, a discretization difference)
    measured = realisation(7)
    known_prob, known_sol = fit(measured, modelled=False, scheme=BackwardEuler())
    prob = Problem(
        plant(),
        TIMES,
        scheme=BackwardEuler(),
        measured_inputs={F: (FORCE, 1e-5)},
        known_parameters={m: MASS},
        objective=Tracking({x: measured}, 1.0 / SIGMA_Y**2),
        cache=False,
    )
    z0 = prob.initial_guess(state_guess(measured), {c: 1.0, k: 10.0})
    # the free force starts at its measurement
    np.testing.assert_array_equal(prob.layout.node_matrix(z0)[:, 2], FORCE)
    solution = prob.solve(z0, print_level=0)
    for p in (c, k):
        assert solution.parameters[p] == pytest.approx(known_sol.parameters[p], rel=1e-5)


def test_bad_noise_options_are_all_reported_at_once():
    with pytest.raises(ProblemDefinitionError) as info:
        Problem(
            plant().with_disturbances({F: w}),
            TIMES,
            known_trajectories={F: FORCE},
            known_parameters={m: MASS},
            measured_inputs={F: (FORCE, 1.0), v: (FORCE, 1.0), x: (FORCE[:5], -1.0)},
            process_noise={w: -1.0, v: 1.0},
            cache=False,
        )
    text = str(info.value)
    assert "F is also given in known_trajectories" in text
    assert "measured_inputs: v is not an input of the model" in text
    assert "process_noise[w]: expected a finite standard deviation > 0, found -1.0" in text
    assert "process_noise: v is not an unknown input of the model" in text
    with pytest.raises(ProblemDefinitionError) as info:
        Problem(
            plant(),
            TIMES,
            measured_inputs={F: (FORCE[:5], float("nan"))},
            known_parameters={m: MASS},
            cache=False,
        )
    text = str(info.value)
    assert f"expected {N} values (one per node), found shape (5,)" in text
    assert "standard deviation: expected a finite standard deviation > 0, found nan" in text
    with pytest.raises(ProblemDefinitionError) as info:
        Problem(plant(), TIMES, measured_inputs=[F], process_noise=3.0, known_parameters={m: 1})
    text = str(info.value)
    assert "measured_inputs: expected a mapping input -> (values, standard deviation)" in text
    assert (
        "process_noise: expected a mapping disturbance -> standard deviation (or a tuple of "
        "disturbances -> covariance), found float" in text
    )
    with pytest.raises(ProblemDefinitionError, match="expected a pair"):
        Problem(plant(), TIMES, measured_inputs={F: FORCE}, known_parameters={m: MASS})


def test_disturbance_on_an_input_is_added_to_it_before_the_controller_closes_the_loop():
    from colloc import StateFeedback

    T, u = dynamicsymbols("T u")
    model = Model.from_equations(
        [x.diff(t) - v, m * v.diff(t) + c * v + k * x - T],
        [x, v],
        outputs={u: T},
        controlled_inputs=[T],
    )
    noisy = model.with_disturbances({T: w})
    assert sm.simplify(noisy.residual[1] - model.residual[1] + w) == 0
    assert noisy.outputs[u] == T + w
    feedback = StateFeedback.symbolic(1, 2)
    closed = noisy.close_loop(feedback)
    law = model.close_loop(StateFeedback.symbolic(1, 2)).residual[1]
    assert sm.simplify(closed.residual[1] - (law - w)) == 0
    assert closed.unknown_inputs == (w,)


def test_replace_data_swaps_measured_inputs_and_process_noise_like_a_fresh_build():
    """A Monte Carlo over noisy measured inputs, or a sweep over the disturbance's level,
    without rebuilding: the problem with swapped data has the objective, gradient and
    defects of a problem built with them, and the solve gives the fresh build's estimate."""
    rng = np.random.default_rng(11)
    model = plant().with_disturbances({1: w})
    measured = realisation(3)

    def build(force, sigma_f, sigma_w):
        return Problem(
            model,
            TIMES,
            measured_inputs={F: (force, sigma_f)},
            process_noise={w: sigma_w},
            known_parameters={m: MASS},
            objective=Tracking({x: measured}, 1.0 / SIGMA_Y**2),
            cache=False,
        )

    swapped = build(FORCE, 0.1, SIGMA_W)
    noisy_force = FORCE + 0.3 * rng.standard_normal(N)
    swapped.replace_data(measured_inputs={F: (noisy_force, 0.3)}, process_noise={w: 0.5})
    fresh = build(noisy_force, 0.3, 0.5)
    z = fresh.initial_guess(state_guess(measured), {c: 1.0, k: 10.0})
    np.testing.assert_array_equal(
        swapped.initial_guess(state_guess(measured), {c: 1.0, k: 10.0}), z
    )
    assert swapped.nlp.objective(z) == pytest.approx(fresh.nlp.objective(z), rel=1e-12)
    np.testing.assert_allclose(
        swapped.nlp.gradient(z), fresh.nlp.gradient(z), rtol=1e-12, atol=1e-12
    )
    np.testing.assert_allclose(swapped.defects(z), fresh.defects(z), atol=1e-12)
    a, b = swapped.solve(z, print_level=0), fresh.solve(z, print_level=0)
    for p in (c, k):
        assert a.parameters[p] == pytest.approx(b.parameters[p], rel=1e-9)
    with pytest.raises(ProblemDefinitionError, match="measured_inputs: expected the same inputs"):
        swapped.replace_data(measured_inputs={})
    with pytest.raises(ProblemDefinitionError, match=r"process_noise\[w\]: expected a finite .*-1"):
        swapped.replace_data(process_noise={w: -1.0})
    # the refused swaps changed nothing
    assert swapped.nlp.objective(z) == pytest.approx(fresh.nlp.objective(z), rel=1e-12)
    assert swapped.process_noise == fresh.process_noise
