"""Outputs that measure an input (a joint torque): compiled values and an identification.

The closed loop ``x' = -a x + r + e``, ``r = -g x`` with a measured excitation ``e``; the
output ``y = r`` becomes ``-g x`` when the loop is closed. The tracking objective is checked
against NumPy at a random point, and the gain is identified from ``x`` and ``r`` measured
along an ODE solution (SciPy's integrator, not the collocation problem).
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
from scipy.integrate import solve_ivp
from sympy.physics.mechanics import dynamicsymbols

from colloc import Model, Problem, StateFeedback, Tracking, cramer_rao_bound

t = dynamicsymbols._t
x, r, e, y = dynamicsymbols("x r e y")
a = sm.Symbol("a")
A_TRUE, G_TRUE, X0 = 0.5, 2.0, 1.0
TIMES = np.linspace(0.0, 6.0, 601)


def excitation(tt):
    return np.sin(2.0 * tt) + 0.5 * np.sin(5.3 * tt)


def closed_model():
    model = Model.from_equations(
        [x.diff(t) + a * x - r - e],
        [x],
        controlled_inputs=[r],
        known_inputs=[e],
        outputs={x: x, y: r},
    )
    feedback = StateFeedback.symbolic(1, 1)
    return model.close_loop(feedback), feedback.K[0, 0]


def measured():
    sol = solve_ivp(
        lambda tt, s: [-(A_TRUE + G_TRUE) * s[0] + excitation(tt)],
        (TIMES[0], TIMES[-1]),
        [X0],
        t_eval=TIMES,
        rtol=1e-10,
        atol=1e-12,
    )
    return sol.y[0], -G_TRUE * sol.y[0]


def problem(xm, ym, weights=None):
    closed, g = closed_model()
    return (
        Problem(
            closed,
            TIMES,
            known_trajectories={e: excitation(TIMES)},
            known_parameters={a: A_TRUE},
            objective=Tracking({x: xm, y: ym}, weights),
            cache=False,
        ),
        g,
    )


def random_point(seed):
    """The problem on random data (weights 0.3 on x, 1.7 on y) at a random point."""
    rng = np.random.default_rng(seed)
    xm, ym = rng.standard_normal((2, TIMES.size))
    pr, g = problem(xm, ym, {x: 0.3, y: 1.7})
    xs, gv = rng.standard_normal(TIMES.size), 1.3
    return pr, g, xm, ym, xs, gv, pr.initial_guess({x: xs}, {g: gv})


def test_tracking_an_input_output_matches_numpy():
    pr, _, xm, ym, xs, gv, z = random_point(4)
    expected = np.sum(0.3 * (xs - xm) ** 2 + 1.7 * (-gv * xs - ym) ** 2)
    assert pr.nlp.objective(z) == pytest.approx(expected, rel=1e-12)


def test_gain_identified_from_state_and_torque():
    xm, ym = measured()
    pr, g = problem(xm, ym)
    solution = pr.solve(pr.initial_guess({x: xm}, {g: 1.0}))
    assert solution.success
    # midpoint at h = 0.01 s: second-order error, far below the start's 50 %
    assert solution.parameters[g] == pytest.approx(G_TRUE, rel=1e-3)


def test_measuring_the_torque_tightens_the_bound():
    xm, ym = measured()
    with_torque, g = problem(xm, ym, {x: 1.0, y: 1.0})
    without, _ = problem(xm, ym, {x: 1.0, y: 0.0})
    z = with_torque.initial_guess({x: xm}, {g: G_TRUE})
    tight = cramer_rao_bound(with_torque, z).standard_errors[g]
    loose = cramer_rao_bound(without, z).standard_errors[g]
    assert tight < loose


def test_gauss_newton_hessian_is_2_jt_w_j_of_the_residuals():
    # residuals per node: r_x = x - xm (weight 0.3), r_y = -g x - ym (weight 1.7); by hand
    # d2/dx2 = 2 (0.3 + 1.7 g^2), d2/dx dg = 2 * 1.7 g x, d2/dg2 = sum 2 * 1.7 x^2, while
    # the exact Hessian adds the residual-weighted 2 * 1.7 * r_y * (-1) to the cross term
    pr, g, _, ym, xs, gv, z = random_point(5)
    nlp, lay = pr.nlp, pr.layout
    rows, cols = nlp.hessianstructure()
    dense = np.zeros((nlp.n, nlp.n))
    np.add.at(dense, (rows, cols), nlp.gauss_newton_hessian(z))
    exact = np.zeros((nlp.n, nlp.n))
    np.add.at(exact, (rows, cols), nlp.hessian(z, np.zeros(nlp.m), 1.0))
    ix = lay.node_indices("x")
    ig = lay.variable_index(g.name)
    np.testing.assert_allclose(dense[ix, ix], 2 * (0.3 + 1.7 * gv**2), rtol=1e-12)
    np.testing.assert_allclose(dense[ig, ix], 2 * 1.7 * gv * xs, rtol=1e-12)
    assert dense[ig, ig] == pytest.approx(np.sum(2 * 1.7 * xs**2), rel=1e-12)
    r_y = -gv * xs - ym
    np.testing.assert_allclose(exact[ig, ix] - dense[ig, ix], 2 * 1.7 * r_y * -1.0, atol=1e-12)
