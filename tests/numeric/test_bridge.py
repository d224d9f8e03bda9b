"""The SymPy -> CasADi bridge against SymPy's own arbitrary-precision evaluation."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc.numeric import UnsupportedExpressionError, sympy_to_casadi

a, b, cc = sm.symbols("a b c")
q = dynamicsymbols("q")
t = dynamicsymbols._t

EXPRESSIONS = [
    sm.sin(a) * sm.cos(b) + sm.tan(a / 3),
    sm.asin(a / 2) + sm.acos(b / 3) + sm.atan(cc),
    sm.atan2(a, b) - sm.atan2(-b, cc),
    sm.sinh(a) + sm.cosh(b) * sm.tanh(cc),
    sm.exp(-(a**2)) + sm.log(1 + b**2),
    sm.Abs(a - b) + sm.sign(cc - a),
    sm.Max(a, b) - sm.Min(b, cc) + sm.Max(a, b, cc) + sm.Min(a, b, cc),
    sm.erf(a * b),
    sm.sqrt(1 + a**2) + (2 + b**2) ** sm.Rational(3, 2) + (3 + cc**2) ** -sm.Rational(1, 3),
    a**3 - 2 / b**2 + (1 + cc**2) ** 0.75 + (2 + a**2) ** (b / 4),
    sm.pi * a + sm.E * b - sm.Rational(7, 3) * cc + sm.Float(1e-3) * a * b * cc,
    sm.cos(q) * q.diff(t) + t**2,
]


def evaluate(expr, values):
    leaves = {s: ca.SX.sym(str(s)) for s in (a, b, cc, q, q.diff(t), t)}
    (sx,) = sympy_to_casadi([expr], leaves)
    syms = list(leaves.values())
    fn = ca.Function("f", syms, [sx])
    return float(fn(*[values[s] for s in leaves]))


@pytest.mark.parametrize("expr", EXPRESSIONS, ids=range(len(EXPRESSIONS)))
def test_values_match_sympy_evalf(expr):
    rng = np.random.default_rng(7)
    for _ in range(4):
        values = dict(
            zip((a, b, cc, q, q.diff(t), t), rng.uniform(-0.9, 0.9, 6).tolist(), strict=True)
        )
        values[b] = values[b] + 1.5  # keeps 2/b**2 away from the pole
        reference = float(expr.xreplace({k: sm.Float(v, 30) for k, v in values.items()}).evalf(30))
        assert evaluate(expr, values) == pytest.approx(reference, rel=1e-13, abs=1e-13)


def test_matrix_of_expressions_keeps_order():
    leaves = {a: ca.SX.sym("a"), b: ca.SX.sym("b")}
    exprs = [a + b, a * b, a - b]
    out = sympy_to_casadi(exprs, leaves)
    fn = ca.Function("f", [leaves[a], leaves[b]], [ca.vertcat(*out)])
    np.testing.assert_allclose(np.array(fn(2.0, 5.0)).ravel(), [7.0, 10.0, -3.0])


def test_shared_subexpressions_stay_shared():
    """A subexpression used many times becomes one SX node, not many copies."""
    x = ca.SX.sym("x")
    inner = sm.exp(sm.sin(a) ** 2 + sm.cos(a) ** 3)  # a product, so SymPy does not distribute
    exprs = [inner * k for k in range(1, 30)]
    out = sympy_to_casadi(exprs, {a: x})
    fn = ca.Function("f", [x], [ca.vertcat(*out)])
    single = ca.Function("g", [x], [sympy_to_casadi([inner], {a: x})[0]])
    # per output a constant, a product and an output on top of one copy of the inner
    # expression; copies would add at least 6 instructions each
    assert fn.n_instructions() <= single.n_instructions() + 3 * 29
    np.testing.assert_allclose(
        np.array(fn(0.3)).ravel(),
        [math.exp(math.sin(0.3) ** 2 + math.cos(0.3) ** 3) * k for k in range(1, 30)],
    )


def test_deep_expression_does_not_hit_the_recursion_limit():
    depth = 3000  # three times Python's default recursion limit
    expr = a
    for _ in range(depth):
        # unevaluated, hashed level by level: SymPy itself recurses when evaluating
        expr = sm.sin(expr, evaluate=False)
        hash(expr)
    x = ca.SX.sym("x")
    (sx,) = sympy_to_casadi([expr], {a: x})
    value = 0.5
    for _ in range(depth):
        value = math.sin(value)
    assert float(ca.Function("f", [x], [sx])(0.5)) == pytest.approx(value, rel=1e-12)


def test_unsupported_function_is_named():
    x = ca.SX.sym("x")
    with pytest.raises(
        UnsupportedExpressionError, match=r"unsupported SymPy functions: \['besselj', 'floor'\]"
    ):
        sympy_to_casadi([sm.floor(a) + sm.besselj(1, a)], {a: x})


def test_unbound_symbols_are_named_with_unsupported_functions():
    x = ca.SX.sym("x")
    with pytest.raises(
        UnsupportedExpressionError, match=r"no numeric counterpart: \['b'\]"
    ) as info:
        sympy_to_casadi([a + b, sm.floor(a)], {a: x})
    assert "floor" in str(info.value)
    assert isinstance(info.value, TypeError)


def test_unbound_derivative_is_named():
    with pytest.raises(UnsupportedExpressionError, match=r"Derivative\(q\(t\), t\)"):
        sympy_to_casadi([q.diff(t) + q], {q: ca.SX.sym("q")})
