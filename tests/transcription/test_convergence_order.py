"""Measured convergence order of every scheme against its declared order.

A nonlinear implicit model with non-identity mass terms, ``3 x' = 3 v`` and
``2 v' + v/2 + x^3 = u(t) + g(t)``, is forced so that its exact solution is
``x*(t) = sin 2t + exp(-t)/2`` (method of manufactured solutions): part of the forcing is a
known input trajectory ``u`` given as data at the nodes, the rest an explicit function of
time in the residual. With the initial state fixed by instance constraints the collocation
problem is square; its solution on N, 2N-1 and 4N-3 nodes (each grid halves the steps of
the previous one) gives the error at the final time, whose ratios measure the order.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc import Model, Problem
from colloc.transcription import BackwardEuler, HermiteSimpson, Midpoint, RadauIIA, Trapezoidal

T_FINAL = 2.0
_s = sm.Symbol("s")
X_EXACT = sm.sin(2 * _s) + sm.exp(-_s) / 2
KNOWN_FORCE = sm.cos(3 * _s)


def manufactured_model():
    t = dynamicsymbols._t
    x, v, u = dynamicsymbols("x v u")
    forcing = 2 * X_EXACT.diff(_s, 2) + X_EXACT.diff(_s) / 2 + X_EXACT**3
    rest = (forcing - KNOWN_FORCE).subs(_s, t)
    model = Model.from_equations(
        [3 * x.diff(t) - 3 * v, 2 * v.diff(t) + v / 2 + x**3 - u - rest],
        [x, v],
        known_inputs=[u],
    )
    return model, x, v, u


def final_error(scheme, num_nodes):
    model, x, v, u = manufactured_model()
    x_of = sm.lambdify(_s, X_EXACT, "numpy")
    v_of = sm.lambdify(_s, X_EXACT.diff(_s), "numpy")
    u_of = sm.lambdify(_s, KNOWN_FORCE, "numpy")
    times = np.linspace(0.0, T_FINAL, num_nodes)
    problem = Problem(
        model,
        times,
        scheme=scheme,
        known_trajectories={u: u_of(times)},
        instance_constraints=[x.func(0.0) - x_of(0.0), v.func(0.0) - v_of(0.0)],
        cache=False,
    )
    assert problem.layout.num_variables == problem.layout.num_constraints  # square system
    guess = problem.initial_guess({x: x_of(times) + 0.05, v: v_of(times)})
    solution = problem.solve(guess, tol=1e-13)
    assert solution.success, solution.status
    assert np.max(np.abs(problem.defects(solution.z))) < 1e-9
    x_end, v_end = solution.trajectories[x][-1], solution.trajectories[v][-1]
    return float(np.hypot(x_end - x_of(T_FINAL), v_end - v_of(T_FINAL)))


@pytest.mark.parametrize(
    ("scheme", "num_nodes"),
    [
        (BackwardEuler(), 81),
        (Midpoint(), 21),
        (Trapezoidal(), 21),
        (RadauIIA(), 21),
        (HermiteSimpson(), 21),
    ],
    ids=lambda p: getattr(p, "name", str(p)),
)
def test_measured_order_matches_declared_order(scheme, num_nodes):
    sizes = [num_nodes, 2 * num_nodes - 1, 4 * num_nodes - 3]
    errors = np.array([final_error(scheme, n) for n in sizes])
    orders = np.log2(errors[:-1] / errors[1:])
    assert np.all(np.abs(orders - scheme.order) < 0.3), (errors, orders)


def test_declared_orders():
    """The orders the schemes declare are the textbook values."""
    assert BackwardEuler.order == 1
    assert Midpoint.order == 2
    assert Trapezoidal.order == 2
    assert HermiteSimpson.order == 4
    assert RadauIIA.order == 3


def test_higher_order_scheme_is_more_accurate_on_the_same_grid():
    errors = {s.name: final_error(s, 21) for s in (BackwardEuler(), Midpoint(), HermiteSimpson())}
    assert errors["HermiteSimpson"] < 0.1 * errors["Midpoint"] < 0.1 * errors["BackwardEuler"]


@pytest.mark.parametrize("z", [-0.5, -3.0, -100.0])
def test_radau_follows_its_stability_function_and_damps_stiff_modes(z):
    """On ``x' = lambda x`` every step multiplies by the method's stability function
    ``R(z) = (1 + z/3) / (1 - 2z/3 + z^2/6)``, ``z = lambda h``; ``R(-inf) = 0`` (L-stable),
    where the midpoint rule's ``(1 + z/2) / (1 - z/2)`` tends to -1."""
    t = dynamicsymbols._t
    x = dynamicsymbols("x")
    h, steps = 0.01, 10
    model = Model.from_equations([x.diff(t) - (z / h) * x], [x])
    times = np.arange(steps + 1) * h
    ends = {}
    for scheme in (RadauIIA(), Midpoint()):
        problem = Problem(
            model, times, scheme=scheme, instance_constraints=[x.func(0.0) - 1.0], cache=False
        )
        solution = problem.solve(problem.initial_guess({x: np.exp(z * times / h)}), tol=1e-14)
        assert solution.success
        ends[scheme.name] = solution.trajectories[x][-1]
    radau = (1 + z / 3) / (1 - 2 * z / 3 + z**2 / 6)
    assert ends["RadauIIA"] == pytest.approx(radau**steps, rel=1e-8, abs=1e-14)
    assert ends["Midpoint"] == pytest.approx(((1 + z / 2) / (1 - z / 2)) ** steps, rel=1e-8)
    if z == -100.0:
        assert abs(ends["RadauIIA"]) < 1e-15 < 0.5 < abs(ends["Midpoint"])
