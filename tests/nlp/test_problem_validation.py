"""Every validation error path of Problem, its objective terms, the grid and solve()."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc import (
    IntegralCost,
    Model,
    Problem,
    ProblemDefinitionError,
    TerminalCost,
    Tracking,
)
from colloc.transcription import HermiteSimpson, Midpoint, TimeGrid

t = dynamicsymbols._t
q, u, r, f = dynamicsymbols("q u r f")
k, c, m = sm.symbols("k c m")
TIMES = np.linspace(0.0, 1.0, 5)


@pytest.fixture(scope="module")
def model():
    """Driven oscillator: controlled torque r (free), known force f."""
    return Model.from_equations(
        [q.diff(t) - u, m * u.diff(t) + c * u + k * q - r - f],
        [q, u],
        controlled_inputs=[r],
        known_inputs=[f],
    )


def make(model, **overrides):
    args = {
        "times": TIMES,
        "known_trajectories": {f: np.zeros(5)},
        "known_parameters": {m: 1.0, c: 0.1, k: 2.0},
        "cache": False,
    }
    args.update(overrides)
    return Problem(model, **args)


def test_a_valid_definition_builds(model):
    problem = make(model)
    assert problem.layout.node_names == ["q", "u", "r"]
    assert problem.layout.num_variables == 5 * 3
    assert problem.layout.num_constraints == 4 * 2


# --------------------------------------------------------------------------- types
def test_model_must_be_a_model():
    with pytest.raises(TypeError, match=r"model: expected a colloc.Model, found str"):
        Problem("pendulum", TIMES)


@pytest.mark.parametrize("scheme", ["midpoint", Midpoint], ids=["string", "class"])
def test_scheme_must_be_a_scheme_object(model, scheme):
    with pytest.raises(TypeError, match=r"scheme: expected a scheme object such as Midpoint\(\)"):
        make(model, scheme=scheme)


# --------------------------------------------------------------------------- times / grid
@pytest.mark.parametrize(
    ("times", "pattern"),
    [
        ([0.0, 0.5, 0.5, 0.7, 1.0], r"times: expected strictly increasing values, found t\[1\]"),
        ([0.0, 0.6, 0.4, 0.7, 1.0], r"times: expected strictly increasing values, found t\[1\]"),
        ([0.0], r"times: expected a 1-D array of at least 2 times, found shape \(1,\)"),
        (
            np.zeros((5, 1)),
            r"times: expected a 1-D array of at least 2 times, found shape \(5, 1\)",
        ),
        ([0.0, 0.2, np.nan, 0.7, 1.0], r"times: expected finite values, found NaN or inf"),
    ],
    ids=["repeated", "decreasing", "single", "two-dimensional", "nan"],
)
def test_times_must_be_strictly_increasing_and_finite(model, times, pattern):
    with pytest.raises(ValueError, match=pattern):
        make(model, times=times)


def test_uniform_grid_arguments():
    with pytest.raises(ValueError, match=r"duration: expected a positive number, found -1.0"):
        TimeGrid.uniform(-1.0, 10)
    with pytest.raises(ValueError, match=r"num_nodes: expected at least 2, found 1"):
        TimeGrid.uniform(1.0, 1)
    np.testing.assert_allclose(TimeGrid.uniform(2.0, 5, start=1.0).times, [1, 1.5, 2, 2.5, 3])


# --------------------------------------------------------------------------- trajectories
@pytest.mark.parametrize(
    ("trajectories", "pattern"),
    [
        (
            {f: np.zeros(5), q: np.zeros(5)},
            r"known_trajectories: q is a state \(inputs: \['r', 'f'\]\)",
        ),
        (
            {f: np.zeros(5), sm.Function("w")(t): np.zeros(5)},
            r"known_trajectories: w is not an input of the model",
        ),
        (
            {f: np.zeros(4)},
            r"known_trajectories\[f\]: expected shape \(5,\) \(one value per node\), found \(4,\)",
        ),
        ({f: [0.0, np.nan, 0.0, 0.0, 0.0]}, r"known_trajectories\[f\]: expected finite values"),
        ({}, r"known_trajectories: the model's known inputs \['f'\] have no trajectory"),
    ],
    ids=["state", "not-an-input", "wrong-length", "nan", "missing-known-input"],
)
def test_known_trajectories(model, trajectories, pattern):
    with pytest.raises(ProblemDefinitionError, match=pattern):
        make(model, known_trajectories=trajectories)


def test_known_trajectory_of_a_controlled_input_makes_it_data(model):
    problem = make(model, known_trajectories={f: np.zeros(5), r: np.ones(5)})
    assert problem.layout.node_names == ["q", "u"]


# --------------------------------------------------------------------------- parameters
@pytest.mark.parametrize(
    ("overrides", "pattern"),
    [
        (
            {"known_parameters": {m: 1.0, c: 0.1, k: 2.0, sm.Symbol("zz"): 1.0}},
            r"known_parameters: zz is not a parameter of the model \(parameters: \['c', 'k', 'm'\]\)",
        ),
        (
            {"known_parameters": {m: "heavy", c: 0.1, k: 2.0}},
            r"known_parameters\[m\]: expected a number, found 'heavy'",
        ),
        (
            {"known_parameters": {m: 1.0, c: np.inf, k: 2.0}},
            r"known_parameters\[c\]: expected a finite number, found inf",
        ),
        (
            {"known_parameters": {m: 1.0, c: 0.1}, "unknown_parameters": [k, sm.Symbol("zz")]},
            r"unknown_parameters: \['zz'\] are not parameters of the model",
        ),
        (
            {"known_parameters": {m: 1.0, c: 0.1, k: 2.0}, "unknown_parameters": [k]},
            r"unknown_parameters: \['k'\] are also given in known_parameters",
        ),
        (
            {"known_parameters": {m: 1.0}, "unknown_parameters": [k]},
            r"parameters \['c'\] are neither known nor unknown; give a value in known_parameters",
        ),
    ],
    ids=["not-a-parameter", "not-a-number", "not-finite", "unknown-stray", "both", "neither"],
)
def test_parameters(model, overrides, pattern):
    with pytest.raises(ProblemDefinitionError, match=pattern):
        make(model, **overrides)


def test_parameters_without_values_default_to_unknown(model):
    problem = make(model, known_parameters={m: 1.0})
    assert problem.layout.parameter_names == ["c", "k"]


# --------------------------------------------------------------------------- bounds
@pytest.mark.parametrize(
    ("bounds", "pattern"),
    [
        ({k: (0.0, 1.0)}, r"bounds: k is not a free quantity \(free: \['q', 'u', 'r'\]\)"),
        ({f: (0.0, 1.0)}, r"bounds: f is not a free quantity"),
        ({q: (1.0,)}, r"bounds\[q\]: expected a pair \(lower, upper\), found \(1.0,\)"),
        ({q: "ab"}, r"bounds\[q\]: expected a pair \(lower, upper\), found 'ab'"),
        ({q: (2.0, 1.0)}, r"bounds\[q\]: lower 2.0 is above upper 1.0"),
    ],
    ids=["known-parameter", "known-input", "single-value", "text", "crossed"],
)
def test_bounds(model, bounds, pattern):
    with pytest.raises(ProblemDefinitionError, match=pattern):
        make(model, bounds=bounds)


def test_bounds_reach_the_free_vector(model):
    problem = make(
        model,
        scheme=HermiteSimpson(),
        known_parameters={m: 1.0, c: 0.1},
        bounds={q: (-1.0, 2.0), k: (0.5, 3.0)},
    )
    lo, hi = problem.variable_bounds()
    lay = problem.layout
    assert np.all(lo[lay.node_indices("q")] == -1.0) and np.all(hi[lay.node_indices("q")] == 2.0)
    assert lo[lay.variable_index("k")] == 0.5 and hi[lay.variable_index("k")] == 3.0
    mid = lay.interval_matrix(lo)[:, lay.interval_names.index("q_mid")]
    assert np.all(mid == -1.0)  # Hermite-Simpson midpoint states obey the state bounds
    assert np.all(lo[lay.node_indices("u")] <= -1e19)


# --------------------------------------------------------------------------- instance constraints
@pytest.mark.parametrize(
    ("constraint", "pattern"),
    [
        (q.func(0.3), r"instance_constraints\[1\]: time 0.3 of q\(0.3\) is not a node of the grid"),
        (f.func(0.0), r"instance_constraints\[1\]: f\(0.0\) is not a state or free input"),
        (sm.Function("w")(0.0), r"instance_constraints\[1\]: w\(0.0\) is not a state or free"),
        (q, r"instance_constraints\[1\]: q\(t\) must be evaluated at a numeric time"),
        (q.func(0.0) - sm.Symbol("zz"), r"symbols \['zz'\] are not parameters of the model"),
        ("q(0) - 1", r"instance_constraints\[1\]: expected a SymPy expression, found 'q\(0\) - 1'"),
    ],
    ids=["non-node-time", "known-input", "unknown-function", "symbolic-time", "stray", "text"],
)
def test_instance_constraints(model, constraint, pattern):
    with pytest.raises(ProblemDefinitionError, match=pattern):
        make(model, instance_constraints=[q.func(0.0), constraint])


def test_instance_constraint_rows_evaluate_at_their_nodes(model):
    problem = make(
        model,
        known_parameters={m: 1.0, c: 0.1},
        instance_constraints=[q.func(0.25) - 0.5, u.func(1.0) * k - r.func(0.0)],
    )
    lay = problem.layout
    rng = np.random.default_rng(0)
    z = rng.normal(size=lay.num_variables)
    X = lay.node_matrix(z)
    expected = [X[1, 0] - 0.5, X[4, 1] * z[lay.variable_index("k")] - X[0, 2]]
    np.testing.assert_allclose(problem.defects(z)[-2:], expected, rtol=1e-14)


# --------------------------------------------------------------------------- objective
@pytest.mark.parametrize(
    "objective",
    [[IntegralCost(r**2), 3], "r**2", 5],
    ids=["int-in-list", "text", "bare-int"],
)
def test_objective_terms_must_be_objective_objects(model, objective):
    # ProblemDefinitionError is a ValueError; a TypeError naming the argument is also fine
    with pytest.raises(
        (TypeError, ValueError), match=r"objective: expected Tracking, IntegralCost or TerminalCost"
    ):
        make(model, objective=objective)


@pytest.mark.parametrize(
    ("measurements", "pattern"),
    [
        (
            {dynamicsymbols("s"): np.zeros(5)},
            r"Tracking: s is not an output or input of the model \(outputs: \['q', 'u'\], inputs",
        ),
        (
            {q: np.zeros(4)},
            r"measurements of q: expected shape \(5,\) \(one per node\), found \(4,",
        ),
        ({q: np.full(5, np.nan)}, r"measurements of q: every sample is NaN"),
        (
            {q: np.array([0.0, 1.0, np.nan, np.inf, -np.inf])},
            r"measurements of q: 2 infinite value\(s\), first at sample 3; mark a missing "
            r"sample with NaN",
        ),
        ({"q": np.zeros(5)}, r"the key 'q' is a string: key measurements by the output .*q\(t\)"),
    ],
    ids=["not-an-output", "wrong-length", "all-nan", "infinite", "string-key"],
)
def test_tracking_against_the_problem(model, measurements, pattern):
    with pytest.raises(ProblemDefinitionError, match=pattern):
        make(model, objective=Tracking(measurements))


def test_tracking_arguments():
    with pytest.raises(ValueError, match=r"measurements: expected a non-empty mapping"):
        Tracking({})
    with pytest.raises(ValueError, match=r"measurements: expected a non-empty mapping .* list"):
        Tracking([np.zeros(3)])
    with pytest.raises(ValueError, match=r"weights: outputs \['u'\] have no measurements"):
        Tracking({q: np.zeros(3)}, weights={u: 2.0})
    with pytest.raises(
        ValueError, match=r"weights: expected non-negative finite numbers.*'q: -1.0'"
    ):
        Tracking({q: np.zeros(3)}, weights=-1.0)
    # a NaN weight is not 'negative', and an infinite one is refused too (issue 32 item 15)
    with pytest.raises(
        ValueError, match=r"weights: expected non-negative finite numbers.*'q: nan'"
    ):
        Tracking({q: np.zeros(3)}, weights=float("nan"))
    with pytest.raises(ValueError, match=r"weights: expected finite numbers, found infinite"):
        Tracking({q: np.zeros(3)}, weights=float("inf"))
    with pytest.raises(ValueError, match=r"measurements: expected numbers at the nodes .*q \(str"):
        Tracking({q: "0.1, 0.2"})


def test_known_trajectories_keyed_by_a_string_or_not_numbers_are_named(model):
    with pytest.raises(ProblemDefinitionError, match=r"the key 'f' is a string: key each"):
        make(model, known_trajectories={"f": np.zeros(5)})
    with pytest.raises(ProblemDefinitionError, match=r"known_trajectories\[f\]: expected numbers"):
        make(model, known_trajectories={f: "zeros"})


def test_cost_terms_need_sympy_expressions():
    with pytest.raises(TypeError, match=r"integrand: expected a SymPy expression, found 'r\*\*2'"):
        IntegralCost("r**2")
    with pytest.raises(TypeError, match=r"expr: expected a SymPy expression, found 1.0"):
        TerminalCost(1.0)


def test_tracking_leaves_out_missing_samples(model):
    """NaN samples carry zero weight: the objective equals the sum over the others."""
    measured = np.array([0.1, np.nan, 0.3, np.nan, 0.5])
    problem = make(model, objective=Tracking({q: measured}, weights=2.0))
    z = np.random.default_rng(1).normal(size=problem.layout.num_variables)
    qz = problem.layout.node_matrix(z)[:, 0]
    ok = ~np.isnan(measured)
    assert problem.nlp.objective(z) == pytest.approx(2.0 * np.sum((qz[ok] - measured[ok]) ** 2))


# --------------------------------------------------------------------------- all at once
def test_every_problem_is_reported_at_once(model):
    with pytest.raises(ProblemDefinitionError, match=r"has 3 problem\(s\)") as info:
        make(
            model,
            known_trajectories={f: np.zeros(4)},
            known_parameters={m: 1.0, c: 0.1, k: 2.0, sm.Symbol("zz"): 1.0},
            bounds={q: (2.0, 1.0)},
        )
    text = str(info.value)
    assert "known_trajectories[f]: expected shape (5,)" in text
    assert "known_parameters: zz is not a parameter" in text
    assert "bounds[q]: lower 2.0 is above upper 1.0" in text
    assert len(info.value.problems) == 3


# --------------------------------------------------------------------------- guesses and solve
@pytest.fixture(scope="module")
def problem(model):
    return make(model)


def test_initial_guess_shape(problem):
    with pytest.raises(ValueError, match=r"initial_guess: expected shape \(15,\), found \(14,\)"):
        problem.solve(np.zeros(14))


def test_initial_guess_finite(problem):
    z = np.zeros(15)
    z[4] = np.nan
    with pytest.raises(ValueError, match=r"initial_guess: expected finite values, .*u at node 1"):
        problem.solve(z)


def test_hessian_option(problem):
    with pytest.raises(
        ValueError, match=r"hessian: expected one of \('exact', 'limited-memory', 'gauss-newton'\)"
    ):
        problem.solve(np.zeros(15), hessian="bfgs")


def test_refused_ipopt_option_names_it(problem):
    with pytest.raises(ValueError, match=r"ipopt option no_such_option=3 was refused"):
        problem.solve(np.zeros(15), no_such_option=3)


def test_initial_guess_builder_rejects_unknown_names(problem):
    with pytest.raises(KeyError, match=r"node_values: 'f' is not a node variable"):
        problem.initial_guess({f: np.zeros(5)})
    with pytest.raises(ValueError, match=r"values of q: expected shape \(5,\), found \(3,\)"):
        problem.initial_guess({q: np.zeros(3)})
    with pytest.raises(KeyError, match=r"name: 'k' is not an unknown parameter"):
        problem.initial_guess(parameters={k: 1.0})


def test_initial_guess_fills_derivative_and_midpoint_variables(model):
    problem = make(
        model,
        scheme=HermiteSimpson(),
        times=np.linspace(0.0, 1.0, 41),
        known_trajectories={f: np.zeros(41)},
    )
    times = problem.grid.times
    z = problem.initial_guess({q: np.sin(times), u: np.cos(times)})
    lay = problem.layout
    X, M = lay.node_matrix(z), lay.interval_matrix(z)
    qdot = X[:, lay.node_names.index("q'")]
    np.testing.assert_allclose(qdot[1:-1], np.cos(times[1:-1]), atol=1.5e-4)  # error h^2/6
    np.testing.assert_allclose(qdot, np.cos(times), atol=2e-2)
    mid = 0.5 * (times[:-1] + times[1:])
    np.testing.assert_allclose(M[:, lay.interval_names.index("q_mid")], np.sin(mid), atol=1e-6)


def test_objective_with_a_state_derivative_is_not_silently_zero(model):
    """Midpoint has no derivative variables: q'(t) in a cost must be refused, not read as 0."""
    with pytest.raises((TypeError, ValueError), match=r"(?i)derivative"):
        make(model, objective=IntegralCost(q.diff(t) ** 2))


