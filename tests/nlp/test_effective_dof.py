"""The effective number of estimated quantities (the influence matrix's trace) and the noise
variance read over the effective degrees of freedom.

References: a linear problem, ``x' = p + w`` measured with noise and ``w`` penalised by a
Gaussian prior, whose influence matrix ``X (X^T X / s^2 + P)^-1 X^T / s^2`` is written out
densely; without the disturbance, the count of free quantities; a Monte Carlo of the noise
variance estimate under the right prior.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc import Model, Problem, Tracking, parameter_uncertainty
from colloc.nlp.influence import influence_trace

t = dynamicsymbols._t
x, w = dynamicsymbols("x w")
p = sm.Symbol("p")
SIGMA, SIGMA_W = 0.05, 0.4


def drift(times, measured, prior=True):
    """``x' = p + w``: midpoint, ``x`` tracked with weight 1/SIGMA^2, ``w`` with its prior."""
    model = Model.from_equations([x.diff(t) - p], [x])
    if prior:
        model = model.with_disturbances({0: w})
    problem = Problem(
        model,
        times,
        objective=Tracking({x: measured}, SIGMA**-2),
        process_noise={w: SIGMA_W} if prior else None,
        cache=False,
    )
    solution = problem.solve(problem.initial_guess({x: measured}, {p: 0.0}))
    assert solution.success
    return problem, solution


def dense_trace(times):
    """tr A of the same problem written as a linear regression on b = (x0, p, w_0..w_N-1)."""
    N, h = times.size, np.diff(times)
    X = np.zeros((N, N + 2))
    X[:, 0] = 1.0
    for k in range(1, N):  # x_k = x_{k-1} + h (p + (w_{k-1} + w_k) / 2)
        X[k] = X[k - 1]
        X[k, 1] += h[k - 1]
        X[k, 2 + k - 1] += h[k - 1] / 2
        X[k, 2 + k] += h[k - 1] / 2
    P = np.diag([0.0, 0.0] + [SIGMA_W**-2] * N)
    A = X @ np.linalg.solve(X.T @ X / SIGMA**2 + P, X.T) / SIGMA**2
    return float(np.trace(A))


@pytest.fixture(scope="module")
def record():
    times = np.linspace(0.0, 4.0, 401)
    rng = np.random.default_rng(2)
    truth = 0.3 * times + np.cumsum(SIGMA_W * rng.standard_normal(times.size)) * 0.01
    return times, truth + SIGMA * rng.standard_normal(times.size)


def test_the_trace_is_the_linear_regressions_exactly_and_estimated_within_its_spread(record):
    times, measured = record
    problem, solution = drift(times, measured)
    reference = dense_trace(times)
    exact = influence_trace(problem, solution.z, probes=10_000)
    assert exact == pytest.approx(reference, rel=1e-8)
    assert 2.0 < reference < times.size  # the prior holds w: fewer than its N + 2 unknowns
    # Hutchinson's estimate: within 4 of its standard deviations sqrt(2 tr A / probes)
    estimate = influence_trace(problem, solution.z)
    assert abs(estimate - reference) < 4 * np.sqrt(2 * reference / 64)
    assert influence_trace(problem, solution.z, seed=1) != estimate  # the seed is used


def test_without_a_prior_the_trace_counts_the_free_quantities(record):
    times, measured = record
    problem, solution = drift(times, measured, prior=False)
    free = problem.nlp.n - problem.nlp.m  # x0 and p
    assert free == 2
    assert influence_trace(problem, solution.z, probes=10_000) == pytest.approx(2.0, rel=1e-8)


def test_the_noise_variance_over_the_effective_dof_is_unbiased_under_the_right_prior():
    """w drawn from its prior, x measured with SIGMA: over realisations the variance per unit
    weight averages 1 (for a linear model with the right prior ``E[sum w r^2] = s^2 (n -
    tr A)`` exactly). With a prior 10 times too loose neither count is unbiased (the
    residuals then hold ``n - 2 tr A + tr A^2``), but the effective one is closer to 1 than
    ``J* / (n - free)``, which misses what the loose disturbance took from the residuals."""
    from colloc.nlp.uncertainty import count_measurements

    times = np.linspace(0.0, 4.0, 201)
    h = np.diff(times)
    found: dict[str, list[float]] = {"right": [], "loose": [], "loose by count": []}
    for seed in range(12):
        rng = np.random.default_rng(100 + seed)
        disturbance = SIGMA_W * rng.standard_normal(times.size)
        truth = np.concatenate(
            [[0.0], np.cumsum(h * (0.3 + 0.5 * (disturbance[:-1] + disturbance[1:])))]
        )
        measured = truth + SIGMA * rng.standard_normal(times.size)
        for name, scale in (("right", 1.0), ("loose", 10.0)):
            model = Model.from_equations([x.diff(t) - p], [x]).with_disturbances({0: w})
            problem = Problem(
                model,
                times,
                objective=Tracking({x: measured}, SIGMA**-2),
                process_noise={w: SIGMA_W * scale},
                cache=False,
            )
            solution = problem.solve(problem.initial_guess({x: measured}, {p: 0.0}))
            result = parameter_uncertainty(problem, solution, method="kkt", discretisation=False)
            found[name].append(result.noise_variance)
            assert result.effective_parameters is not None
            assert result.degrees_of_freedom == pytest.approx(
                times.size - result.effective_parameters
            )
            if name == "loose":
                free = problem.nlp.n - problem.nlp.m
                count = count_measurements(problem) - free
                found["loose by count"].append(solution.stats["objective"] / count)
    right = np.array(found["right"])
    assert abs(right.mean() - 1.0) < 4 * right.std(ddof=1) / np.sqrt(right.size)
    loose, by_count = np.mean(found["loose"]), np.mean(found["loose by count"])
    assert by_count < loose < 1.0 and loose - by_count > 0.1
