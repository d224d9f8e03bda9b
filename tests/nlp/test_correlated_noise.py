"""Process noise correlated between disturbances: ``process_noise={(w1, w2): S}``.

Reference: the same problem written with independent unit disturbances ``v`` entering as
``w = L v`` (``S = L L^T``), which the scalar ``process_noise`` already poses: the two are one
maximum a posteriori problem, so their estimates and standard errors must agree.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc import Model, Problem, ProblemDefinitionError, Tracking, parameter_uncertainty

t = dynamicsymbols._t
x1, x2, F, w1, w2, v1, v2 = dynamicsymbols("x1 x2 F w1 w2 v1 v2")
a, b, c = sm.symbols("a b c")
TIMES = np.linspace(0.0, 6.0, 121)
FORCE = np.sin(2.0 * TIMES) + 0.5 * np.sin(5.3 * TIMES)
S = np.array([[0.04, 0.03], [0.03, 0.09]])  # correlation 0.5
L = np.linalg.cholesky(S)
SIGMA_Y = 0.02


def equations(d1, d2):
    return [x1.diff(t) + a * x1 - b * x2 - d1, x2.diff(t) + c * x2 - F - d2]


def data(seed=4):
    """The noise-free response to the force (a = 1, b = 0.5, c = 2) plus sensor noise."""
    from scipy.integrate import solve_ivp

    def rhs(time, x):
        force = np.sin(2.0 * time) + 0.5 * np.sin(5.3 * time)
        return [-x[0] + 0.5 * x[1], -2.0 * x[1] + force]

    truth = solve_ivp(rhs, (0, 6), [0.0, 0.0], t_eval=TIMES, rtol=1e-10, atol=1e-12).y
    rng = np.random.default_rng(seed)
    return truth + SIGMA_Y * rng.standard_normal(truth.shape)


def solved(model, process_noise, measured):
    problem = Problem(
        model,
        TIMES,
        known_trajectories={F: FORCE},
        objective=Tracking({x1: measured[0], x2: measured[1]}, 1 / SIGMA_Y**2),
        process_noise=process_noise,
        cache=False,
    )
    guess = problem.initial_guess({x1: measured[0], x2: measured[1]}, {a: 0.8, b: 0.4, c: 1.5})
    solution = problem.solve(guess)
    assert solution.success
    return problem, solution


@pytest.fixture(scope="module")
def pair():
    measured = data()
    correlated = Model.from_equations(
        equations(0, 0), [x1, x2], known_inputs=[F]
    ).with_disturbances({0: w1, 1: w2})
    whitened = Model.from_equations(
        equations(L[0, 0] * v1, L[1, 0] * v1 + L[1, 1] * v2),
        [x1, x2],
        known_inputs=[F],
        unknown_inputs=[v1, v2],
    )
    return (
        solved(correlated, {(w1, w2): S}, measured),
        solved(whitened, {v1: 1.0, v2: 1.0}, measured),
    )


def test_a_covariance_is_the_problem_of_independent_unit_disturbances_through_its_factor(pair):
    (problem, solution), (reference, expected) = pair
    for p in (a, b, c):
        assert solution.parameters[p] == pytest.approx(expected.parameters[p], rel=1e-7)
    assert solution.stats["objective"] == pytest.approx(expected.stats["objective"], rel=1e-8)
    # the disturbances are the reference's L v
    v = np.vstack([expected.trajectories[v1], expected.trajectories[v2]])
    w = np.vstack([solution.trajectories[w1], solution.trajectories[w2]])
    np.testing.assert_allclose(w, L @ v, atol=1e-7)
    for method in ("kkt", "sandwich"):
        found = parameter_uncertainty(problem, solution, method=method, discretisation=False)
        ref = parameter_uncertainty(reference, expected, method=method, discretisation=False)
        for p in (a, b, c):
            assert found.standard_errors[p] == pytest.approx(ref.standard_errors[p], rel=1e-5)


def test_correlation_changes_the_fit_and_a_diagonal_covariance_is_the_scalar_one(pair):
    (problem, solution), _ = pair
    measured = data()
    model = problem.model
    independent = solved(model, {w1: 0.2, w2: 0.3}, measured)[1]
    diagonal = solved(model, {(w1, w2): np.diag([0.04, 0.09])}, measured)[1]
    for p in (a, b, c):
        assert diagonal.parameters[p] == pytest.approx(independent.parameters[p], rel=1e-8)
    assert not np.isclose(solution.parameters[a], independent.parameters[a], rtol=1e-4)


def test_a_new_covariance_of_the_same_group_needs_no_rebuild(pair):
    (problem, _), _ = pair
    measured = data()
    other = np.array([[0.09, -0.02], [-0.02, 0.04]])
    fresh = solved(problem.model, {(w1, w2): other}, measured)[1]
    problem.replace_data(process_noise={(w1, w2): other})
    guess = problem.initial_guess({x1: measured[0], x2: measured[1]}, {a: 0.8, b: 0.4, c: 1.5})
    swapped = problem.solve(guess)
    for p in (a, b, c):
        assert swapped.parameters[p] == pytest.approx(fresh.parameters[p], rel=1e-8)
    with pytest.raises(
        ProblemDefinitionError, match=r"expected the same disturbances .*\(w1, w2\)"
    ):
        problem.replace_data(process_noise={w1: 0.1, w2: 0.1})
    problem.replace_data(process_noise={(w1, w2): S})


def test_bad_covariances_are_all_named_at_once():
    model = Model.from_equations(equations(0, 0), [x1, x2], known_inputs=[F]).with_disturbances(
        {0: w1, 1: w2}
    )

    def problems(noise):
        with pytest.raises(ProblemDefinitionError) as info:
            Problem(
                model,
                TIMES,
                known_trajectories={F: FORCE},
                objective=Tracking({x1: FORCE}),
                process_noise=noise,
                cache=False,
            )
        return str(info.value)

    text = problems({(w1, w2): [[1.0, 2.0], [2.0, 1.0]], (x1,): [[1.0]]})
    assert (
        "process_noise[w1, w2]: expected a positive definite covariance, found eigenvalues" in text
    )
    assert "process_noise: x1 is not an unknown input" in text
    text = problems({(w1, w2): np.eye(3)})
    assert (
        "expected a 2 x 2 covariance matrix (one row per disturbance), found shape (3, 3)" in text
    )
    text = problems({(w1, w2): [[1.0, 0.5], [0.4, 1.0]]})
    assert "process_noise[w1, w2]: expected a symmetric matrix" in text
    text = problems({(w1, w2): np.eye(2), w2: 1.0})
    assert "process_noise[w2]: w2 given twice; each disturbance belongs to one entry" in text
    text = problems({(w1, w2): [["x", 0], [0, 1]]})
    assert "process_noise[w1, w2]: expected a 2 x 2 covariance matrix, found" in text
