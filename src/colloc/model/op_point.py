"""Operating points and other user mappings keyed by SymPy objects or by their names.

Keys may be the SymPy objects themselves (``q1``, ``q1.diff(t)``, a constant ``g``) or
their names. Names follow one rule: a function of time ``q1(t)`` is ``"q1"``, its first
derivative ``"q1_dot"``, its second ``"q1_ddot"`` (one more ``d`` per order), and a
constant symbol is its own name.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import sympy as sm

from colloc.model.errors import ModelError
from colloc.model.symbols import name_of

__all__ = ["OperatingPointError", "resolve_mapping", "resolve_sequence", "variable_name"]


class OperatingPointError(ModelError):
    """An operating point, a split of the variables or a substitution is not usable.

    Every problem found is listed at once (see :class:`colloc.model.errors.ModelError`).
    """

    def __init__(self, problems: Iterable[str]) -> None:
        super().__init__(problems, what="linearization input")


def variable_name(var: sm.Basic) -> str:
    """Name of ``var`` as accepted in operating points: ``q1``, ``q1_dot``, ``q1_ddot``, ``g``."""
    if isinstance(var, sm.Derivative):
        order = var.derivative_count
        return f"{name_of(var.expr)}_{'d' * (order - 1)}dot"
    return name_of(var)


def _as_value(value: Any) -> sm.Expr | None:
    # Strings are refused rather than parsed: no user text is ever evaluated.
    if isinstance(value, str | bool | np.bool_):
        return None
    try:
        return sm.sympify(value, strict=True)
    except (sm.SympifyError, TypeError):
        return None


def _lookup(
    allowed: Sequence[sm.Basic], argument: str
) -> tuple[dict[str, sm.Basic], set[sm.Basic], list[str]]:
    by_name: dict[str, sm.Basic] = {}
    problems: list[str] = []
    for var in allowed:
        name = variable_name(var)
        if name in by_name and by_name[name] != var:
            problems.append(f"{argument}: two variables share the name {name!r}; use the objects")
        by_name[name] = var
    return by_name, set(allowed), problems


def resolve_sequence(
    items: Sequence[Any] | sm.MatrixBase | None,
    allowed: Sequence[sm.Basic],
    argument: str,
    problems: list[str],
) -> tuple[sm.Basic, ...] | None:
    """Turn a sequence of objects or names into the objects, appending problems found.

    Parameters
    ----------
    items : sequence or None
        Objects or names; ``None`` passes through.
    allowed : sequence of sympy.Basic
        What the items may be.
    argument : str
        The argument name used in messages.
    problems : list of str
        Problems are appended here, so callers can report all of them at once.

    Returns
    -------
    tuple or None
    """
    if items is None:
        return None
    seq = list(items) if not isinstance(items, sm.Basic) else [items]
    by_name, allowed_set, own = _lookup(allowed, argument)
    problems.extend(own)
    out: list[sm.Basic] = []
    unknown: list[str] = []
    for item in seq:
        var = by_name.get(item) if isinstance(item, str) else item
        if var is None or var not in allowed_set:
            unknown.append(str(item))
        elif var in out:
            problems.append(f"{argument}: {variable_name(var)} is listed more than once")
        else:
            out.append(var)
    if unknown:
        problems.append(
            f"{argument}: expected entries from {[variable_name(v) for v in allowed]}, "
            f"found unknown {unknown}"
        )
    return tuple(out)


def resolve_mapping(
    mapping: Mapping[Any, Any] | None,
    allowed: Sequence[sm.Basic],
    argument: str,
    problems: list[str],
    *,
    required: Sequence[sm.Basic] = (),
) -> dict[sm.Basic, sm.Expr]:
    """Turn a mapping keyed by objects or names into ``{object: sympy value}``.

    Parameters
    ----------
    mapping : mapping or None
        Keys are objects from ``allowed`` or their names (see :func:`variable_name`);
        values are numbers or SymPy expressions (strings are refused, never parsed).
    allowed : sequence of sympy.Basic
        Keys that may appear.
    argument : str
        The argument name used in messages.
    problems : list of str
        Every missing, extra, repeated key or bad value is appended here.
    required : sequence of sympy.Basic
        Keys that must appear.

    Returns
    -------
    dict
    """
    if mapping is None:
        mapping = {}
    if not isinstance(mapping, Mapping):
        problems.append(f"{argument}: expected a dict, found {type(mapping).__name__}")
        return {}
    by_name, allowed_set, own = _lookup(allowed, argument)
    problems.extend(own)
    out: dict[sm.Basic, sm.Expr] = {}
    extra: list[str] = []
    for key, value in mapping.items():
        var = by_name.get(key) if isinstance(key, str) else key
        if var is None or var not in allowed_set:
            extra.append(variable_name(key) if isinstance(key, sm.Basic) else str(key))
            continue
        if var in out:
            problems.append(f"{argument}: {variable_name(var)} is given twice (object and name)")
            continue
        converted = _as_value(value)
        if converted is None:
            out[var] = sm.nan  # given, so not reported missing as well
            problems.append(
                f"{argument}: value of {variable_name(var)} must be a number or a SymPy "
                f"expression, found {type(value).__name__} {value!r}"
            )
            continue
        out[var] = converted
    missing = [variable_name(v) for v in required if v not in out]
    if missing:
        problems.append(f"{argument}: missing entries for {missing}")
    if extra:
        problems.append(
            f"{argument}: unexpected entries {extra}; allowed are "
            f"{[variable_name(v) for v in allowed]}"
        )
    return out
