"""Validation of a model definition that collects every problem before raising."""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping

import sympy as sm
from sympy.core.function import AppliedUndef

from colloc.model.symbols import (
    constants_in,
    derivatives_in,
    functions_of_time,
    is_function_of_time,
    name_of,
)


def validate_model(
    residual: sm.Matrix,
    states: tuple[sm.Basic, ...],
    controlled: tuple[sm.Basic, ...],
    known: tuple[sm.Basic, ...],
    unknown: tuple[sm.Basic, ...],
    outputs: Mapping[sm.Basic, sm.Expr],
    parameters: tuple[sm.Basic, ...] | None,
    t: sm.Symbol,
) -> tuple[list[str], set[sm.Symbol]]:
    """Check a model definition.

    Parameters
    ----------
    residual, states, controlled, known, unknown, outputs, parameters, t
        The pieces of a :class:`colloc.Model` definition.

    Returns
    -------
    problems : list of str
        Every problem found (empty when the definition is sound).
    constants : set of sympy.Symbol
        The constants found in the residual (the parameters when none are given).
    """
    problems: list[str] = []
    groups = {
        "states": states,
        "controlled_inputs": controlled,
        "known_inputs": known,
        "unknown_inputs": unknown,
    }
    for label, items in groups.items():
        bad = [str(s) for s in items if not is_function_of_time(s, t)]
        if bad:
            problems.append(
                f"{label}: expected functions of time such as q(t) (e.g. from "
                f"dynamicsymbols), found {bad}"
            )
        dup = [name_of(s) for s, c in Counter(items).items() if c > 1]
        if dup:
            problems.append(f"{label}: listed more than once: {dup}")
    seen: dict[sm.Basic, str] = {}
    for label, items in groups.items():
        for s in items:
            if s in seen and seen[s] != label:
                problems.append(f"{name_of(s)} is declared both in {seen[s]} and in {label}")
            seen.setdefault(s, label)

    if residual.shape[0] == 0:
        problems.append("residual: expected at least one equation, found none")
    if len(states) != residual.shape[0]:
        problems.append(
            f"residual has {residual.shape[0]} equation(s) but there are {len(states)} state(s); "
            "expected one equation per state"
        )

    other_time = sorted({str(f) for f in residual.atoms(AppliedUndef) if f.args != (t,)})
    if other_time:
        problems.append(
            f"functions {other_time} are not functions of the model's time symbol "
            f"{name_of(t)}: pass the symbol they use as t= (from_equations, from_kane, "
            "from_lagrange), or build them with dynamicsymbols"
        )
    declared = set(seen)
    in_residual = functions_of_time(residual, t)
    undeclared = in_residual - declared
    if undeclared:
        problems.append(
            "unknown functions of time in the residual (declare each as a state or an input): "
            f"{sorted(name_of(f) for f in undeclared)}"
        )
    absent = [name_of(w) for w in unknown if w in declared and w not in in_residual]
    if absent:
        problems.append(
            f"unknown_inputs: {absent} appear in no equation, so nothing could determine them "
            "(a typo, or another function of the same name?)"
        )
    for d in derivatives_in(residual):
        base, order = d.expr, sum(c for _, c in d.variable_count)
        if base not in states:
            problems.append(
                f"the residual differentiates {name_of(base)}, which is not a state; "
                "only state derivatives x'(t) may appear (an input that enters through its "
                "derivative is declared by input_derivatives={v: a})"
            )
        elif order > 1:
            problems.append(
                f"the residual holds a derivative of order {order} of {name_of(base)}; "
                "write the model in first-order form (add a speed state)"
            )
    if states and not any(d.expr in states for d in derivatives_in(residual)):
        problems.append("the residual contains no state derivative x'(t); nothing evolves")

    constants = constants_in(residual, t)
    names_of_functions = {name_of(f) for f in declared | in_residual}
    clashes = sorted(str(c) for c in constants if str(c) in names_of_functions)
    if clashes:
        problems.append(
            f"symbol(s) {clashes} are used both as a constant and as a function of time "
            "(state or input) of the same name"
        )
    if parameters is not None:
        bad_params = [str(p) for p in parameters if not isinstance(p, sm.Symbol) or p == t]
        if bad_params:
            problems.append(f"parameters: expected constant sympy Symbols, found {bad_params}")
        as_state = sorted(str(p) for p in parameters if p in declared)
        if as_state:
            problems.append(f"parameters: {as_state} are also states or inputs")
        missing = constants - set(parameters)
        if missing:
            problems.append(
                "unknown symbols in the residual (not among the given parameters): "
                f"{sorted(str(m) for m in missing)}"
            )

    problems += output_problems(outputs, states, t, controlled + known + unknown)
    return problems, constants


def output_problems(
    outputs: Mapping[sm.Basic, sm.Expr],
    states: tuple[sm.Basic, ...],
    t: sm.Symbol,
    inputs: tuple[sm.Basic, ...] = (),
) -> list[str]:
    """Problems with measured outputs ``y = g(x, r, t)``."""
    problems: list[str] = []
    allowed = set(states) | set(inputs)
    for y, g in outputs.items():
        extra = functions_of_time(g, t) - allowed if isinstance(g, sm.Basic) else set()
        if not isinstance(g, sm.Basic):
            problems.append(f"output {name_of(y)}: expected a SymPy expression, found {g!r}")
        elif extra:
            problems.append(
                f"output {name_of(y)} depends on {sorted(name_of(e) for e in extra)}, "
                "which are neither states nor inputs; outputs are y = g(x, r, t)"
            )
        elif derivatives_in(g):
            problems.append(f"output {name_of(y)}: derivatives are not allowed in outputs")
    return problems
