"""The layout: free-vector and constraint indices <-> meaning, both ways.

Round trips are checked on a bare layout and on built problems; the constraint
descriptions are checked against the Jacobian sparsity (a constraint said to belong to
interval k may only depend on nodes k and k+1, interval k and the parameters).
"""

from __future__ import annotations

import re

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc import Model, Problem
from colloc.nlp.layout import ConstraintBlock, Layout
from colloc.transcription import BackwardEuler, HermiteSimpson, Midpoint, Trapezoidal

t = dynamicsymbols._t
TIMES = np.array([0.0, 0.1, 0.25, 0.3, 0.5])


def bare_layout():
    lay = Layout(TIMES, ["q", "u", "T"], ["q_mid", "u_mid"], ["c", "k"])
    lay.add_block(ConstraintBlock("interval", 2, 4, "interval", ("dq", "du")))
    lay.add_block(ConstraintBlock("node", 1, 5, "node"))
    lay.add_block(ConstraintBlock("instance", 3, 1, "instance"))
    return lay


def test_sizes_and_offsets():
    lay = bare_layout()
    assert lay.num_nodes == 5
    assert lay.interval_offset == 15
    assert lay.parameter_offset == 15 + 4 * 2
    assert lay.num_variables == 25
    assert lay.num_constraints == 8 + 5 + 3
    assert [b.offset for b in lay.blocks] == [0, 8, 13]


def test_variable_round_trip():
    lay = bare_layout()
    node_pattern = re.compile(r"(\w+) at node (\d+) \(t = ([\d.e-]+)\)")
    interval_pattern = re.compile(r"(\w+) in interval (\d+) \[([\d.e-]+), ([\d.e-]+)\]")
    seen = set()
    for i in range(lay.num_variables):
        text = lay.describe_variable(i)
        if match := node_pattern.fullmatch(text):
            name, node = match.group(1), int(match.group(2))
            assert lay.variable_index(name, node) == i
            assert float(match.group(3)) == pytest.approx(TIMES[node])
            assert i in lay.node_indices(name)
        elif match := interval_pattern.fullmatch(text):
            name, k = match.group(1), int(match.group(2))
            assert lay.interval_offset + k * 2 + lay.interval_names.index(name) == i
            assert float(match.group(4)) == pytest.approx(TIMES[k + 1])
        else:
            name = text.removeprefix("parameter ")
            assert lay.variable_index(name) == i
        seen.add(text)
    assert len(seen) == lay.num_variables  # every entry has its own description


def test_constraint_descriptions():
    lay = bare_layout()
    assert lay.describe_constraint(0) == "interval: dq, interval 0 [0, 0.1]"
    assert lay.describe_constraint(7) == "interval: du, interval 3 [0.3, 0.5]"
    assert lay.describe_constraint(8) == "node: equation 0, node 0 (t = 0)"
    assert lay.describe_constraint(12) == "node: equation 0, node 4 (t = 0.5)"
    assert lay.describe_constraint(15) == "instance: equation 2, instance constraint"


def test_fill_and_views_round_trip():
    lay = bare_layout()
    rng = np.random.default_rng(0)
    q, T = rng.normal(size=5), rng.normal(size=5)
    mid = rng.normal(size=4)
    z = lay.fill({"q": q, "T": T, "u": 2.0}, {"k": 3.5}, {"u_mid": mid}, default=-1.0)
    X, M = lay.node_matrix(z), lay.interval_matrix(z)
    np.testing.assert_array_equal(X[:, 0], q)
    np.testing.assert_array_equal(X[:, 1], 2.0)
    np.testing.assert_array_equal(X[:, 2], T)
    np.testing.assert_array_equal(M[:, 1], mid)
    np.testing.assert_array_equal(M[:, 0], -1.0)
    assert lay.parameters(z) == {"c": -1.0, "k": 3.5}
    np.testing.assert_array_equal(z[lay.node_indices("T")], T)
    X[2, 1] = 9.0  # the matrices are views of z
    assert z[lay.variable_index("u", 2)] == 9.0


