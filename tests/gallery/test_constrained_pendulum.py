"""Gallery: a pendulum written in Cartesian coordinates with Lagrange's method and a constraint.

The bob's position ``(x, y)`` is held at distance ``L`` from the pivot by a holonomic
constraint, so ``from_lagrange`` gives the Lagrange multiplier ``lam1`` as an algebraic state;
a known horizontal force ``F(t)`` drives it against viscous drag ``c``. The drag and the rod
length are estimated from noisy positions and checked against the truth within their
reported standard errors; the multiplier against the rod tension of the truth. Public API
only. Reference: SciPy's ``solve_ivp`` of the same pendulum in its angle,
``m L q'' = -m g sin q - c L q' + F cos q``.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me
from scipy.integrate import solve_ivp

import colloc

t = me.dynamicsymbols._t
x, y, F = me.dynamicsymbols("x y F")
m, g, L, c = sm.symbols("m g L c", positive=True)
TRUTH = {m: 1.0, g: 9.81, L: 0.8, c: 0.3}
SIGMA = 0.002  # m
TIMES = np.linspace(0.0, 10.0, 1001)


def force(time):
    return 1.5 * np.sin(1.7 * time) + 0.8 * np.sin(4.3 * time + 1.0)


def cartesian_pendulum() -> me.LagrangesMethod:
    N = me.ReferenceFrame("N")
    pivot = me.Point("O")
    pivot.set_vel(N, 0)
    bob = pivot.locatenew("P", x * N.x + y * N.y)
    bob.set_vel(N, x.diff(t) * N.x + y.diff(t) * N.y)
    lagrange = me.LagrangesMethod(
        me.Lagrangian(N, me.Particle("bob", bob, m)),
        [x, y],
        hol_coneqs=[x**2 + y**2 - L**2],
        forcelist=[(bob, -m * g * N.y - c * bob.vel(N) + F * N.x)],
        frame=N,
    )
    lagrange.form_lagranges_equations()
    return lagrange


def truth():
    """Angle, rate and the multiplier that holds the rod (from the y equation)."""
    mass, gravity, length, drag = (TRUTH[s] for s in (m, g, L, c))

    def rhs(time, s):
        q, w = s
        return [
            w,
            (-mass * gravity * np.sin(q) - drag * length * w + force(time) * np.cos(q))
            / (mass * length),
        ]

    q, w = solve_ivp(rhs, (0, 10), [0.4, 0.0], t_eval=TIMES, rtol=1e-11, atol=1e-12).y
    acc = np.array([rhs(tk, s)[1] for tk, s in zip(TIMES, np.c_[q, w], strict=True)])
    y_, yd = -length * np.cos(q), length * np.sin(q) * w
    ydd = length * (np.cos(q) * w**2 + np.sin(q) * acc)
    lam = -(drag * yd + gravity * mass + mass * ydd) / (2 * y_)  # from SymPy's eom row 2
    return q, w, lam


def test_drag_and_rod_length_from_noisy_positions_within_their_standard_errors():
    q, _, lam_true = truth()
    rng = np.random.default_rng(11)
    xm = TRUTH[L] * np.sin(q) + rng.normal(0.0, SIGMA, TIMES.size)
    ym = -TRUTH[L] * np.cos(q) + rng.normal(0.0, SIGMA, TIMES.size)

    model = colloc.Model.from_lagrange(cartesian_pendulum(), known_inputs=[F])
    ux, uy, lam = model.states[2:]
    assert model.algebraic_states == (lam,)
    assert len(model.initial_constraints) == 2  # position and velocity level
    problem = colloc.Problem(
        model,
        TIMES,
        known_trajectories={F: force(TIMES)},
        known_parameters={m: TRUTH[m], g: TRUTH[g]},
        objective=colloc.Tracking({x: xm, y: ym}, weights={x: SIGMA**-2, y: SIGMA**-2}),
    )
    # a start consistent with the constraint: on the circle, moving along it
    angle = np.unwrap(np.arctan2(xm, -ym))
    rate = np.gradient(angle, TIMES)
    guess = problem.initial_guess(
        {
            x: 0.75 * np.sin(angle),
            y: -0.75 * np.cos(angle),
            ux: 0.75 * np.cos(angle) * rate,
            uy: 0.75 * np.sin(angle) * rate,
        },
        {c: 1.0, L: 0.75},
    )
    solution = problem.solve(guess, print_level=0)
    assert solution.success, solution.status
    se = colloc.parameter_uncertainty(problem, solution).standard_errors
    for p in (c, L):
        assert abs(solution.parameters[p] - TRUTH[p]) < 3 * se[p], (p, solution.parameters[p])
    assert se[c] < 0.01 * TRUTH[c] and se[L] < 1e-3 * TRUTH[L]

    X, Y, LAM = (solution.trajectories[s] for s in (x, y, lam))
    length = solution.parameters[L]
    # the constraint holds along the whole motion, not only where it was imposed: the
    # midpoint rule's drift of the differentiated constraint, 9e-5 of L^2 measured
    assert np.max(np.abs(X**2 + Y**2 - length**2)) < 1e-3 * length**2
    # the multiplier is the rod's (the rod tension over 2L): no alternating mode at the nodes
    assert np.max(np.abs(LAM - lam_true)) < 0.02 * np.max(np.abs(lam_true))


def test_constrained_lagrange_models_carry_the_constraints_for_the_first_node():
    model = colloc.Model.from_lagrange(cartesian_pendulum(), known_inputs=[F])
    ux, uy = model.states[2:4]
    position, velocity = model.initial_constraints
    assert sm.expand(position - (x**2 + y**2 - L**2)) == 0
    assert sm.expand(velocity - (2 * x * ux + 2 * y * uy)) == 0
    assert L in model.parameters
    # the closing row is the acceleration-level constraint: it holds the speeds' derivatives
    closing = model.residual[-1]
    assert closing.has(ux.diff(t)) and closing.has(uy.diff(t))
    with pytest.raises(colloc.ModelError, match="constraints hold L"):
        colloc.Model.from_lagrange(cartesian_pendulum(), known_inputs=[F], parameters=[m, g, c])
