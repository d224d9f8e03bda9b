"""Gallery: a driven mass on a hardening (cubic) spring and a damper, no controller.

Plain parameter estimation: the plant is written with Kane's method, the driving force is a
known input, and the linear and cubic stiffness and the damping are estimated from a noisy
position record with their standard errors. Public API only (``colloc.__all__``).
Reference: SciPy's ``solve_ivp`` of ``m x'' = F - c x' - k1 x - k3 x^3``.
"""

from __future__ import annotations

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me
from scipy.integrate import solve_ivp

import colloc

x, u, F = me.dynamicsymbols("x u F")
m, c, k1, k3 = sm.symbols("m c k1 k3")
TRUTH = {m: 1.0, c: 0.6, k1: 25.0, k3: 400.0}
SIGMA = 0.002  # m


def force(time):
    return 6.0 * np.sin(3.1 * time) + 3.0 * np.sin(7.3 * time + 1.0)


def plant() -> colloc.Model:
    N = me.ReferenceFrame("N")
    wall = me.Point("wall")
    wall.set_vel(N, 0)
    P = wall.locatenew("P", x * N.x)
    P.set_vel(N, u * N.x)
    spring_and_damper = (-k1 * x - k3 * x**3 - c * u + F) * N.x
    kane = me.KanesMethod(N, [x], [u], kd_eqs=[x.diff() - u])
    kane.kanes_equations([me.Particle("mass", P, m)], [(P, spring_and_damper)])
    return colloc.Model.from_kane(kane, known_inputs=[F])


def test_stiffness_and_damping_within_their_standard_errors():
    times = np.linspace(0.0, 10.0, 1001)
    mass, damping, linear, cubic = (TRUTH[s] for s in (m, c, k1, k3))

    def rhs(time, y):
        return [y[1], (force(time) - damping * y[1] - linear * y[0] - cubic * y[0] ** 3) / mass]

    exact = solve_ivp(rhs, (0.0, 10.0), [0.05, 0.0], t_eval=times, rtol=1e-11, atol=1e-12).y
    measured = exact[0] + np.random.default_rng(11).normal(0.0, SIGMA, times.size)
    # the spring must be driven into its cubic range for k3 to show
    assert np.max(np.abs(exact[0])) > 0.15

    problem = colloc.Problem(
        plant(),
        times,
        # fourth order: at this noise level the midpoint rule's O(h^2) bias in k3 (0.5 %)
        # would be five standard errors
        scheme=colloc.transcription.HermiteSimpson(),
        known_trajectories={F: force(times)},
        known_parameters={m: mass},
        objective=colloc.Tracking({x: measured}, SIGMA**-2),
    )
    guess = problem.initial_guess(
        {x: measured, u: np.gradient(measured, times)}, {c: 1.0, k1: 10.0, k3: 0.0}
    )
    solution = problem.solve(guess, scale={k1: 10.0, k3: 100.0})
    assert solution.success, solution.status
    errors = colloc.parameter_uncertainty(problem, solution).standard_errors
    for p in (c, k1, k3):
        assert abs(solution.parameters[p] - TRUTH[p]) < 3 * errors[p], (p, solution.parameters[p])
        assert errors[p] < 0.05 * TRUTH[p]  # the record determines each of them
