"""Per-output noise variances in ``parameter_uncertainty``, against the spread of estimates.

A damped oscillator is fitted to its position and speed measured with noise of very
different size (1 mm and 0.1 m/s) under equal weights: the pooled variance is then wrong
for both signals, the per-output one right for each. Reference: the spread of the
estimates over independent noise realisations (the problem built once, the data swapped).
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc import Model, Problem, Tracking, parameter_uncertainty

t = dynamicsymbols._t
x, v = dynamicsymbols("x v")
k, c = sm.symbols("k c")
TIMES = np.linspace(0.0, 4.0, 201)
K_TRUE, C_TRUE = 9.0, 0.4
SIGMAS = {x: 1e-3, v: 0.1}
REALISATIONS = 40
SPREAD_FACTOR = 1.5


def truth() -> dict:
    wd = np.sqrt(K_TRUE - C_TRUE**2 / 4)
    decay = np.exp(-0.5 * C_TRUE * TIMES)
    pos = 0.2 * decay * np.cos(wd * TIMES)
    vel = 0.2 * decay * (-0.5 * C_TRUE * np.cos(wd * TIMES) - wd * np.sin(wd * TIMES))
    return {x: pos, v: vel}


@pytest.fixture(scope="module")
def fits():
    clean = truth()
    model = Model.from_equations([x.diff(t) - v, v.diff(t) + c * v + k * x], [x, v])
    out = {}
    for name, weights in (
        ("equal", {x: 1.0, v: 1.0}),
        ("right", {y: s**-2 for y, s in SIGMAS.items()}),
    ):
        problem = Problem(model, TIMES, objective=Tracking(clean, weights), cache=False)
        estimates, pooled, separate = [], [], []
        for seed in range(REALISATIONS):
            rng = np.random.default_rng(seed)
            data = {y: clean[y] + SIGMAS[y] * rng.standard_normal(TIMES.size) for y in clean}
            problem.replace_data(objective=Tracking(data, weights))
            guess = problem.initial_guess({x: data[x], v: clean[v]}, {k: 8.0, c: 0.3})
            sol = problem.solve(guess)
            assert sol.success, sol.stats["message"]
            a = parameter_uncertainty(problem, sol, method="kkt")
            b = parameter_uncertainty(problem, sol, per_output=True)
            assert (a.method, b.method) == ("kkt", "kkt per output")
            estimates.append([sol.parameters[k], sol.parameters[c]])
            pooled.append([a.standard_errors[k], a.standard_errors[c]])
            separate.append([b.standard_errors[k], b.standard_errors[c]])
        out[name] = tuple(map(np.array, (estimates, pooled, separate)))
    return out


def test_per_output_errors_match_the_spread_under_wrong_weights(fits):
    estimates, pooled, separate = fits["equal"]
    spread = estimates.std(axis=0, ddof=1)
    ratio = spread / separate.mean(axis=0)
    assert np.all((ratio > 1 / SPREAD_FACTOR) & (ratio < SPREAD_FACTOR)), ratio
    # the pooled variance averages the two signals' (about sigma_v^2 / 2), while the speed,
    # which carries most of the information, has sigma_v^2: pooled errors are too small
    # by about sqrt(2), i.e. overconfident
    overconfidence = separate.mean(axis=0) / pooled.mean(axis=0)
    assert np.all(overconfidence > 1.25), overconfidence


def test_per_output_errors_equal_the_pooled_ones_under_right_weights(fits):
    estimates, pooled, separate = fits["right"]
    agreement = separate.mean(axis=0) / pooled.mean(axis=0)
    assert np.all(np.abs(agreement - 1) < 0.1), agreement
    spread = estimates.std(axis=0, ddof=1)
    ratio = spread / separate.mean(axis=0)
    assert np.all((ratio > 1 / SPREAD_FACTOR) & (ratio < SPREAD_FACTOR)), ratio


def test_per_output_is_refused_with_the_sandwich(fits):
    clean = truth()
    model = Model.from_equations([x.diff(t) - v, v.diff(t) + c * v + k * x], [x, v])
    problem = Problem(model, TIMES, objective=Tracking(clean), cache=False)
    sol = problem.solve(problem.initial_guess(clean, {k: 8.0, c: 0.3}))
    with pytest.raises(ValueError, match="per_output: only for method='kkt'"):
        parameter_uncertainty(problem, sol, method="sandwich", per_output=True)


def test_per_output_with_priors_needs_absolute_tracking_weights():
    """With a process-noise prior (weight ``1 / sigma_w^2``) the tracking weights must be
    ``1 / sigma^2`` as well: relative weights (1 for a signal with 1 mm noise) put the data in
    other units than the prior, and per_output refuses by name instead of reporting errors
    two orders of magnitude off. Absolute weights pass and give errors of the KKT size."""
    w = dynamicsymbols("w")
    model = Model.from_equations(
        [x.diff(t) - v, v.diff(t) + c * v + k * x - w], [x, v], unknown_inputs=[w]
    )
    clean = truth()
    rng = np.random.default_rng(3)
    data = {y: clean[y] + SIGMAS[y] * rng.standard_normal(TIMES.size) for y in clean}
    results = {}
    for name, weights in (
        ("relative", {x: 1.0, v: 1.0}),
        ("absolute", {y: s**-2 for y, s in SIGMAS.items()}),
    ):
        problem = Problem(
            model, TIMES, objective=Tracking(data, weights), process_noise={w: 0.05}, cache=False
        )
        sol = problem.solve(problem.initial_guess({x: data[x], v: clean[v]}, {k: 8.0, c: 0.3}))
        assert sol.success
        try:
            results[name] = parameter_uncertainty(problem, sol, per_output=True)
        except ValueError as error:
            results[name] = error
    refused = results["relative"]
    assert isinstance(refused, ValueError)
    assert "per_output: the priors of process_noise / measured_inputs" in str(refused)
    assert "variance per unit weight is x (" in str(refused) and "relative" in str(refused)
    accepted = results["absolute"]
    assert not isinstance(accepted, ValueError) and accepted.method == "kkt per output"
    assert 0 < accepted.standard_errors[k] < 0.5  # K_TRUE = 9: a finite, small error
