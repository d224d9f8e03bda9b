"""Model.with_disturbances: process-noise trajectories added to chosen equations.

Checked against the plain residual (symbolically), against the built NLP's defects (a start
with ``w = F`` is consistent with the equations), and end to end: a disturbance force that
drove a backward-Euler mass-spring-damper is recovered from exact positions.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc import IntegralCost, Model, Problem, Tracking
from colloc.model.errors import ModelError
from colloc.transcription import BackwardEuler

t = dynamicsymbols._t
MASS, DAMPING, STIFFNESS = 2.0, 0.8, 30.0


def oscillator():
    x, v = dynamicsymbols("x v")
    m, c, k = sm.symbols("m c k")
    model = Model.from_equations(
        [x.diff(t) - v, m * v.diff(t) + c * v + k * x], [x, v], outputs=[x]
    )
    return model, (x, v), {m: MASS, c: DAMPING, k: STIFFNESS}


def test_disturbance_is_subtracted_from_its_row_only_and_becomes_an_unknown_input():
    model, (x, v), _ = oscillator()
    w = dynamicsymbols("w")
    disturbed = model.with_disturbances({1: w})
    assert sm.simplify(disturbed.residual[1] - (model.residual[1] - w)) == 0
    assert disturbed.residual[0] == model.residual[0]
    assert disturbed.unknown_inputs == (w,)
    assert disturbed.states == model.states and disturbed.parameters == model.parameters
    assert model.unknown_inputs == ()  # the original is untouched


def test_bad_disturbances_are_all_reported_at_once():
    model, (x, v), _ = oscillator()
    a = dynamicsymbols("a")
    with pytest.raises(ModelError) as info:
        model.with_disturbances({2: a, 0: sm.Symbol("c"), 1: x})
    text = str(info.value)
    assert "row 2 is not an equation" in text
    assert "c for row 0 is not a function of t" in text
    assert "x is already a state or input" in text
    with pytest.raises(ModelError, match="row True is not an equation"):
        model.with_disturbances({True: a})
    with pytest.raises(ModelError, match="given for two rows"):
        model.with_disturbances({0: a, 1: a})
    with pytest.raises(ModelError, match="non-empty mapping"):
        model.with_disturbances({})


def test_a_start_with_w_equal_to_the_residual_satisfies_every_defect():
    model, (x, v), constants = oscillator()
    w_x, w_v = dynamicsymbols("w_x w_v")
    disturbed = model.with_disturbances({0: w_x, 1: w_v})
    times = np.linspace(0.0, 2.0, 41)
    problem = Problem(
        disturbed, times, scheme=BackwardEuler(), known_parameters=constants, cache=False
    )
    # any states at all: not a solution of the undisturbed equations
    states = {x: np.sin(3 * times) + times**2, v: np.cos(times)}
    undisturbed = problem.defects(problem.initial_guess(states)).reshape(-1, 2)
    assert np.abs(undisturbed).max() > 1.0
    # backward Euler evaluates the residual at each interval's end: w there equals F there
    w = {w_x: np.r_[0.0, undisturbed[:, 0]], w_v: np.r_[0.0, undisturbed[:, 1]]}
    consistent = problem.defects(problem.initial_guess({**states, **w}))
    assert np.abs(consistent).max() < 1e-12


def backward_euler_motion(times, force):
    """The exact backward-Euler solution of m v' + c v + k x = w from rest at x = 0.1."""
    h = times[1] - times[0]
    x, v = np.zeros(times.size), np.zeros(times.size)
    x[0] = 0.1
    system = np.array([[1.0, -h], [STIFFNESS * h, MASS + DAMPING * h]])
    for k in range(times.size - 1):
        x[k + 1], v[k + 1] = np.linalg.solve(system, [x[k], MASS * v[k] + h * force[k + 1]])
    return x, v


def test_disturbance_force_is_recovered_from_exact_positions():
    model, (x, v), constants = oscillator()
    w = dynamicsymbols("w")
    disturbed = model.with_disturbances({1: w})
    times = np.linspace(0.0, 2.0, 201)
    force = 5.0 * np.sin(4.0 * times) + 2.0 * np.cos(11.0 * times)
    measured, velocity = backward_euler_motion(times, force)
    problem = Problem(
        disturbed,
        times,
        scheme=BackwardEuler(),
        known_parameters=constants,
        objective=[Tracking({x: measured}, 1e6), IntegralCost(1e-8 * w**2)],
        instance_constraints=[v.func(0.0)],  # from rest: else v(0) and w(h) trade off
        cache=False,
    )
    solution = problem.solve(problem.initial_guess({x: measured}), print_level=0, tol=1e-10)
    assert solution.success, solution.status
    # w at node 0 enters no backward-Euler defect; the penalty sends it to 0
    assert np.max(np.abs(solution.trajectories[w][1:] - force[1:])) < 1e-3 * np.abs(force).max()
    assert np.max(np.abs(solution.trajectories[v] - velocity)) < 1e-6
    assert abs(solution.trajectories[w][0]) < 1e-3
