"""The scheme's own error in estimated parameters, by Richardson from a grid twice as fine.

References: Betts and Huffman's (2003, section 7) single-parameter problem, whose solution is
known in closed form (``y1 = sin(p t)`` with ``p = pi``), so each estimate's actual error is
known; the midpoint rule's second and Hermite-Simpson's fourth order; the objective of the
refined problem against the original's at the same samples.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc import (
    DiscretisationWarning,
    KnownTrajectory,
    Model,
    Problem,
    Tracking,
    discretisation_error,
    parameter_uncertainty,
    refined_problem,
)
from colloc.nlp.refinement import refined_times
from colloc.transcription import HermiteSimpson, Midpoint

t = dynamicsymbols._t
y1, y2 = dynamicsymbols("y1 y2")
mu, p = sm.symbols("mu p")
MODEL = Model.from_equations(
    [y1.diff(t) - y2, y2.diff(t) - mu**2 * y1 + (mu**2 + p**2) * sm.sin(p * t)],
    [y1, y2],
    outputs=[y1],
)
TIMES = np.linspace(0.0, 1.0, 100)


def betts(scheme, noise_sd=0.0, seed=0, stiffness=60.0):
    """The problem on 100 nodes (noise 0.05 as in opty's example, or none), solved. With
    ``mu = 60`` the dynamics have a mode growing as ``exp(60 t)``, which pins ``p`` to a
    standard error of about 1e-27 whatever the noise."""
    rng = np.random.default_rng(seed)
    measured = np.sin(np.pi * TIMES) + noise_sd * rng.standard_normal(TIMES.size)
    problem = Problem(
        MODEL,
        TIMES,
        scheme,
        known_parameters={mu: stiffness},
        objective=Tracking({y1: measured}, 1 / 0.05**2),
        instance_constraints=[y1.func(0.0), y2.func(0.0) - np.pi],
        cache=False,
    )
    guess = problem.initial_guess(
        {y1: np.sin(np.pi * TIMES), y2: np.pi * np.cos(np.pi * TIMES)}, {p: 3.0}
    )
    solution = problem.solve(guess)
    assert solution.success
    return problem, solution


@pytest.mark.parametrize(("scheme", "order"), [(Midpoint(), 2), (HermiteSimpson(), 4)])
def test_the_estimate_is_the_actual_error_of_noise_free_data(scheme, order):
    problem, solution = betts(scheme)
    actual = solution.parameters[p] - np.pi
    estimate = discretisation_error(problem, solution)
    assert estimate.estimated and estimate.order == order
    # the actual errors: midpoint 6.6e-4, Hermite-Simpson 1.0e-8
    assert abs(actual) > (1e-4 if order == 2 else 1e-9)
    assert estimate.errors[p] == pytest.approx(actual, rel=0.01)
    # the refined grid's own error is the coarse one over 2^order
    refined_actual = estimate.refined[p] - np.pi
    assert actual / refined_actual == pytest.approx(2.0**order, rel=0.1)


def test_midpoint_warns_where_the_standard_error_says_nothing():
    """Betts's dynamics pin ``p`` to a standard error of ~1e-27: midpoint's error 6.6e-4 is
    warned of, Hermite-Simpson's 1e-8 (3e-9 of the value, under DISCRETISATION_RTOL) is
    not."""
    problem, solution = betts(Midpoint())
    with pytest.warns(DiscretisationWarning, match=r"p \(-0.000657.*against SE"):
        result = parameter_uncertainty(problem, solution)
    assert result.standard_errors[p] < 1e-20
    assert result.discretisation_errors[p] == pytest.approx(solution.parameters[p] - np.pi, 0.01)
    assert result.discretisation_note.startswith("Richardson, order 2")
    problem, solution = betts(HermiteSimpson())
    with warnings.catch_warnings():
        warnings.simplefilter("error", DiscretisationWarning)
        result = parameter_uncertainty(problem, solution)
    assert abs(result.discretisation_errors[p]) < 1e-7
    # asked not to, it is not estimated
    assert (
        parameter_uncertainty(problem, solution, discretisation=False).discretisation_errors == {}
    )


def test_where_noise_sets_the_error_bar_the_midpoint_error_is_not_warned_of():
    """``mu = 1``: no fast mode, and opty's noise of 0.05 gives ``p`` a standard error of
    about 1e-2, beside which the midpoint rule's error on 100 nodes is small."""
    problem, solution = betts(Midpoint(), noise_sd=0.05, seed=3, stiffness=1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DiscretisationWarning)
        result = parameter_uncertainty(problem, solution)
    error, se = result.discretisation_errors[p], result.standard_errors[p]
    assert 0 < abs(error) < 0.5 * se
    # and it is still the change a refined grid makes, within the scheme's order
    noise_free_problem, noise_free = betts(Midpoint(), stiffness=1.0)
    actual = noise_free.parameters[p] - np.pi
    assert discretisation_error(noise_free_problem, noise_free).errors[p] == pytest.approx(
        actual, rel=0.05
    )


def test_the_refined_problem_has_the_same_objective_and_inputs():
    problem, solution = betts(Midpoint(), noise_sd=0.05, seed=1)
    fine = refined_problem(problem)
    np.testing.assert_array_equal(fine.grid.times[0::2], problem.grid.times)
    np.testing.assert_allclose(fine.grid.times[1::2], 0.5 * (TIMES[:-1] + TIMES[1:]))
    # any fine trajectory through the coarse one's samples costs what the coarse one costs
    rng = np.random.default_rng(5)
    X = np.column_stack([solution.trajectories[y1], solution.trajectories[y2]])
    fine_X = rng.standard_normal((fine.grid.num_nodes, 2))
    fine_X[0::2] = X
    z = fine.initial_guess(fine_X, {p: solution.parameters[p]})
    assert fine.nlp.objective(z) == pytest.approx(solution.stats["objective"], rel=1e-10)


def test_known_inputs_keep_their_rule_between_nodes_and_measured_ones_their_samples():
    x, v, F, G = dynamicsymbols("x v F G")
    k = sm.symbols("k")
    model = Model.from_equations(
        [x.diff(t) - v, v.diff(t) + k * x - F - G], [x, v], known_inputs=[F, G]
    )
    times = np.linspace(0.0, 2.0, 11)
    square = np.where(times < 1.0, 0.0, 1.0)
    problem = Problem(
        model,
        times,
        known_trajectories={F: KnownTrajectory(square, "linear")},
        objective=Tracking({x: np.sin(times)}),
        measured_inputs={G: (np.cos(times), 0.1)},
        cache=False,
    )
    fine = refined_problem(problem)
    middles = 0.5 * (square[:-1] + square[1:])  # the linear rule's, not a cubic's overshoot
    np.testing.assert_array_equal(fine.known_trajectories[F][1::2], middles)
    values, sigma = fine.measured_inputs[G]
    np.testing.assert_array_equal(values[0::2], np.cos(times))
    assert np.all(np.isnan(values[1::2])) and sigma == 0.1


def test_process_noise_is_not_refined_and_says_why():
    x, v, w = dynamicsymbols("x v w")
    k = sm.symbols("k")
    model = Model.from_equations([x.diff(t) - v, v.diff(t) + k * x], [x, v]).with_disturbances(
        {1: w}
    )
    times = np.linspace(0.0, 3.0, 31)
    problem = Problem(
        model, times, objective=Tracking({x: np.cos(times)}), process_noise={w: 0.1}, cache=False
    )
    with pytest.raises(ValueError, match="process_noise, whose prior is per node"):
        refined_problem(problem)
    solution = problem.solve(problem.initial_guess({x: np.cos(times)}, {k: 1.0}))
    estimate = discretisation_error(problem, solution)
    assert not estimate.estimated and "not estimated: problem: has process_noise" in estimate.note


def test_refined_times_interleave():
    np.testing.assert_array_equal(refined_times(np.array([0.0, 1.0, 3.0])), [0, 0.5, 1, 2, 3])