def test_objective_with_a_state_derivative_uses_the_derivative_variables(model):
    """Hermite-Simpson carries q' at every node: the cost integrates those values."""
    problem = make(model, scheme=HermiteSimpson(), objective=IntegralCost(q.diff(t) ** 2))
    lay = problem.layout
    z = np.random.default_rng(2).normal(size=lay.num_variables)
    qdot = lay.node_matrix(z)[:, lay.node_names.index("q'")]
    expected = np.sum(0.5 * np.diff(TIMES) * (qdot[:-1] ** 2 + qdot[1:] ** 2))
    assert problem.nlp.objective(z) == pytest.approx(expected, rel=1e-12)


def test_objective_with_a_stray_symbol_names_it(model):
    with pytest.raises((TypeError, ValueError), match=r"\['zz'\]"):
        make(model, objective=IntegralCost(r**2 + sm.Symbol("zz")))


def test_replace_data_with_new_known_parameters_matches_a_fresh_build():
    import colloc

    """Changing known constants re-solves without a rebuild and equals a new Problem."""
    t = dynamicsymbols._t
    q, u = dynamicsymbols("q u")
    m, c, k = sm.symbols("m c k")
    model = colloc.Model.from_equations([q.diff(t) - u, m * u.diff(t) + c * u + k * q], [q, u])
    times = np.linspace(0.0, 1.0, 11)
    first = colloc.Problem(model, times, known_parameters={m: 1.0, c: 0.2, k: 3.0}, cache=False)
    z = np.random.default_rng(3).normal(size=first.layout.num_variables)
    first.replace_data(known_parameters={m: 2.0, c: 0.5, k: 7.0})
    fresh = colloc.Problem(model, times, known_parameters={m: 2.0, c: 0.5, k: 7.0}, cache=False)
    np.testing.assert_allclose(first.defects(z), fresh.defects(z), rtol=0, atol=1e-12)
    with pytest.raises(colloc.ProblemDefinitionError, match="neither known nor unknown"):
        first.replace_data(known_parameters={m: 2.0, c: 0.5})