@pytest.mark.parametrize(
    ("call", "error", "pattern"),
    [
        (lambda lay: lay.variable_index("zz"), KeyError, r"name: 'zz' is not an unknown parameter"),
        (lambda lay: lay.variable_index("zz", 0), KeyError, r"name: 'zz' is not a node variable"),
        (
            lambda lay: lay.variable_index("q", 5),
            IndexError,
            r"node: expected an index in \[0, 5\)",
        ),
        (lambda lay: lay.describe_variable(25), IndexError, r"i: expected an index in \[0, 25\)"),
        (lambda lay: lay.describe_variable(-1), IndexError, r"i: expected an index in \[0, 25\)"),
        (lambda lay: lay.describe_constraint(16), IndexError, r"j: expected an index in \[0, 16\)"),
        (lambda lay: lay.fill({"zz": 1.0}), KeyError, r"node_values: 'zz' is not a node variable"),
        (
            lambda lay: lay.fill(interval_values={"zz": 1.0}),
            KeyError,
            r"interval_values: 'zz' is not an interval variable",
        ),
        (
            lambda lay: lay.fill({"q": np.zeros(4)}),
            ValueError,
            r"values of q: expected shape \(5,\), found \(4,\)",
        ),
        (lambda lay: lay.fill(parameter_values={"q": 1.0}), KeyError, r"'q' is not an unknown"),
    ],
    ids=[
        "unknown-parameter",
        "unknown-node-variable",
        "node-out-of-range",
        "variable-too-large",
        "variable-negative",
        "constraint-too-large",
        "fill-node",
        "fill-interval",
        "fill-length",
        "fill-parameter",
    ],
)
def test_layout_errors(call, error, pattern):
    with pytest.raises(error, match=pattern):
        call(bare_layout())


# --------------------------------------------------------------------------- built problems
def built(scheme):
    q, u, T = dynamicsymbols("q u T")
    k, c = sm.symbols("k c")
    model = Model.from_equations(
        [q.diff(t) - u, 2 * u.diff(t) + c * u + k * sm.sin(q) - T], [q, u], controlled_inputs=[T]
    )
    return Problem(
        model,
        TIMES,
        scheme=scheme,
        known_parameters={c: 0.2},
        instance_constraints=[q.func(0.0) - 1.0, u.func(0.5) * k],
        cache=False,
    )


@pytest.mark.parametrize(
    "scheme", [BackwardEuler(), Midpoint(), Trapezoidal(), HermiteSimpson()], ids=lambda s: s.name
)
def test_constraint_descriptions_agree_with_jacobian_sparsity(scheme):
    problem = built(scheme)
    lay, nlp = problem.layout, problem.nlp
    assert lay.num_variables == nlp.n and lay.num_constraints == nlp.m
    rows, cols = nlp.jacobianstructure()
    for j in range(nlp.m):
        text = lay.describe_constraint(j)
        assert scheme.name in text or text.startswith("instance")
        columns = cols[rows == j]
        assert columns.size > 0
        where = [lay.describe_variable(int(i)) for i in columns]
        if match := re.search(r"interval (\d+) \[", text):
            k = int(match.group(1))
            allowed = (f"at node {k} ", f"at node {k + 1} ", f"in interval {k} ", "parameter k")
        elif match := re.search(r"node (\d+) \(", text):
            k = int(match.group(1))
            allowed = (f"at node {k} ", "parameter k")
        else:
            allowed = ("q at node 0 ", "u at node 4 ", "parameter k")
        assert all(any(a in w for a in allowed) for w in where), (text, where)


@pytest.mark.parametrize(
    ("scheme", "node_names", "interval_names"),
    [
        (Midpoint(), ["q", "u", "T"], []),
        (Trapezoidal(), ["q", "u", "T", "q'", "u'"], []),
        (HermiteSimpson(), ["q", "u", "T", "q'", "u'"], ["q_mid", "u_mid", "q'_mid", "u'_mid"]),
    ],
    ids=["Midpoint", "Trapezoidal", "HermiteSimpson"],
)
def test_problem_layout_names(scheme, node_names, interval_names):
    lay = built(scheme).layout
    assert lay.node_names == node_names
    assert lay.interval_names == interval_names
    assert lay.parameter_names == ["k"]
    assert lay.num_variables == 5 * len(node_names) + 4 * len(interval_names) + 1


def test_describe_variable_of_a_built_problem():
    problem = built(HermiteSimpson())
    lay = problem.layout
    i = lay.variable_index("u", 3)
    assert lay.describe_variable(i) == "u at node 3 (t = 0.3)"
    assert (
        lay.describe_variable(lay.interval_offset + 4 * 2 + 1) == "u_mid in interval 2 [0.25, 0.3]"
    )
    assert lay.describe_variable(lay.num_variables - 1) == "parameter k"
    assert problem.layout.describe_constraint(lay.num_constraints - 1) == (
        "instance: equation 1, instance constraint"
    )
