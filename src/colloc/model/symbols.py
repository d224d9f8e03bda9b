"""Small helpers for classifying the SymPy objects a model is written in."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import sympy as sm
from sympy.core.function import AppliedUndef
from sympy.physics.mechanics import dynamicsymbols

#: The time symbol shared with :mod:`sympy.physics.mechanics`.
TIME: sm.Symbol = dynamicsymbols._t


def is_function_of_time(obj: Any, t: sm.Symbol = TIME) -> bool:
    """Return True when ``obj`` is an undefined function applied to ``t`` only, e.g. ``q(t)``."""
    return isinstance(obj, AppliedUndef) and obj.args == (t,)


def functions_of_time(expr: sm.Basic | Iterable[sm.Basic], t: sm.Symbol = TIME) -> set[sm.Basic]:
    """Every ``f(t)`` appearing in ``expr`` (derivatives included through their base function)."""
    exprs = [expr] if isinstance(expr, sm.Basic) else list(expr)
    found: set[sm.Basic] = set()
    for e in exprs:
        found |= {a for a in _basic(e).atoms(AppliedUndef) if a.args == (t,)}
    return found


def derivatives_in(expr: sm.Basic | Iterable[sm.Basic]) -> set[sm.Derivative]:
    """Every :class:`sympy.Derivative` appearing in ``expr``."""
    exprs = [expr] if isinstance(expr, sm.Basic) else list(expr)
    found: set[sm.Derivative] = set()
    for e in exprs:
        found |= set(_basic(e).atoms(sm.Derivative))
    return found


def constants_in(expr: sm.Basic | Iterable[sm.Basic], t: sm.Symbol = TIME) -> set[sm.Symbol]:
    """Free symbols of ``expr`` other than time."""
    exprs = [expr] if isinstance(expr, sm.Basic) else list(expr)
    found: set[sm.Symbol] = set()
    for e in exprs:
        found |= set(_basic(e).free_symbols)
    found.discard(t)
    return found


def name_of(obj: sm.Basic) -> str:
    """A readable name: ``q1`` for ``q1(t)``, the symbol name for a symbol."""
    if isinstance(obj, AppliedUndef):
        return str(obj.func)
    return str(obj)


def sort_by_name(objs: Iterable[sm.Basic]) -> tuple[sm.Basic, ...]:
    """Deterministic order (by name) for sets of symbols."""
    return tuple(sorted(objs, key=lambda s: (name_of(s), sm.srepr(s))))


def as_tuple(objs: sm.Basic | Sequence[sm.Basic] | sm.MatrixBase | None) -> tuple[sm.Basic, ...]:
    """Accept one object, a sequence or a column matrix; return a tuple."""
    if objs is None:
        return ()
    if isinstance(objs, sm.MatrixBase):
        return tuple(objs)
    if isinstance(objs, sm.Basic):
        return (objs,)
    return tuple(objs)


def _basic(e: Any) -> Any:
    # Plain numbers carry no symbols; SymPy objects and matrices answer atoms() themselves.
    return e if hasattr(e, "atoms") else sm.Integer(0)
