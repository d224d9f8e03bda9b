"""Gallery: two masses, the first pushed by a force nobody measured (an unknown input).

The plant is written as implicit equations with the force ``w(t)`` on the first mass
declared an unknown input: colloc estimates it at every node beside the coupling spring and
the second mass's spring and damper, from both masses' measured positions. The force enters
only the first mass's equation, so it is determined by that equation and the data; a loose
prior (``process_noise`` of 25 times the force's size) keeps the problem regular without
shrinking it. (With the force on the only measured mass, the parameters would be
identifiable only through the prior, and a maximum a posteriori fit shrinks the force and
biases them: the docs' process-noise page says when that holds.) The parameters are checked
against the truth within their standard errors, and the estimated force against the force
applied. Public API only (``colloc.__all__``).
Reference: SciPy's ``solve_ivp``.
"""

from __future__ import annotations

import numpy as np
import sympy as sm
from scipy.integrate import solve_ivp
from sympy.physics.mechanics import dynamicsymbols

import colloc

t = dynamicsymbols._t
x1, v1, x2, v2, w = dynamicsymbols("x1 v1 x2 v2 w")
m1, m2, k12, k2, c2 = sm.symbols("m1 m2 k12 k2 c2")
TRUTH = {m1: 1.0, m2: 0.5, k12: 30.0, k2: 12.0, c2: 0.7}
SIGMA = 0.001  # m


def push(time):
    return 2.0 * np.sin(1.7 * time) + 1.5 * np.sin(4.9 * time + 0.3) + np.sin(9.1 * time)


def test_parameters_and_the_unknown_force_from_positions():
    times = np.linspace(0.0, 10.0, 1001)
    p = {s: TRUTH[s] for s in TRUTH}

    def rhs(time, y):
        a, va, b, vb = y
        spring = p[k12] * (a - b)
        return [
            va,
            (push(time) - spring) / p[m1],
            vb,
            (spring - p[k2] * b - p[c2] * vb) / p[m2],
        ]

    exact = solve_ivp(rhs, (0.0, 10.0), [0.0] * 4, t_eval=times, rtol=1e-11, atol=1e-13).y
    rng = np.random.default_rng(4)
    measured = {x1: exact[0], x2: exact[2]}
    measured = {s: y + rng.normal(0.0, SIGMA, times.size) for s, y in measured.items()}

    model = colloc.Model.from_equations(
        [
            x1.diff(t) - v1,
            m1 * v1.diff(t) + k12 * (x1 - x2) - w,
            x2.diff(t) - v2,
            m2 * v2.diff(t) - k12 * (x1 - x2) + k2 * x2 + c2 * v2,
        ],
        [x1, v1, x2, v2],
        unknown_inputs=[w],
    )
    problem = colloc.Problem(
        model,
        times,
        scheme=colloc.transcription.HermiteSimpson(),
        known_parameters={m1: TRUTH[m1], m2: TRUTH[m2]},
        objective=colloc.Tracking(measured, SIGMA**-2),
        process_noise={w: 25 * 2.0},
    )
    guess = problem.initial_guess(
        {
            x1: measured[x1],
            v1: np.gradient(measured[x1], times),
            x2: measured[x2],
            v2: np.gradient(measured[x2], times),
        },
        {k12: 20.0, k2: 8.0, c2: 0.3},
    )
    solution = problem.solve(guess)
    assert solution.success, solution.status
    errors = colloc.parameter_uncertainty(problem, solution).standard_errors
    for s in (k12, k2, c2):
        assert abs(solution.parameters[s] - TRUTH[s]) < 3 * errors[s], (s, solution.parameters[s])
        assert errors[s] < 0.1 * TRUTH[s]
    # the force, estimated at every node, follows the one applied: node by node it carries
    # the second difference of the position noise (tens of newtons at 1 mm and 100 Hz),
    # which averages out over a window (its sum telescopes)
    window = np.ones(25) / 25
    estimate = np.convolve(solution.trajectories[w], window, "valid")
    applied = np.convolve(push(times), window, "valid")
    rms = np.sqrt(np.mean((estimate - applied) ** 2))
    # ... so that it explains at least 80 % of the applied force's variance
    assert rms < np.sqrt(0.2) * np.sqrt(np.mean(applied**2)), rms
