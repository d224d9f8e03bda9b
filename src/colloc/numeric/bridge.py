"""Translate SymPy expressions into CasADi SX expressions.

The translation walks each expression tree once, memoising every node, so a subexpression
that SymPy shares (as in equations from Kane's method) becomes one shared SX node.
Text is never evaluated: only the node types listed here are understood, and anything else
is reported by name.
"""

from __future__ import annotations

import functools
import operator
from collections.abc import Callable, Iterable, Mapping

import casadi as ca
import sympy as sm

_FUNCTIONS: dict[type, Callable[..., ca.SX]] = {
    sm.sin: ca.sin,
    sm.cos: ca.cos,
    sm.tan: ca.tan,
    sm.asin: ca.asin,
    sm.acos: ca.acos,
    sm.atan: ca.atan,
    sm.atan2: ca.atan2,
    sm.sinh: ca.sinh,
    sm.cosh: ca.cosh,
    sm.tanh: ca.tanh,
    sm.exp: ca.exp,
    sm.log: ca.log,
    sm.Abs: ca.fabs,
    sm.sign: ca.sign,
    sm.Max: ca.fmax,
    sm.Min: ca.fmin,
    sm.erf: ca.erf,
}


class UnsupportedExpressionError(TypeError):
    """A SymPy construct has no CasADi counterpart in the bridge."""


def sympy_to_casadi(exprs: Iterable[sm.Basic], leaves: Mapping[sm.Basic, ca.SX]) -> list[ca.SX]:
    """Convert SymPy expressions to CasADi SX.

    Parameters
    ----------
    exprs : iterable of sympy.Basic
        Scalar expressions.
    leaves : mapping
        Every symbol, function of time and derivative in ``exprs`` -> its SX scalar.

    Returns
    -------
    list of casadi.SX
        One scalar SX per expression.

    Raises
    ------
    UnsupportedExpressionError
        Naming the SymPy node types that cannot be converted and any unbound leaves.
    """
    memo: dict[sm.Basic, ca.SX] = dict(leaves)
    unbound: set[str] = set()
    unsupported: set[str] = set()

    def convert(e: sm.Basic) -> ca.SX:
        # An explicit stack avoids Python's recursion limit on deep expressions.
        stack: list[tuple[sm.Basic, bool]] = [(e, False)]
        while stack:
            node, expanded = stack.pop()
            if node in memo:
                continue
            if node.is_Number or node in (sm.pi, sm.E):
                memo[node] = ca.SX(float(node))
                continue
            if not node.args or isinstance(node, sm.Derivative):
                unbound.add(str(node))
                memo[node] = ca.SX(float("nan"))
                continue
            if not expanded:
                stack.append((node, True))
                stack.extend((a, False) for a in node.args if a not in memo)
                continue
            memo[node] = _combine(node, [memo[a] for a in node.args], unsupported)
        return memo[e]

    out = [convert(e) for e in exprs]
    if unbound or unsupported:
        parts = []
        if unbound:
            parts.append(f"symbols with no numeric counterpart: {sorted(unbound)}")
        if unsupported:
            parts.append(f"unsupported SymPy functions: {sorted(unsupported)}")
        raise UnsupportedExpressionError("cannot translate to CasADi: " + "; ".join(parts))
    return out


def _combine(node: sm.Basic, args: list[ca.SX], unsupported: set[str]) -> ca.SX:
    if isinstance(node, sm.Add):
        return functools.reduce(operator.add, args)
    if isinstance(node, sm.Mul):
        return functools.reduce(operator.mul, args)
    if isinstance(node, sm.Pow):
        base, exponent = args
        exp_value = node.args[1]
        if exp_value == sm.S.Half:
            return ca.sqrt(base)
        if exp_value.is_Integer:
            return base ** int(exp_value)
        return base**exponent
    func = _FUNCTIONS.get(type(node)) or _FUNCTIONS.get(node.func)  # type: ignore[call-overload]
    if func is None:
        unsupported.add(type(node).__name__)
        return ca.SX(float("nan"))
    return func(*args) if len(args) <= 2 else functools.reduce(func, args)
