"""Validation of what a user hands to :class:`colloc.Problem`, all problems at once."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import sympy as sm
from sympy.core.function import AppliedUndef

from colloc.model.model import Model
from colloc.model.symbols import name_of
from colloc.nlp.known import KnownTrajectory
from colloc.nlp.objective import ObjectiveTerm
from colloc.numeric.real import real_array
from colloc.transcription.interpolation import CubicInterpolation, Interpolation

Bounds = Mapping[sm.Basic, tuple[float, float]]


def check_trajectories(
    model: Model,
    known: Mapping[sm.Basic, Any],
    num_nodes: int,
    problems: list[str],
    measured: Sequence[sm.Basic] = (),
    interpolations: dict[sm.Basic, Interpolation] | None = None,
) -> dict[sm.Basic, np.ndarray]:
    """Known input trajectories: each an input of the model, one finite value per node
    (a known input of the model may instead be ``measured``: a free trajectory tracked).

    Entries may be :class:`KnownTrajectory`; the rule of each between the nodes is written
    into ``interpolations`` when given (cubic for plain arrays).
    """
    out: dict[sm.Basic, np.ndarray] = {}
    for r, entry in known.items():
        values = entry.values if isinstance(entry, KnownTrajectory) else entry
        if interpolations is not None:
            interpolations[r] = (
                entry.between if isinstance(entry, KnownTrajectory) else CubicInterpolation()
            )
        if isinstance(r, str):
            problems.append(
                f"known_trajectories: the key {r!r} is a string: key each trajectory by the "
                f"input itself, e.g. {r}(t) (inputs: {[name_of(i) for i in model.inputs]})"
            )
            continue
        if r not in model.inputs:
            where = "a state" if r in model.states else "not an input of the model"
            problems.append(
                f"known_trajectories: {name_of(r)} is {where} (inputs: "
                f"{[name_of(i) for i in model.inputs]})"
            )
            continue
        try:
            arr = real_array(values)
        except (TypeError, ValueError) as error:
            problems.append(
                f"known_trajectories[{name_of(r)}]: expected numbers at the nodes, found "
                f"{type(values).__name__} {str(values)[:40]!r} ({error})"
            )
            continue
        if arr.shape != (num_nodes,):
            problems.append(
                f"known_trajectories[{name_of(r)}]: expected shape ({num_nodes},) (one value per "
                f"node), found {arr.shape}"
            )
        elif not np.all(np.isfinite(arr)):
            problems.append(
                f"known_trajectories[{name_of(r)}]: expected finite values, found NaN/inf"
            )
        else:
            out[r] = arr
    missing = [name_of(r) for r in model.known_inputs if r not in known and r not in measured]
    if missing:
        problems.append(
            f"known_trajectories: the model's known inputs {missing} have no trajectory; "
            "give one per node, give them as measured_inputs, or declare them unknown_inputs "
            "of the model"
        )
    return out


def check_parameters(
    model: Model,
    known: Mapping[sm.Symbol, Any],
    unknown: Sequence[sm.Symbol] | None,
    problems: list[str],
) -> tuple[dict[sm.Symbol, float], tuple[sm.Symbol, ...]]:
    """Known values and the unknown parameters; every model parameter must be one of them."""
    values: dict[sm.Symbol, float] = {}
    # Sets, not the tuples: a gain schedule has tens of thousands of parameters.
    parameters = set(model.parameters)
    for p, v in known.items():
        if p not in parameters:
            problems.append(
                f"known_parameters: {name_of(p)} is not a parameter of the model "
                f"(parameters: {[name_of(q) for q in model.parameters]})"
            )
            continue
        try:
            fv = float(v)
        except (TypeError, ValueError):
            problems.append(f"known_parameters[{name_of(p)}]: expected a number, found {v!r}")
            continue
        if not np.isfinite(fv):
            problems.append(
                f"known_parameters[{name_of(p)}]: expected a finite number, found {v!r}"
            )
        values[p] = fv
    if unknown is None:
        free = tuple(p for p in model.parameters if p not in known)
    else:
        free = tuple(unknown)
        free_set = set(free)
        stray = [name_of(p) for p in free if p not in parameters]
        if stray:
            problems.append(f"unknown_parameters: {stray} are not parameters of the model")
        both = [name_of(p) for p in free if p in known]
        if both:
            problems.append(f"unknown_parameters: {both} are also given in known_parameters")
        neither = [name_of(p) for p in model.parameters if p not in known and p not in free_set]
        if neither:
            problems.append(
                f"parameters {neither} are neither known nor unknown; give a value in "
                "known_parameters or list them in unknown_parameters"
            )
    return values, free


def check_objective(objective: Any, problems: list[str]) -> list[ObjectiveTerm]:
    """One term or a sequence of terms (``None``: a feasibility problem)."""
    if objective is None:
        return []
    if isinstance(objective, ObjectiveTerm):
        terms = [objective]
    elif isinstance(objective, list | tuple):
        terms = list(objective)
    else:
        problems.append(
            "objective: expected Tracking, IntegralCost or TerminalCost terms (or a list of "
            f"them), found {type(objective).__name__}"
        )
        return []
    bad = [type(t).__name__ for t in terms if not isinstance(t, ObjectiveTerm)]
    if bad:
        problems.append(
            f"objective: expected Tracking, IntegralCost or TerminalCost terms, found {bad}"
        )
    return [t for t in terms if isinstance(t, ObjectiveTerm)]


def check_bounds(
    bounds: Bounds, allowed: Sequence[sm.Basic], problems: list[str]
) -> dict[sm.Basic, tuple[float, float]]:
    """Bounds on states, free inputs and unknown parameters."""
    out: dict[sm.Basic, tuple[float, float]] = {}
    allowed_set = set(allowed)
    for s, pair in bounds.items():
        if s not in allowed_set:
            problems.append(
                f"bounds: {name_of(s)} is not a free quantity (free: "
                f"{[name_of(a) for a in allowed]})"
            )
            continue
        try:
            lo, hi = (float(v) for v in pair)
        except (TypeError, ValueError):
            problems.append(f"bounds[{name_of(s)}]: expected a pair (lower, upper), found {pair!r}")
            continue
        if np.isnan(lo) or np.isnan(hi):
            problems.append(f"bounds[{name_of(s)}]: expected numbers, found NaN in ({lo}, {hi})")
        elif not lo <= hi:
            problems.append(f"bounds[{name_of(s)}]: lower {lo} is above upper {hi}")
        out[s] = (lo, hi)
    return out


def model_instance_constraints(
    model: Model, node_residual: bool, times: np.ndarray
) -> list[sm.Expr]:
    """What the model asks of particular nodes, as instance constraints.

    Its :attr:`~colloc.Model.initial_constraints` at the first node; and, for a scheme
    without a residual at each node (``node_residual`` False: the interval defects see a
    state without derivative only through neighbouring nodes, e.g. as their mean), a zero
    second difference of each such state over the first three nodes (equal values with two
    nodes), which fixes the one alternating mode those defects leave free.

    Parameters
    ----------
    model : Model
    node_residual : bool
        Whether the scheme holds the residual at every node (schemes with derivative
        variables).
    times : ndarray
        The grid's node times.

    Returns
    -------
    list of sympy.Expr
        In ``x(t_k)`` values, as :func:`parse_instance_constraints` reads them.
    """

    def at(k: int) -> dict[sm.Basic, sm.Basic]:
        tk = sm.Float(float(times[k]))
        return {x: x.func(tk) for x in model.states}

    out = [sm.sympify(e, strict=True).xreplace(at(0)) for e in model.initial_constraints]
    if not node_residual:
        for x in model.algebraic_states:
            if times.size >= 3:
                out.append(x.xreplace(at(0)) - 2 * x.xreplace(at(1)) + x.xreplace(at(2)))
            else:
                out.append(x.xreplace(at(0)) - x.xreplace(at(1)))
    return out


def parse_instance_constraints(
    exprs: Sequence[sm.Expr],
    node_functions: Sequence[sm.Basic],
    parameters: Sequence[sm.Symbol],
    times: np.ndarray,
    problems: list[str],
) -> tuple[list[sm.Expr], list[sm.Symbol], list[tuple[int, int]]]:
    """Replace ``x(t_k)`` by placeholders.

    Returns
    -------
    exprs : list of sympy.Expr
        The constraints in placeholders and parameters.
    placeholders : list of sympy.Symbol
    locations : list of (node, position in node_functions)
    """
    funcs = {f.func: j for j, f in enumerate(node_functions)}
    tol = 1e-9 * max(1.0, float(np.max(np.abs(times))))
    holders: dict[sm.Basic, sm.Symbol] = {}
    locations: list[tuple[int, int]] = []
    out: list[sm.Expr] = []
    for i, e in enumerate(exprs):
        if not isinstance(e, sm.Basic):
            problems.append(f"instance_constraints[{i}]: expected a SymPy expression, found {e!r}")
            continue
        for a in sorted(e.atoms(AppliedUndef), key=str):
            if a in holders:
                continue
            if a.func not in funcs:
                problems.append(
                    f"instance_constraints[{i}]: {a} is not a state or free input trajectory"
                )
                continue
            if len(a.args) != 1 or not a.args[0].is_number:
                problems.append(
                    f"instance_constraints[{i}]: {a} must be evaluated at a numeric time, e.g. "
                    f"{a.func}(0.0)"
                )
                continue
            tk = float(a.args[0])
            k = int(np.argmin(np.abs(times - tk)))
            if abs(times[k] - tk) > tol:
                problems.append(
                    f"instance_constraints[{i}]: time {tk} of {a} is not a node of the grid "
                    f"(nearest node t = {times[k]})"
                )
                continue
            holders[a] = sm.Symbol(f"_ic{len(holders)}")
            locations.append((k, funcs[a.func]))
        stray = e.free_symbols - set(parameters) - set(holders.values())
        if stray:
            problems.append(
                f"instance_constraints[{i}]: symbols {sorted(map(str, stray))} are not "
                "parameters of the model"
            )
        out.append(e.xreplace(holders))
    return out, list(holders.values()), locations


def check_node_terms(
    terms: Sequence[Any], model: Model, derivatives_allowed: bool, problems: list[str]
) -> None:
    """Objective expressions may use states, inputs, parameters, t and their own data only
    (and a schedule's slots, which a tracked output of a closed loop holds)."""
    allowed_funcs = set(model.states) | set(model.inputs) | {s.weight for s in model.schedules}
    scheduled = {p for s in model.schedules for p in s.parameters}
    slots = {a for s in model.schedules for a in s.slots_a + s.slots_b}
    for i, term in enumerate(terms):
        funcs = {a for a in term.expr.atoms(AppliedUndef)} - allowed_funcs
        syms = term.expr.free_symbols - (set(model.parameters) - scheduled) - slots
        syms -= set(term.data_symbols) | {model.t}
        if funcs or syms:
            names = sorted(name_of(f) for f in funcs) + sorted(str(s) for s in syms)
            problems.append(
                f"objective term {i}: {names} are not states, inputs or parameters of the model"
            )
        ders = term.expr.atoms(sm.Derivative)
        if ders and not derivatives_allowed:
            problems.append(
                f"objective term {i}: uses state derivatives {sorted(map(str, ders))}, which this "
                "scheme has no variables for; use Trapezoidal or HermiteSimpson, or add a state"
            )


def check_schedules(
    model: Model,
    known: Mapping[sm.Symbol, float],
    unknown: Sequence[sm.Symbol],
    trajectories: Mapping[sm.Basic, np.ndarray],
    problems: list[str],
) -> None:
    """Schedule points are all known or all unknown; phases are non-decreasing."""
    for sched in model.schedules:
        n_known = sum(p in known for p in sched.parameters)
        if 0 < n_known < len(sched.parameters):
            problems.append(
                f"schedule over {name_of(sched.phase)}: give every point's parameters in "
                f"known_parameters or none of them (found {n_known} of {len(sched.parameters)})"
            )
        phase = trajectories.get(sched.phase)
        if phase is not None and np.any(np.diff(phase) < 0):
            i = int(np.argmax(np.diff(phase) < 0))
            problems.append(
                f"known_trajectories[{name_of(sched.phase)}]: expected the unwrapped phase "
                f"(non-decreasing, in cycles), found a decrease after node {i}"
            )


def _standard_deviation(value: Any, where: str, problems: list[str]) -> float | None:
    try:
        std = float(value)
    except (TypeError, ValueError):
        problems.append(f"{where}: expected a standard deviation > 0, found {value!r}")
        return None
    if not (np.isfinite(std) and std > 0):
        problems.append(f"{where}: expected a finite standard deviation > 0, found {value!r}")
        return None
    return std


def _is_mapping(value: Any, name: str, expected: str, problems: list[str]) -> bool:
    if isinstance(value, Mapping):
        return True
    problems.append(f"{name}: expected a mapping {expected}, found {type(value).__name__}")
    return False


def check_process_noise(
    model: Model, process_noise: Mapping[Any, Any], problems: list[str]
) -> dict[Any, Any]:
    """Disturbance -> its standard deviation per node, or a tuple of disturbances -> their
    covariance per node (a symmetric positive definite matrix); each an unknown input, and
    none in two entries."""
    out: dict[Any, Any] = {}
    if not _is_mapping(
        process_noise,
        "process_noise",
        "disturbance -> standard deviation (or a tuple of disturbances -> covariance)",
        problems,
    ):
        return out
    seen: set[sm.Basic] = set()
    for key, value in process_noise.items():
        group = tuple(key) if isinstance(key, tuple | list) else (key,)
        where = f"process_noise[{', '.join(map(name_of, group))}]"
        bad = [w for w in group if w not in model.unknown_inputs]
        twice = [w for w in group if w in seen]
        seen.update(group)
        if bad:
            problems.append(
                f"process_noise: {', '.join(map(name_of, bad))} is not an unknown input of the "
                "model (add it with Model.with_disturbances; unknown inputs: "
                f"{[name_of(r) for r in model.unknown_inputs]})"
            )
            continue
        if twice or len(set(group)) != len(group):
            problems.append(
                f"{where}: {', '.join(map(name_of, twice or group))} given twice; each "
                "disturbance belongs to one entry"
            )
            continue
        if not isinstance(key, tuple | list):
            std = _standard_deviation(value, where, problems)
            if std is not None:
                out[key] = std
            continue
        covariance = _covariance(value, len(group), where, problems)
        if covariance is not None:
            out[group] = covariance
    return out


def _covariance(value: Any, size: int, where: str, problems: list[str]) -> np.ndarray | None:
    """A ``size x size`` symmetric positive definite matrix, or None with the problem said."""
    try:
        matrix = np.array(value, dtype=float)
    except (TypeError, ValueError):
        problems.append(f"{where}: expected a {size} x {size} covariance matrix, found {value!r}")
        return None
    if matrix.shape != (size, size):
        problems.append(
            f"{where}: expected a {size} x {size} covariance matrix (one row per disturbance), "
            f"found shape {matrix.shape}"
        )
        return None
    if not np.all(np.isfinite(matrix)):
        problems.append(f"{where}: expected finite values, found {matrix.tolist()}")
        return None
    if not np.allclose(matrix, matrix.T, rtol=1e-10, atol=0.0):
        problems.append(f"{where}: expected a symmetric matrix, found {matrix.tolist()}")
        return None
    try:
        np.linalg.cholesky(matrix)
    except np.linalg.LinAlgError:
        eig = np.linalg.eigvalsh(matrix)
        problems.append(
            f"{where}: expected a positive definite covariance, found eigenvalues {eig.tolist()}"
        )
        return None
    return matrix


def check_measured_inputs(
    model: Model,
    measured: Mapping[sm.Basic, Any],
    known: Mapping[sm.Basic, Any],
    num_nodes: int,
    problems: list[str],
) -> dict[sm.Basic, tuple[np.ndarray, float]]:
    """Input -> (measured values per node, NaN where missing; standard deviation)."""
    out: dict[sm.Basic, tuple[np.ndarray, float]] = {}
    if not _is_mapping(
        measured, "measured_inputs", "input -> (values, standard deviation)", problems
    ):
        return out
    for r, entry in measured.items():
        where = f"measured_inputs[{name_of(r)}]"
        if r not in model.inputs:
            problems.append(
                f"measured_inputs: {name_of(r)} is not an input of the model (inputs: "
                f"{[name_of(i) for i in model.inputs]})"
            )
            continue
        if r in known:
            problems.append(
                f"measured_inputs: {name_of(r)} is also given in known_trajectories; an input "
                "is either known exactly or measured with noise"
            )
            continue
        if not (isinstance(entry, tuple | list) and len(entry) == 2):
            problems.append(
                f"{where}: expected a pair (values, standard deviation), found {entry!r}"
            )
            continue
        values, std_value = entry
        arr = np.asarray(values, dtype=float)
        std = _standard_deviation(std_value, f"{where} standard deviation", problems)
        if arr.shape != (num_nodes,):
            problems.append(
                f"{where}: expected {num_nodes} values (one per node), found shape {arr.shape}"
            )
        elif np.isinf(arr).any() or np.isnan(arr).all():
            problems.append(
                f"{where}: expected finite values (NaN where missing), found inf or all NaN"
            )
        elif std is not None:
            out[r] = (arr, std)
    return out


def same_keys(
    option: str, what: str, built: Mapping[Any, Any], new: Mapping[Any, Any], problems: list[str]
) -> None:
    """Name the difference when ``new`` does not cover the built problem's ``built`` keys
    (only once the new values are otherwise valid): ``option`` is the argument, ``what``
    its keys in words; the message is appended to ``problems``."""
    if set(new) != set(built) and not problems:
        problems.append(
            f"{option}: expected the same {what} as the built problem "
            f"{[key_name(k) for k in built]}, found {[key_name(k) for k in new]}"
        )


def key_name(key: Any) -> str:
    """A symbol's name, or a group's ``(a, b)``."""
    if isinstance(key, tuple):
        return "(" + ", ".join(map(name_of, key)) + ")"
    return name_of(key)
