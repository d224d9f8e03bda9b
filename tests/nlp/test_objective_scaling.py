"""The objective scaled for IPOPT when its curvature dwarfs the defects' (issue 31, item 4).

Absolute tracking weights ``1 / sigma^2`` of a precise sensor (a weight of 1e10 here) made
MUMPS reallocate its workspace at every factorisation: 10.8 s against 0.05 s. The solve now
passes IPOPT ``obj_scaling_factor``, which brings the largest diagonal entry of the
objective's Gauss-Newton Hessian at the start to the defects' largest Jacobian entry. Checked against the same problem with weight 1 (a second, well-scaled solve of
the same minimiser): the estimates agree, the objective is reported unscaled, no
reallocation is logged, and a factor the user gives is kept.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc import Model, Problem, Tracking
from colloc.nlp.solving import objective_scaling

t = dynamicsymbols._t
x, v, F = dynamicsymbols("x v F")
c, k = sm.symbols("c k")
TIMES = np.linspace(0.0, 10.0, 1001)
FORCE = 6.0 * np.sin(3.1 * TIMES) + 3.0 * np.sin(7.3 * TIMES + 1.0)


def measured() -> np.ndarray:
    """Positions of x'' + 0.6 x' + 25 x = F by the midpoint recursion, with 2 mm noise."""
    h = TIMES[1] - TIMES[0]
    A = np.array([[1.0, -h / 2], [25.0 * h / 2, 1.0 + 0.6 * h / 2]])
    B = np.array([[1.0, h / 2], [-25.0 * h / 2, 1.0 - 0.6 * h / 2]])
    state = np.zeros((TIMES.size, 2))
    for j in range(TIMES.size - 1):
        force = 0.5 * (FORCE[j] + FORCE[j + 1])
        state[j + 1] = np.linalg.solve(A, B @ state[j] + [0.0, h * force])
    return state[:, 0] + np.random.default_rng(4).normal(0.0, 0.002, TIMES.size)


def problem(weight: float, data: np.ndarray) -> tuple[Problem, np.ndarray]:
    model = Model.from_equations(
        [x.diff(t) - v, v.diff(t) + c * v + k * x - F], [x, v], outputs=[x], known_inputs=[F]
    )
    p = Problem(
        model,
        TIMES,
        known_trajectories={F: FORCE},
        objective=Tracking({x: data}, weight),
        cache=False,
    )
    return p, p.initial_guess({x: data, v: np.gradient(data, TIMES)}, {c: 0.3, k: 20.0})


def test_a_large_weight_is_scaled_away_and_gives_the_unit_weight_estimate():
    data = measured()
    plain, z_plain = problem(1.0, data)
    heavy, z_heavy = problem(1e10, data)
    assert objective_scaling(plain.nlp, z_plain) is None  # curvature 2: left as it is
    factor = objective_scaling(heavy.nlp, z_heavy)
    # d^2/dx^2 of w (x - d)^2 = 2 w, brought to the defects' largest Jacobian entry (about
    # 1 / h = 100: the midpoint defect of v, 1 / h + c / 2)
    assert factor == pytest.approx(100.0 / 2e10, rel=0.01)
    reference = plain.solve(z_plain, stall_seconds=None)
    scaled = heavy.solve(z_heavy, stall_seconds=None)
    assert scaled.success and reference.success
    assert scaled.stats["ipopt_options"]["obj_scaling_factor"] == pytest.approx(factor)
    assert "obj_scaling_factor" not in reference.stats["ipopt_options"]
    for p in (c, k):
        assert scaled.parameters[p] == pytest.approx(reference.parameters[p], rel=1e-8)
    # reported unscaled: the weighted objective is the unit one times the weight
    assert scaled.stats["objective"] == pytest.approx(1e10 * reference.stats["objective"], rel=1e-6)
    assert "reallocating" not in scaled.stats["ipopt_log"]


def test_a_scaling_factor_the_user_gives_is_kept():
    heavy, z0 = problem(1e10, measured())
    solution = heavy.solve(z0, stall_seconds=None, obj_scaling_factor=1e-9, max_iter=3)
    assert solution.stats["ipopt_options"]["obj_scaling_factor"] == 1e-9
