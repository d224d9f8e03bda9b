"""Gallery: a pendulum hanging from a support whose acceleration is the known input.

The plant is written with Kane's method in the support's speed ``v(t)``, so Kane's equations
hold ``v'(t)``; ``input_derivatives={v: a}`` declares that derivative as the measured support
acceleration ``a(t)``. The rod length ``L`` is estimated from noisy angles and checked
against the truth within its reported standard error. Public API only (``colloc.__all__``).
Reference: SciPy's ``solve_ivp`` of the hand-derived ``L q'' = -(g sin q + a cos q)``.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me
from scipy.integrate import solve_ivp

import colloc

t = me.dynamicsymbols._t
q, u, v, a = me.dynamicsymbols("q u v a")
m, g, L = sm.symbols("m g L", positive=True)
TRUTH = {m: 1.0, g: 9.81, L: 0.7}
SIGMA = 0.005  # rad


def support_acceleration(time):
    return 2.0 * np.sin(2.3 * time) + 1.2 * np.sin(5.1 * time + 0.4)


def support_speed(time):
    return -2.0 / 2.3 * np.cos(2.3 * time) - 1.2 / 5.1 * np.cos(5.1 * time + 0.4)


def support_pendulum() -> me.KanesMethod:
    """A bob on a massless rod from a support moving along x at the known speed ``v(t)``."""
    N = me.ReferenceFrame("N")
    B = N.orientnew("B", "Axis", (q, N.z))
    support = me.Point("support")
    support.set_vel(N, v * N.x)
    P = support.locatenew("P", -L * B.y)
    P.v2pt_theory(support, N, B)
    kane = me.KanesMethod(N, [q], [u], kd_eqs=[q.diff(t) - u])
    kane.kanes_equations([me.Particle("bob", P, m)], [(P, -m * g * N.y)])
    return kane


def plant() -> colloc.Model:
    return colloc.Model.from_kane(support_pendulum(), known_inputs=[v], input_derivatives={v: a})


def test_rod_length_from_noisy_angles_within_its_standard_error():
    times = np.linspace(0.0, 8.0, 801)
    length, gravity = TRUTH[L], TRUTH[g]

    def rhs(time, y):
        return [
            y[1],
            -(gravity * np.sin(y[0]) + support_acceleration(time) * np.cos(y[0])) / length,
        ]

    exact = solve_ivp(rhs, (0, 8), [0.3, 0.0], t_eval=times, rtol=1e-11, atol=1e-12).y
    rng = np.random.default_rng(5)
    measured = exact[0] + rng.normal(0.0, SIGMA, times.size)

    problem = colloc.Problem(
        plant(),
        times,
        known_trajectories={v: support_speed(times), a: support_acceleration(times)},
        known_parameters={m: TRUTH[m], g: TRUTH[g]},
        objective=colloc.Tracking({q: measured}, weights={q: SIGMA**-2}),
    )
    guess = problem.initial_guess({q: measured, u: np.gradient(measured, times)}, {L: 1.0})
    solution = problem.solve(guess, print_level=0)
    assert solution.success
    se = colloc.parameter_uncertainty(problem, solution).standard_errors[L]
    assert abs(solution.parameters[L] - length) < 3 * se
    assert se < 0.01 * length  # and the data do determine it


def test_an_input_through_its_derivative_is_accepted_with_input_derivatives():
    kane = support_pendulum()
    assert v.diff(t) in kane.forcing.atoms(sm.Derivative)
    with pytest.raises(colloc.ModelError, match=r"differentiates v.*input_derivatives=\{v: a\}"):
        colloc.Model.from_kane(kane, known_inputs=[v])
    model = colloc.Model.from_kane(kane, known_inputs=[v], input_derivatives={v: a})
    assert a in model.known_inputs and v in model.known_inputs
    assert not any(d.expr == v for d in model.residual.atoms(sm.Derivative))
    acceleration = sm.solve(model.residual[1], u.diff(t))[0]
    assert sm.simplify(acceleration + (g * sm.sin(q) + a * sm.cos(q)) / L) == 0


def test_input_derivatives_are_validated():
    kane = support_pendulum()
    with pytest.raises(colloc.ModelError, match="input_derivatives: expected each value"):
        colloc.Model.from_kane(kane, known_inputs=[v], input_derivatives={v: sm.Symbol("a")})
    with pytest.raises(colloc.ModelError, match="input_derivatives: expected a mapping"):
        colloc.Model.from_kane(kane, known_inputs=[v], input_derivatives=[(v, a)])  # type: ignore[arg-type]
