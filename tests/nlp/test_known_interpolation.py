"""How a known input is evaluated between the nodes is the rule its trajectory names.

Reference: for ``x' = r(t)`` the midpoint defect of interval k is
``(x_{k+1} - x_k) / h - r_mid``; states built from independent sums of the rule's midpoint
values (the trapezoidal rule for the node mean; the exact midpoint values of a cubic
``r``, which four-node cubic interpolation reproduces) make every defect vanish.
"""

from __future__ import annotations

import numpy as np
import pytest
from sympy.physics.mechanics import dynamicsymbols

from colloc import KnownTrajectory, Model, Problem, Tracking
from colloc.model.errors import ProblemDefinitionError
from colloc.transcription import HermiteSimpson, LinearInterpolation, Midpoint

t = dynamicsymbols._t
x, r = dynamicsymbols("x r")
TIMES = np.sort(np.r_[0.0, np.random.default_rng(3).uniform(0.0, 2.0, 17), 2.0])


def cubic(s):
    return s**3 - 2.0 * s**2 + 0.5


def problem(values, scheme=None):
    model = Model.from_equations([x.diff(t) - r], [x], known_inputs=[r])
    return Problem(
        model,
        TIMES,
        scheme=scheme,
        known_trajectories={r: values},
        objective=Tracking({x: np.zeros(TIMES.size)}),
        cache=False,
    )


def defects_for(prob, increments):
    states = np.r_[0.0, np.cumsum(increments)]
    return prob.defects(prob.initial_guess({x: states}))


def test_linear_rule_is_the_mean_of_the_two_nodes():
    values = cubic(TIMES)
    h = np.diff(TIMES)
    trapezoid = h * 0.5 * (values[:-1] + values[1:])
    linear = problem(KnownTrajectory(values, "linear"))
    assert np.max(np.abs(defects_for(linear, trapezoid))) < 1e-12
    # the default (cubic) rule is not the mean: the same states leave defects of the size of
    # the cubic's curvature term h^2 r''/8
    default = problem(values)
    assert np.max(np.abs(defects_for(default, trapezoid))) > 1e-3


def test_cubic_rule_reproduces_a_cubic_at_the_midpoints():
    values = cubic(TIMES)
    h = np.diff(TIMES)
    exact_mid = h * cubic(0.5 * (TIMES[:-1] + TIMES[1:]))
    for entry in (values, KnownTrajectory(values), KnownTrajectory(values, "cubic")):
        assert np.max(np.abs(defects_for(problem(entry), exact_mid))) < 1e-10


def test_rule_reaches_hermite_simpson_midpoint_residual():
    values = cubic(TIMES)
    linear = problem(KnownTrajectory(values, LinearInterpolation()), HermiteSimpson())
    z = linear.initial_guess({x: np.zeros(TIMES.size)})
    n_mid = linear.layout.interval_names.index("x'_mid")
    mids = linear.layout.interval_matrix(z)
    mids[:, n_mid] = 0.5 * (values[:-1] + values[1:])
    block = next(b for b in linear.layout.blocks if b.name == "interval")
    rows = linear.defects(z)[block.offset : block.offset + block.size].reshape(-1, 3)
    # the third defect of each interval is the residual x'_mid - r_mid
    assert np.max(np.abs(rows[:, 2])) < 1e-12


def test_replace_data_keeps_the_rule_of_a_plain_array_and_takes_a_new_one():
    values = cubic(TIMES)
    h = np.diff(TIMES)
    trapezoid = h * 0.5 * (values[:-1] + values[1:])
    prob = problem(KnownTrajectory(values, "linear"), Midpoint())
    prob.replace_data(known_trajectories={r: 2.0 * values})
    assert np.max(np.abs(defects_for(prob, 2.0 * trapezoid))) < 1e-12
    prob.replace_data(known_trajectories={r: KnownTrajectory(values, "cubic")})
    exact_mid = h * cubic(0.5 * (TIMES[:-1] + TIMES[1:]))
    assert np.max(np.abs(defects_for(prob, exact_mid))) < 1e-10


def test_unknown_rule_is_refused_naming_the_choices():
    with pytest.raises(ValueError, match=r"between: .*\['cubic', 'linear'\].*'spline'"):
        KnownTrajectory(np.zeros(3), "spline")
    with pytest.raises(ProblemDefinitionError, match=r"known_trajectories\[r\]: expected shape"):
        problem(KnownTrajectory(np.zeros(3), "linear"))
