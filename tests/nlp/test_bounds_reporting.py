"""What a solve says about its answer: a parameter at a bound, a start outside them, a misfit.

Reference: ``x' = -k x`` with ``x(0) = 1`` tracked from ``exp(-2 t)``; its least-squares
``k`` is 2, so a bound ``k <= 1`` must end at 1 and be named. With ``k`` held at 1 on
noisy data the residuals carry the misfit ``exp(-t) - exp(-2 t)`` (slow), with ``k`` free
only the white noise.
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


def noisy_decay(seed):
    rng = np.random.default_rng(seed)
    return np.exp(-2.0 * TIMES) + rng.normal(0.0, 0.01, TIMES.size)


def test_a_fit_that_leaves_systematic_residuals_says_so_and_a_good_one_does_not():
    data = noisy_decay(2)
    model = Model.from_equations([x.diff(t) + k * x], [x], parameters=[k])
    free = Problem(model, TIMES, objective=Tracking({x: data}), cache=False)
    good = free.solve(free.initial_guess({x: data}, {k: 1.0}), print_level=0)
    assert good.status.notes == ()
    # the same data with k held at a wrong value: the optimum the solver reports is a
    # misfit (as a worse local optimum, or a parameter at its bound, would leave)
    held = Problem(
        model, TIMES, objective=Tracking({x: data}), known_parameters={k: 1.0}, cache=False
    )
    bad = held.solve(held.initial_guess({x: data}, {}), print_level=0)
    assert bad.success
    (note,) = bad.status.notes
    assert "tracking residuals of x are systematic" in note and note in str(bad.status)
    # the bound case above: the parameter at its bound leaves the same mark
    bounded = decay({k: (0.0, 1.0)})
    at_bound = bounded.solve(bounded.initial_guess({x: data}, {k: 0.5}), print_level=0)
    assert at_bound.status.at_bounds == ("k",) and len(at_bound.status.notes) == 1


def test_printed_stats_summarise_the_log_and_keep_the_values_whole():
    import json

    t = dynamicsymbols._t
    x = dynamicsymbols("x")
    a = sm.symbols("a")
    model = Model.from_equations([x.diff(t) + a * x], [x])
    times = np.linspace(0.0, 2.0, 41)
    measured = 2.0 * np.exp(-0.7 * times)
    problem = Problem(model, times, objective=Tracking({x: measured}), cache=False)
    solution = problem.solve(problem.initial_guess({x: measured}, {a: 0.1}))
    stats = solution.stats
    log = stats["ipopt_log"]
    assert isinstance(log, str) and log.count("\n") > 20  # the whole log is there
    printed = str(stats)
    assert "<IPOPT log: " in printed and "iterations>" in printed
    longest = max(log.splitlines(), key=len)
    assert longest not in printed and len(printed) < len(log)
    assert f"'iterations': {stats['iterations']}" in printed
    assert isinstance(stats, dict) and json.loads(json.dumps(stats["times"])) == stats["times"]
