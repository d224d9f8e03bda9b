"""Objective terms written as integrals, and integrands in the model's outputs.

References: NumPy's trapezoidal rule and plain sums of the same expressions evaluated
directly on the trajectories.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc import IntegralCost, Model, Problem, TerminalCost, Tracking, parameter_uncertainty
from colloc.nlp.residuals import tracking_residuals

t = dynamicsymbols._t
x, v, y = dynamicsymbols("x v y")
k, c = sm.symbols("k c")
TIMES = np.sort(np.r_[0.0, np.random.default_rng(7).uniform(0.0, 3.0, 40), 3.0])
STATES = {x: np.cos(2.0 * TIMES), v: -2.0 * np.sin(2.0 * TIMES)}
DATA = np.sin(TIMES)


def model() -> Model:
    return Model.from_equations(
        [x.diff(t) - v, v.diff(t) + c * v + k * x], [x, v], outputs={y: x**2 + v}
    )


def value(objective, parameters=None) -> float:
    prob = Problem(model(), TIMES, objective=objective, cache=False)
    z = prob.initial_guess(STATES, parameters or {k: 3.0, c: 0.5})
    return float(prob.nlp.objective(z))


def test_tracking_as_an_integral_is_the_trapezoidal_rule():
    out = STATES[x] ** 2 + STATES[v]
    r2 = 4.0 * (out - DATA) ** 2
    assert value(Tracking({y: DATA}, 4.0, integral=True)) == pytest.approx(
        np.trapezoid(r2, TIMES), rel=1e-12
    )
    assert value(Tracking({y: DATA}, 4.0)) == pytest.approx(np.sum(r2), rel=1e-12)


def test_integral_cost_takes_outputs_and_parameters():
    out = STATES[x] ** 2 + STATES[v]
    expected = np.trapezoid(out**2 + (3.0 - 2.0) ** 2, TIMES)  # k = 3
    assert value(IntegralCost(y**2 + (k - 2) ** 2)) == pytest.approx(expected, rel=1e-12)


def test_terminal_cost_takes_outputs():
    out = STATES[x] ** 2 + STATES[v]
    assert value(TerminalCost(c * y)) == pytest.approx(0.5 * out[-1], rel=1e-12)


def test_integral_tracking_weights_each_sample_by_its_quadrature_factor():
    prob = Problem(model(), TIMES, objective=Tracking({y: DATA}, 2.0, integral=True), cache=False)
    z = prob.initial_guess(STATES, {k: 3.0, c: 0.5})
    (signal,) = tracking_residuals(prob, z)
    h = np.diff(TIMES)
    factors = np.r_[h / 2, 0.0] + np.r_[0.0, h / 2]
    np.testing.assert_allclose(signal.weights, 2.0 * factors, rtol=1e-14)
    np.testing.assert_allclose(signal.residuals, STATES[x] ** 2 + STATES[v] - DATA, atol=1e-12)


def test_integral_and_sum_tracking_give_the_same_errors_on_a_uniform_grid():
    # on a uniform grid the integral is h times the sum but for the ends' half weight:
    # the same estimates and standard errors to within the two end samples' share
    times = np.linspace(0.0, 4.0, 401)
    wd = np.sqrt(9.0 - 0.04)
    clean = 0.2 * np.exp(-0.2 * times) * np.cos(wd * times)
    measured = clean + 1e-3 * np.random.default_rng(2).standard_normal(times.size)
    plain_model = Model.from_equations([x.diff(t) - v, v.diff(t) + c * v + k * x], [x, v])
    results = []
    for term in (Tracking({x: measured}), Tracking({x: measured}, 100.0, integral=True)):
        prob = Problem(plain_model, times, objective=term, cache=False)
        sol = prob.solve(prob.initial_guess({x: measured}, {k: 8.0, c: 0.3}))
        assert sol.success
        unc = parameter_uncertainty(prob, sol)
        results.append((sol.parameters[k], unc.standard_errors[k], unc.standard_errors[c]))
    (k1, se_k1, se_c1), (k2, se_k2, se_c2) = results
    assert abs(k1 - k2) < 0.1 * se_k1  # 0.05 of it; the ends' half weights
    assert se_k2 == pytest.approx(se_k1, rel=0.02)
    assert se_c2 == pytest.approx(se_c1, rel=0.02)


def test_integral_flag_must_be_a_bool():
    with pytest.raises(TypeError, match="integral: expected True or False, found 'yes'"):
        Tracking({y: DATA}, integral="yes")
