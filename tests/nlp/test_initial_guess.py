"""Problem.initial_guess takes mappings by symbol or arrays in the documented shapes.

Reference: the same start built from mappings; the layout's own accessors.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc import Model, Problem, Tracking

t = dynamicsymbols._t
x, v, w = dynamicsymbols("x v w")
k, c = sm.symbols("k c")
TIMES = np.linspace(0.0, 1.0, 21)


@pytest.fixture(scope="module")
def problem():
    model = Model.from_equations([x.diff(t) - v, v.diff(t) + c * v + k * x], [x, v])
    return Problem(
        model.with_disturbances({1: w}),
        TIMES,
        objective=Tracking({x: np.cos(TIMES)}),
        process_noise={w: 0.1},
        cache=False,
    )


def test_arrays_give_the_start_the_mappings_give(problem):
    X = np.column_stack([np.cos(TIMES), -np.sin(TIMES), 0.01 * TIMES])
    names = problem.layout.parameter_names
    values = np.arange(1.0, len(names) + 1.0)
    by_symbol = problem.initial_guess(
        {x: X[:, 0], v: X[:, 1], w: X[:, 2]},
        {p: val for p, val in zip(problem.partition.unknown_parameters, values, strict=True)},
    )
    np.testing.assert_array_equal(problem.initial_guess(X, values), by_symbol)
    # states only: the free input gets the default
    states_only = problem.initial_guess(X[:, :2], list(values))
    np.testing.assert_array_equal(states_only[problem.layout.node_indices("w")], 0.0)
    np.testing.assert_array_equal(
        states_only[problem.layout.node_indices("x")], by_symbol[problem.layout.node_indices("x")]
    )


def test_arrays_of_another_shape_are_refused_with_the_expected_one(problem):
    with pytest.raises(
        ValueError, match=r"trajectories: .*\(21, 2\) or \(21, 3\).*\['x', 'v', 'w'\]"
    ):
        problem.initial_guess(np.zeros((20, 2)))
    with pytest.raises(ValueError, match=r"parameters: .*shape \(2,\).*found shape \(3,\)"):
        problem.initial_guess(None, np.zeros(3))
