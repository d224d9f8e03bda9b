"""Solving in scaled variables: the same problem, its derivatives scaled consistently.

References: finite differences of the scaled functions; the unscaled solve's optimum; an
active bound reached exactly in the original units.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc import Model, Problem, Tracking
from colloc.solve.scaling import ScaledNLP

t = dynamicsymbols._t
x, v = dynamicsymbols("x v")
k, c = sm.symbols("k c")
TIMES = np.linspace(0.0, 2.0, 81)
K_TRUE, C_TRUE = 400.0, 0.02  # gains four orders apart


def msd_problem(bounds=None):
    model = Model.from_equations([x.diff(t) - v, v.diff(t) + c * v + k * x], [x, v])
    w = np.sqrt(K_TRUE)
    data = 0.1 * np.exp(-0.5 * C_TRUE * TIMES) * np.cos(w * TIMES)
    noise = np.random.default_rng(0).normal(0.0, 1e-3, TIMES.size)
    return Problem(
        model,
        TIMES,
        objective=Tracking({x: data + noise}, 1e6),
        bounds=bounds,
        cache=False,
    )


def test_scaled_derivatives_match_finite_differences():
    prob = msd_problem()
    nlp = prob.nlp
    scale = prob.variable_scale({k: 300.0, c: 0.05, x: 0.1})
    scaled = ScaledNLP(nlp, scale)
    rng = np.random.default_rng(1)
    zs = rng.normal(size=nlp.n)
    step = 1e-6
    e = np.zeros(nlp.n)
    for i in (0, 5, nlp.n - 2, nlp.n - 1):
        e[:] = 0.0
        e[i] = step
        fd_f = (scaled.objective(zs + e) - scaled.objective(zs - e)) / (2 * step)
        assert fd_f == pytest.approx(scaled.gradient(zs)[i], rel=1e-6, abs=1e-6)
        fd_g = (scaled.constraints(zs + e) - scaled.constraints(zs - e)) / (2 * step)
        jr, jc = scaled.jacobianstructure()
        col = np.zeros(nlp.m)
        np.add.at(col, jr[jc == i], scaled.jacobian(zs)[jc == i])
        np.testing.assert_allclose(col, fd_g, rtol=1e-6, atol=1e-6)
    # the Hessian of the Lagrangian: finite differences of its gradient
    lam = rng.normal(size=nlp.m)
    hr, hc = scaled.hessianstructure()
    H = np.zeros((nlp.n, nlp.n))
    np.add.at(H, (hr, hc), scaled.hessian(zs, lam, 1.0))
    H = H + np.tril(H, -1).T
    jr, jc = scaled.jacobianstructure()

    def lagrangian_gradient(z):
        grad = scaled.gradient(z).copy()
        np.add.at(grad, jc, scaled.jacobian(z) * lam[jr])
        return grad

    i = nlp.n - 2  # k: the parameter column couples every interval
    e[:] = 0.0
    e[i] = step
    fd = (lagrangian_gradient(zs + e) - lagrangian_gradient(zs - e)) / (2 * step)
    np.testing.assert_allclose(H[:, i], fd, rtol=1e-5, atol=1e-5)


def test_scaled_solve_reaches_the_unscaled_optimum():
    prob = msd_problem()
    guess = prob.initial_guess({x: 0.1 * np.cos(20.0 * TIMES)}, {k: 350.0, c: 0.0})
    plain = prob.solve(guess)
    scaled = prob.solve(guess, scale={k: 400.0, c: 0.02, x: 0.1, v: 2.0})
    assert plain.success and scaled.success
    assert scaled.stats["scale"] == {"k": 400.0, "c": 0.02, "x": 0.1, "v": 2.0}
    assert plain.stats["scale"] == {}
    for p in (k, c):
        assert scaled.parameters[p] == pytest.approx(plain.parameters[p], rel=1e-5, abs=1e-8)
    assert scaled.stats["objective"] == pytest.approx(plain.stats["objective"], rel=1e-7)


def test_bounds_hold_in_original_units():
    prob = msd_problem(bounds={c: (0.05, 1.0)})  # the truth 0.02 is below: c ends at 0.05
    guess = prob.initial_guess({x: 0.1 * np.cos(20.0 * TIMES)}, {k: 350.0, c: 0.5})
    sol = prob.solve(guess, scale={c: 0.01})
    assert sol.success
    assert sol.parameters[c] == pytest.approx(0.05, rel=1e-6)
    # IPOPT relaxes bounds by bound_relax_factor (1e-8, relative) in its own units
    assert sol.parameters[c] >= 0.05 * (1.0 - 1e-8) - 1e-14
    assert sol.status.at_bounds == ("c",)


def test_bad_scales_are_refused_naming_them():
    prob = msd_problem()
    guess = prob.initial_guess()
    with pytest.raises(ValueError, match=r"scale: c: expected a positive number, found -1"):
        prob.solve(guess, scale={c: -1})
    with pytest.raises(ValueError, match=r"scale: t is not a state, free input or unknown"):
        prob.solve(guess, scale={sm.Symbol("t"): 1.0})
