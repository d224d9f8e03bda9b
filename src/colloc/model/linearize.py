"""Linearize a ``KanesMethod``, a ``LagrangesMethod`` or a :class:`colloc.Model`.

Mechanical systems go through SymPy's own :class:`~sympy.physics.mechanics.linearize.
Linearizer` (the general form of Peterson, Gede and Hubbard, 2015); this module adds what
users otherwise do by hand: checking the operating point, choosing the dependent
coordinates and speeds, solving the Lagrange multipliers at the operating point, and
returning a :class:`~colloc.model.state_space.StateSpace`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, TypeAlias

import sympy as sm
from sympy.physics.mechanics import KanesMethod, LagrangesMethod, Linearizer, msubs

from colloc.model.general_form import (
    format_value,
    is_nonzero,
    is_singular,
    solve_linear,
    stack,
    to_state_space,
)
from colloc.model.model import Model
from colloc.model.op_point import (
    OperatingPointError,
    resolve_mapping,
    resolve_sequence,
    variable_name,
)
from colloc.model.state_space import StateSpace
from colloc.model.symbols import TIME

__all__ = ["linearize"]

Names: TypeAlias = Sequence[Any] | sm.MatrixBase | None


def linearize(
    system: KanesMethod | LagrangesMethod | Model,
    op_point: Mapping[Any, Any],
    q_ind: Names = None,
    q_dep: Names = None,
    u_ind: Names = None,
    u_dep: Names = None,
    *,
    inputs: Names = None,
    constants: Mapping[Any, Any] | None = None,
    equilibrium: bool = False,
    numeric: bool | None = None,
    simplify: bool = False,
    tol: float = 1e-9,
) -> StateSpace:
    """Linearize a system about an operating point into ``dx/dt = A x + B r``.

    Parameters
    ----------
    system : KanesMethod, LagrangesMethod or colloc.Model
        A ``KanesMethod`` after ``kanes_equations``, a ``LagrangesMethod`` after
        ``form_lagranges_equations`` (``hol_coneqs`` and ``nonhol_coneqs`` allowed), or a
        :class:`colloc.Model` whose residual ``F(x', x, r, p, t)`` is square in ``x'``.
    op_point : mapping
        Values of every coordinate ``q`` and speed ``u`` (for a Model: every state) and of
        the speed derivatives ``u'`` (Model: ``x'``), keyed by the SymPy object or its name:
        ``"q1"`` for ``q1(t)``, ``"q1_dot"`` for its first derivative, ``"q1_ddot"`` for the
        second. For a ``LagrangesMethod`` the speeds are ``q'`` and their derivatives ``q''``.
        Inputs ``r`` may be given and default to 0. Coordinate derivatives of a
        ``KanesMethod`` are computed from its kinematic equations. Values are numbers or
        SymPy expressions (symbolic operating points are fine).
    q_ind, q_dep : sequence, optional
        Independent and dependent coordinates (objects or names); one dependent coordinate
        per configuration constraint. Give either; the other is the complement. Default:
        the ``KanesMethod``'s own split; all independent when there are no constraints.
    u_ind, u_dep : sequence, optional
        Independent and dependent speeds, one dependent speed per motion constraint. For a
        ``LagrangesMethod`` with only holonomic constraints they default to the derivatives
        of ``q_ind`` and ``q_dep``.
    inputs : sequence, optional
        The inputs whose columns ``B`` holds, in this order. Default: every input found
        (SymPy's canonical order for mechanics systems, ``Model.inputs`` for a Model).
    constants : mapping, optional
        Values substituted for constants (symbols or names) before linearizing.
    equilibrium : bool
        Require an equilibrium: the speed derivatives (Model: all state derivatives) are 0,
        may be omitted from ``op_point``, and the equations of motion must hold there.
    numeric : bool or None
        ``None``: NumPy arrays when every entry is a number, SymPy matrices otherwise.
        ``True``: NumPy arrays, and an error naming any symbol left. ``False``: SymPy.
    simplify : bool
        Simplify symbolic results.
    tol : float
        Absolute tolerance when checking that numeric residuals vanish.

    Returns
    -------
    StateSpace
        ``A``, ``B``, the states ``[q_ind, u_ind]`` (Model: its states), the inputs, and the
        general form ``M``, ``A_general``, ``B_general``. Lagrange multipliers are solved
        from the system's equations at the operating point and substituted.

    Raises
    ------
    OperatingPointError
        (a ``ValueError``) listing every missing or unexpected entry, bad split, violated
        constraint, failed equilibrium check or singular matrix found.
    TypeError
        If ``system`` is of another type or its equations have not been formed.

    Examples
    --------
    >>> ss = linearize(lagranges_method, {"q1": L, "q2": 0, "q1_dot": 0, "q2_dot": 0},
    ...                q_ind=["q2"], q_dep=["q1"], equilibrium=True)  # doctest: +SKIP
    >>> ss.A                                                          # doctest: +SKIP
    Matrix([[0, 1], [-9.8/L, 0]])
    """
    options = dict(numeric=numeric, simplify=simplify, tol=tol)
    if isinstance(system, Model):
        given = [
            n
            for n, v in zip(
                ("q_ind", "q_dep", "u_ind", "u_dep"), (q_ind, q_dep, u_ind, u_dep), strict=True
            )
            if v is not None
        ]
        if given:
            raise OperatingPointError(
                [
                    f"{n}: a colloc.Model has no dependent variables to choose; found {n} given"
                    for n in given
                ]
            )
        return _linearize_model(system, op_point, inputs, constants, equilibrium, options)
    if isinstance(system, KanesMethod | LagrangesMethod):
        lin = _mechanics_linearizer(system, q_ind, q_dep, u_ind, u_dep)
        return _linearize_general(lin, op_point, inputs, constants, equilibrium, options)
    raise TypeError(
        "system: expected a KanesMethod, a LagrangesMethod or a colloc.Model, "
        f"found {type(system).__name__}"
    )


# --------------------------------------------------------------------------- split
def _mechanics_linearizer(
    system: KanesMethod | LagrangesMethod, q_ind: Names, q_dep: Names, u_ind: Names, u_dep: Names
) -> Linearizer:
    problems: list[str] = []
    if isinstance(system, KanesMethod):
        if getattr(system, "_fr", None) is None:
            raise TypeError(
                "system: expected a KanesMethod whose kanes_equations() has been called"
            )
        base = system.to_linearizer()
        q, u = tuple(base.q), tuple(base.u)
        num_hol, num_motion = len(base.f_c), len(base.f_v)
        q_split = _split(
            q, q_ind, q_dep, num_hol, (tuple(base.q_i), tuple(base.q_d)), "q", problems
        )
        u_split = _split(
            u, u_ind, u_dep, num_motion, (tuple(base.u_i), tuple(base.u_d)), "u", problems
        )
        _raise(problems)
        assert q_split is not None and u_split is not None
        # Kane's equations hold whichever speeds are called dependent, so SymPy's general
        # form is reused with the user's partition.
        return _ordered(base, q_split, u_split)
    if getattr(system, "eom", None) is None:
        raise TypeError(
            "system: expected a LagrangesMethod whose form_lagranges_equations() has been called"
        )
    q = tuple(system.q)
    u = tuple(x.diff(TIME) for x in q)
    # SymPy keeps the holonomic constraints apart only in this attribute.
    num_hol = len(system._hol_coneqs)
    num_motion = len(system.coneqs)
    q_split = _split(q, q_ind, q_dep, num_hol, (q, ()) if num_hol == 0 else None, "q", problems)
    derived: Split | None = None
    if q_split is not None and num_motion == num_hol:
        derived = (_diff(q_split[0]), _diff(q_split[1]))
    u_split = _split(u, u_ind, u_dep, num_motion, derived, "u", problems)
    _raise(problems)
    assert q_split is not None and u_split is not None
    base = system.to_linearizer(q_split[0], u_split[0], q_split[1], u_split[1])
    return _ordered(base, q_split, u_split)


Split: TypeAlias = tuple[tuple[sm.Basic, ...], tuple[sm.Basic, ...]]


def _ordered(base: Linearizer, q_split: Split, u_split: Split) -> Linearizer:
    """The same general form with q = [q_ind, q_dep] and u = [u_ind, u_dep].

    SymPy 1.14 builds its permutation matrices transposed (``permutation_matrix`` returns
    P with ``new = P old``, used as ``old = P new``); that is harmless only when the
    reordering is its own inverse. Ordering the vectors as the split makes it the identity.
    """
    return Linearizer(
        base.f_0,
        base.f_1,
        base.f_2,
        base.f_3,
        base.f_4,
        base.f_c,
        base.f_v,
        base.f_a,
        q_split[0] + q_split[1],
        u_split[0] + u_split[1],
        q_split[0],
        q_split[1],
        u_split[0],
        u_split[1],
        base.r,
        base.lams,
    )


def _diff(coords: tuple[sm.Basic, ...]) -> tuple[sm.Basic, ...]:
    return tuple(x.diff(TIME) for x in coords)


def _split(
    all_vars: tuple[sm.Basic, ...],
    ind: Names,
    dep: Names,
    num_dep: int,
    default: tuple[tuple[sm.Basic, ...], tuple[sm.Basic, ...]] | None,
    label: str,
    problems: list[str],
) -> tuple[tuple[sm.Basic, ...], tuple[sm.Basic, ...]] | None:
    kind = "configuration" if label == "q" else "motion"
    ind_t = resolve_sequence(ind, all_vars, f"{label}_ind", problems)
    dep_t = resolve_sequence(dep, all_vars, f"{label}_dep", problems)
    if ind_t is None and dep_t is None:
        if default is None:
            problems.append(
                f"{label}_dep: the system has {num_dep} {kind} constraint(s); expected "
                f"{num_dep} dependent entries chosen from {[variable_name(v) for v in all_vars]}, "
                "found none"
            )
        return default
    if ind_t is None:
        ind_t = tuple(v for v in all_vars if v not in set(dep_t or ()))
    if dep_t is None:
        dep_t = tuple(v for v in all_vars if v not in set(ind_t))
    both = [variable_name(v) for v in ind_t if v in dep_t]
    if both:
        problems.append(
            f"{label}_ind/{label}_dep: {both} are listed as both independent and dependent"
        )
    left = [variable_name(v) for v in all_vars if v not in ind_t and v not in dep_t]
    if left:
        problems.append(f"{label}_ind/{label}_dep: {left} are in neither")
    if len(dep_t) != num_dep:
        problems.append(
            f"{label}_dep: expected {num_dep} entries (one per {kind} constraint), found "
            f"{len(dep_t)}: {[variable_name(v) for v in dep_t]}"
        )
    return ind_t, dep_t


# --------------------------------------------------------------------------- mechanics
def _linearize_general(
    lin: Linearizer,
    op_point: Mapping[Any, Any],
    inputs: Names,
    constants: Mapping[Any, Any] | None,
    equilibrium: bool,
    options: dict[str, Any],
) -> StateSpace:
    q, u, r, lams = (tuple(m) for m in (lin.q, lin.u, lin.r, lin.lams))
    ud = tuple(v.diff(TIME) for v in u)
    qd = tuple(v.diff(TIME) for v in q)
    rows = [lin.f_0, lin.f_1, lin.f_2, lin.f_3, lin.f_4, lin.f_c, lin.f_v, lin.f_a]
    params = _constants_of(rows, exclude=set(lams))
    problems: list[str] = []
    const = resolve_mapping(constants, params, "constants", problems)
    point = resolve_mapping(
        op_point, q + u + ud + r, "op_point", problems, required=q + u + (() if equilibrium else ud)
    )
    chosen = resolve_sequence(inputs, r, "inputs", problems)
    _raise(problems)
    point = _complete(point, ud if equilibrium else (), r, const, equilibrium, options["tol"])
    if not set(qd) <= set(u):
        point.update(solve_linear(lin.f_0 + lin.f_1, qd, point, "kinematic equations"))
    _check_constraints(lin, point, options["tol"])
    multipliers: dict[sm.Basic, sm.Expr] = {}
    if lams or equilibrium:
        dyn = stack(lin.f_2 + lin.f_3 + lin.f_4, lin.f_a)
        solved = solve_linear(dyn, ud + lams, _without(point, ud), "equations of motion")
        multipliers = {lam: solved[lam] for lam in lams}
        if equilibrium:
            _check_equilibrium(
                dyn, {**point, **multipliers}, solved, ud, len(lin.f_2), options["tol"]
            )
    m_eq, a_gen, b_gen = lin.linearize(op_point=point)
    m_eq, a_gen = msubs(m_eq, multipliers), msubs(a_gen, multipliers)
    b_gen = msubs(b_gen, multipliers) if b_gen.shape[0] else sm.zeros(m_eq.shape[0], len(r))
    sel = chosen if chosen is not None else r
    b_gen = b_gen[:, [r.index(v) for v in sel]] if sel else sm.zeros(m_eq.shape[0], 0)
    states = tuple(lin.q_i) + tuple(lin.u_i)
    return to_state_space(
        m_eq, a_gen, b_gen, lin.perm_mat.T, states, sel, {**point, **multipliers}, options
    )


def _check_constraints(lin: Linearizer, point: dict[sm.Basic, sm.Expr], tol: float) -> None:
    problems: list[str] = []
    for kind, eqs in (("configuration", lin.f_c), ("motion", lin.f_v)):
        for i, value in enumerate(msubs(eqs, point)):
            if is_nonzero(value, tol):
                problems.append(
                    f"op_point: violates {kind} constraint {i} (residual {format_value(value)})"
                )
    for label, eqs, dep in (("q_dep", lin.f_c, lin.q_d), ("u_dep", lin.f_v, lin.u_d)):
        if len(dep) and is_singular(msubs(eqs.jacobian(dep), point)):
            problems.append(
                f"{label}: the constraints cannot be solved for {[variable_name(v) for v in dep]} "
                "at this operating point (their Jacobian with respect to them is singular); "
                "choose other dependent variables"
            )
    _raise(problems)


def _check_equilibrium(
    dyn: sm.Matrix,
    point: dict[sm.Basic, sm.Expr],
    solved: dict[sm.Basic, sm.Expr],
    ud: tuple[sm.Basic, ...],
    num_dynamic: int,
    tol: float,
) -> None:
    problems: list[str] = []
    for i, value in enumerate(msubs(dyn, point)):
        if is_nonzero(value, tol):
            what = (
                f"dynamic equation {i}"
                if i < num_dynamic
                else f"acceleration constraint {i - num_dynamic}"
            )
            problems.append(
                f"op_point: not an equilibrium, {what} has residual {format_value(value)}"
            )
    if problems:
        moving = [
            f"{variable_name(v)} = {format_value(solved[v])}"
            for v in ud
            if is_nonzero(solved[v], tol)
        ]
        problems.append(f"op_point: the equations give nonzero speed derivatives {moving}")
    _raise(problems)


# --------------------------------------------------------------------------- Model
def _linearize_model(
    model: Model,
    op_point: Mapping[Any, Any],
    inputs: Names,
    constants: Mapping[Any, Any] | None,
    equilibrium: bool,
    options: dict[str, Any],
) -> StateSpace:
    x, xd, r = model.states, model.state_derivatives, model.inputs
    problems: list[str] = []
    const = resolve_mapping(constants, model.parameters, "constants", problems)
    point = resolve_mapping(
        op_point, x + xd + r, "op_point", problems, required=x + (() if equilibrium else xd)
    )
    chosen = resolve_sequence(inputs, r, "inputs", problems)
    if model.num_equations != len(x):
        problems.append(
            f"system: expected a Model with one equation per state, found {model.num_equations} "
            f"equations for {len(x)} states"
        )
    _raise(problems)
    point = _complete(point, xd if equilibrium else (), r, const, equilibrium, options["tol"])
    residual = model.residual
    if equilibrium:
        bad = [
            f"op_point: not an equilibrium, residual row {i} is {format_value(value)}"
            for i, value in enumerate(msubs(residual, point))
            if is_nonzero(value, options["tol"])
        ]
        _raise(bad)
    sel = chosen if chosen is not None else r
    m_eq = msubs(residual.jacobian(xd), point)
    if is_singular(m_eq):
        algebraic = [variable_name(s) for s, d in zip(x, xd, strict=True) if not residual.has(d)]
        raise OperatingPointError(
            [
                "system: dF/dx' is singular at the operating point, so the Model is not an ODE "
                f"there (states without derivatives: {algebraic}); linearize the "
                "KanesMethod/LagrangesMethod instead, choosing q_dep/u_dep"
            ]
        )
    a_gen = -msubs(residual.jacobian(x), point)
    b_gen = -msubs(residual.jacobian(sel), point) if sel else sm.zeros(len(x), 0)
    return to_state_space(m_eq, a_gen, b_gen, sm.eye(len(x)), x, sel, point, options)


# --------------------------------------------------------------------------- shared
def _complete(
    point: dict[sm.Basic, sm.Expr],
    zero_derivs: tuple[sm.Basic, ...],
    inputs: tuple[sm.Basic, ...],
    const: dict[sm.Basic, sm.Expr],
    equilibrium: bool,
    tol: float,
) -> dict[sm.Basic, sm.Expr]:
    if equilibrium:
        moving = [
            f"{variable_name(v)} = {format_value(point[v])}"
            for v in zero_derivs
            if v in point and is_nonzero(point[v], tol)
        ]
        if moving:
            raise OperatingPointError(
                [f"op_point: equilibrium=True needs zero derivatives, found {moving}"]
            )
    for v in zero_derivs + inputs:
        point.setdefault(v, sm.Integer(0))
    done = {k: sm.sympify(v, strict=True).xreplace(const) for k, v in point.items()}
    return {**const, **done}


def _constants_of(rows: list[sm.Matrix], exclude: set[sm.Basic]) -> list[sm.Basic]:
    found: set[sm.Basic] = set()
    for mat in rows:
        found |= mat.free_symbols
    found -= exclude | {TIME}
    return sorted(found, key=variable_name)


def _without(point: dict[sm.Basic, sm.Expr], keys: tuple[sm.Basic, ...]) -> dict[sm.Basic, sm.Expr]:
    return {k: v for k, v in point.items() if k not in set(keys)}


def _raise(problems: list[str]) -> None:
    if problems:
        raise OperatingPointError(problems)
