"""What a solve says about bounds: a parameter that ends at one, a start outside them.

Reference: ``x' = -k x`` with ``x(0) = 1`` tracked from ``exp(-2 t)``; its least-squares
``k`` is 2, so a bound ``k <= 1`` must end at 1 and be named.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc import Model, Problem, Tracking

t = dynamicsymbols._t
x = dynamicsymbols("x")
k = sm.Symbol("k")
TIMES = np.linspace(0.0, 2.0, 81)


def decay(bounds):
    model = Model.from_equations([x.diff(t) + k * x], [x], parameters=[k])
    problem = Problem(
        model,
        TIMES,
        objective=Tracking({x: np.exp(-2.0 * TIMES)}),
        bounds=bounds,
        cache=False,
    )
    return problem


def test_a_parameter_at_its_bound_is_named_in_the_status():
    problem = decay({k: (0.0, 1.0)})
    solution = problem.solve(problem.initial_guess({x: np.exp(-TIMES)}, {k: 0.5}), print_level=0)
    assert solution.parameters[k] == pytest.approx(1.0, abs=1e-6)
    assert solution.status.at_bounds == ("k",)
    assert "parameters at their bounds: ['k']" in str(solution.status)
    assert solution.stats["at_bounds"] == ["k"]

    free = decay({k: (0.0, 5.0)})
    inside = free.solve(free.initial_guess({x: np.exp(-TIMES)}, {k: 0.5}), print_level=0)
    assert inside.parameters[k] == pytest.approx(2.0, rel=1e-3)  # midpoint: O(h^2) from 2
    assert inside.status.at_bounds == () and "bounds" not in str(inside.status)


def test_a_start_outside_the_bounds_is_reported():
    problem = decay({k: (0.0, 1.0)})
    with pytest.warns(UserWarning, match=r"1 value\(s\) outside the bounds, first .*k.* = 3"):
        problem.solve(problem.initial_guess({x: np.exp(-TIMES)}, {k: 3.0}), print_level=0)
