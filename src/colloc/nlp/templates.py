"""Symbolic templates of one interval, one node and the instance constraints.

The model residual is translated to CasADi once; the scheme turns it into the defects of
one interval (and one node); the objective becomes one node expression. Each template is
differentiated once (:class:`colloc.numeric.stencil.StencilFunctions`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import casadi as ca
import sympy as sm

from colloc.model.model import Model
from colloc.model.symbols import name_of
from colloc.nlp.objective import NodeTerm
from colloc.numeric.bridge import sympy_to_casadi
from colloc.numeric.stencil import StencilFunctions
from colloc.transcription.base import IntervalView, NodeView, Residual, Scheme


@dataclass(frozen=True)
class Partition:
    """Which model quantities are free and which are data."""

    model: Model
    free_inputs: tuple[sm.Basic, ...]
    known_inputs: tuple[sm.Basic, ...]
    unknown_parameters: tuple[sm.Symbol, ...]
    known_parameters: tuple[sm.Symbol, ...]

    @property
    def num_states(self) -> int:
        """``n``."""
        return self.model.num_states

    @cached_property
    def scheduled(self) -> frozenset[sm.Symbol]:
        """Parameters that belong to a schedule (reached through slots, not directly)."""
        return frozenset(p for s in self.model.schedules for p in s.parameters)

    @cached_property
    def plain_unknown(self) -> tuple[sm.Symbol, ...]:
        """Unknown parameters outside schedules."""
        scheduled = self.scheduled
        return tuple(p for p in self.unknown_parameters if p not in scheduled)

    @cached_property
    def plain_known(self) -> tuple[sm.Symbol, ...]:
        """Known parameters outside schedules."""
        scheduled = self.scheduled
        return tuple(p for p in self.known_parameters if p not in scheduled)

    @property
    def schedule_is_unknown(self) -> tuple[bool, ...]:
        """Per schedule: whether its points are estimated (else they are data)."""
        unknown = set(self.unknown_parameters)
        return tuple(s.parameters[0] in unknown for s in self.model.schedules)


class _Symbols:
    """SX placeholders for one stencil, and the maps that put them in model order."""

    def __init__(self, part: Partition, scheme: Scheme, prefix: str) -> None:
        n = part.num_states
        self.part = part
        self.n_node = n + len(part.free_inputs) + (n if scheme.node_derivatives else 0)
        self.pu = ca.SX.sym(f"{prefix}p", len(part.plain_unknown))
        self.pk = ca.SX.sym(f"{prefix}pk", len(part.plain_known))
        by_symbol = dict(zip(part.plain_unknown, _entries(self.pu), strict=True))
        by_symbol.update(zip(part.plain_known, _entries(self.pk), strict=True))
        # Schedule points enter only through their slots; as plain parameters they are unused.
        self.p = ca.vertcat(*(by_symbol.get(p, ca.SX(0)) for p in part.model.parameters))
        free_slots: list[ca.SX] = []
        data_slots: list[ca.SX] = []
        weights: list[ca.SX] = []
        S: list[ca.SX] = []
        #: model symbol -> placeholder, for expressions that hold the schedules' slots
        self.slot_leaves: dict[sm.Basic, ca.SX] = {}
        for i, (sched, unknown) in enumerate(
            zip(part.model.schedules, part.schedule_is_unknown, strict=True)
        ):
            a = ca.SX.sym(f"{prefix}sa{i}", sched.size)
            b = ca.SX.sym(f"{prefix}sb{i}", sched.size)
            w = ca.SX.sym(f"{prefix}w{i}")
            (free_slots if unknown else data_slots).extend([a, b])
            weights.append(w)
            S.extend([a, b, w])
            self.slot_leaves.update(zip(sched.slots_a, _entries(a), strict=True))
            self.slot_leaves.update(zip(sched.slots_b, _entries(b), strict=True))
            self.slot_leaves[sched.weight] = w
        self.free_slots = ca.vertcat(*free_slots) if free_slots else ca.SX(0, 1)
        self.data_slots = ca.vertcat(*data_slots) if data_slots else ca.SX(0, 1)
        self.weights = ca.vertcat(*weights) if weights else ca.SX(0, 1)
        self.S = ca.vertcat(*S) if S else ca.SX(0, 1)

    def F(self, F: ca.Function) -> Residual:
        """The residual with parameters and schedule slots bound: ``F(xdot, x, r, t)``."""
        return lambda xd, x, r, t: F(xd, x, r, self.p, t, self.S)

    def node(self, z: ca.SX, r_known: ca.SX, t: ca.SX) -> NodeView:
        n = self.part.num_states
        nf = len(self.part.free_inputs)
        x = z[:n]
        v = z[n + nf : n + nf + n] if z.numel() > n + nf else None
        return NodeView(x, v, self.inputs(z[n : n + nf], r_known), t)

    def inputs(self, r_free: ca.SX, r_known: ca.SX) -> ca.SX:
        by_symbol = dict(zip(self.part.free_inputs, _entries(r_free), strict=True))
        by_symbol.update(zip(self.part.known_inputs, _entries(r_known), strict=True))
        return ca.vertcat(*(by_symbol[r] for r in self.part.model.inputs))


def _entries(v: ca.SX) -> list[ca.SX]:
    # vertsplit of an empty SX returns one empty piece; indexing keeps zero-length honest.
    return [v[i] for i in range(v.numel())]


def residual_function(model: Model) -> ca.Function:
    """``F(xdot, x, r, p, t, S)`` of ``model`` as a CasADi function.

    ``S`` stacks, per schedule, the lower slots, the upper slots and the weight.
    """
    n, m = model.num_states, len(model.inputs)
    xd, x = ca.SX.sym("xd", n), ca.SX.sym("x", n)
    r, p, t = ca.SX.sym("r", m), ca.SX.sym("p", len(model.parameters)), ca.SX.sym("t")
    leaves = _leaves(model, xd, x, r, p, t)
    pieces = []
    for i, sched in enumerate(model.schedules):
        a, b, w = (
            ca.SX.sym(f"sa{i}", sched.size),
            ca.SX.sym(f"sb{i}", sched.size),
            ca.SX.sym(f"w{i}"),
        )
        leaves.update(zip(sched.slots_a, _entries(a), strict=True))
        leaves.update(zip(sched.slots_b, _entries(b), strict=True))
        leaves[sched.weight] = w
        pieces += [a, b, w]
    S = ca.vertcat(*pieces) if pieces else ca.SX(0, 1)
    res = sympy_to_casadi(list(model.residual), leaves)
    return ca.Function("F", [xd, x, r, p, t, S], [ca.vertcat(*res)])


def _leaves(model: Model, xd: ca.SX, x: ca.SX, r: ca.SX, p: ca.SX, t: ca.SX) -> dict:
    leaves: dict[sm.Basic, ca.SX] = {model.t: t}
    leaves.update(zip(model.state_derivatives, _entries(xd), strict=True))
    leaves.update(zip(model.states, _entries(x), strict=True))
    leaves.update(zip(model.inputs, _entries(r), strict=True))
    leaves.update(zip(model.parameters, _entries(p), strict=True))
    return leaves


def interval_template(part: Partition, scheme: Scheme, F: ca.Function) -> StencilFunctions:
    """Defects of one interval: ``w = [node k, node k+1, interval vars, p_unknown]``."""
    s = _Symbols(part, scheme, "i")
    n_rk = len(part.known_inputs)
    z0, z1 = ca.SX.sym("z0", s.n_node), ca.SX.sym("z1", s.n_node)
    extra = ca.SX.sym("m", scheme.num_interval_variables(part.num_states))
    r0, r1, rm = ca.SX.sym("r0", n_rk), ca.SX.sym("r1", n_rk), ca.SX.sym("rm", n_rk)
    t0, h = ca.SX.sym("t0"), ca.SX.sym("h")
    start, end = s.node(z0, r0, t0), s.node(z1, r1, t0 + h)
    n, nf = part.num_states, len(part.free_inputs)
    r_mid = s.inputs(0.5 * (z0[n : n + nf] + z1[n : n + nf]), rm)
    view = IntervalView(start, end, extra, r_mid, t0, h)
    g = scheme.interval_defects(s.F(F), view)
    w = ca.vertcat(z0, z1, extra, s.pu, s.free_slots)
    d = ca.vertcat(r0, r1, rm, s.pk, t0, h, s.data_slots, s.weights)
    return StencilFunctions.build("interval", w, d, g)


def node_template(part: Partition, scheme: Scheme, F: ca.Function) -> StencilFunctions | None:
    """Defects at one node (schemes with derivative variables): ``w = [node, p_unknown]``."""
    s = _Symbols(part, scheme, "n")
    z = ca.SX.sym("z", s.n_node)
    rk, t = ca.SX.sym("r", len(part.known_inputs)), ca.SX.sym("t")
    g = scheme.node_defects(s.F(F), s.node(z, rk, t))
    if g is None:
        return None
    w = ca.vertcat(z, s.pu, s.free_slots)
    return StencilFunctions.build("node", w, ca.vertcat(rk, s.pk, t, s.data_slots, s.weights), g)


def objective_template(
    part: Partition, scheme: Scheme, terms: Sequence[NodeTerm]
) -> StencilFunctions:
    """Node objective ``sum_terms c_term * phi_term``: ``w = [node, p_unknown, free slots]``.

    Data ``d = [r_known, p_known, t, known slots, weights, data of each term..., c of each
    term..., gn]``; the slots bind the schedule points bracketing the node's phase (a tracked
    output of a gain-scheduled controller). ``gn = 1`` makes the Hessian the Gauss-Newton
    one for least-squares terms (:meth:`AssembledNLP.gauss_newton_hessian`), ``0`` exact.
    """
    s = _Symbols(part, scheme, "o")
    model = part.model
    z = ca.SX.sym("z", s.n_node)
    rk, t = ca.SX.sym("r", len(part.known_inputs)), ca.SX.sym("t")
    nv = s.node(z, rk, t)
    # Costs may use x' only where the scheme carries derivative variables at the nodes;
    # Problem refuses such costs for other schemes, so the NaN placeholder never reaches a value.
    xdot = nv.v if nv.v is not None else ca.SX(model.num_states, 1) * float("nan")
    leaves = _leaves(model, xdot, nv.x, nv.r, s.p, t)
    leaves.update(s.slot_leaves)
    data_syms, factors = [], []
    total = ca.SX(0)
    w = ca.vertcat(z, s.pu, s.free_slots)
    # data switch gn: 0 -> the exact Hessian, 1 -> least-squares terms by their Gauss-Newton
    # part 2 c J^T diag(weight) J (positive semidefinite; no residual-weighted curvature)
    gn = ca.SX.sym("gn")
    curvature = ca.SX(w.numel(), w.numel())
    for term in terms:
        dsym = ca.SX.sym("d", len(term.data_symbols))
        leaves.update(zip(term.data_symbols, _entries(dsym), strict=True))
        c = ca.SX.sym("c")
        (phi,) = sympy_to_casadi([term.expr], leaves)
        total = total + c * phi
        data_syms.append(dsym)
        factors.append(c)
        if term.least_squares:
            pieces = sympy_to_casadi([e for pair in term.least_squares for e in pair], leaves)
            r, weight = ca.vertcat(*pieces[0::2]), ca.vertcat(*pieces[1::2])
            J = ca.jacobian(r, w)
            gauss_newton = 2.0 * c * ca.mtimes(J.T, ca.mtimes(ca.diag(weight), J))
            curvature = curvature + gn * (gauss_newton - ca.hessian(c * phi, w)[0])
    d = ca.vertcat(rk, s.pk, t, s.data_slots, s.weights, *data_syms, *factors, gn)
    return StencilFunctions.build("objective", w, d, total, curvature)


def instance_template(
    part: Partition,
    exprs: Sequence[sm.Expr],
    variables: Sequence[sm.Basic],
) -> StencilFunctions:
    """Instance constraints in ``w = [variables..., p_unknown]``, data ``d = p_known``.

    ``variables`` are the placeholder symbols that stand for ``x_j(t_k)`` values.
    """
    s = _Symbols(part, _NoScheme(), "c")
    v = ca.SX.sym("v", len(variables))
    leaves: dict[sm.Basic, ca.SX] = dict(zip(variables, _entries(v), strict=True))
    leaves.update(zip(part.model.parameters, _entries(s.p), strict=True))
    g = ca.vertcat(*sympy_to_casadi(exprs, leaves))
    return StencilFunctions.build("instance", ca.vertcat(v, s.pu), s.pk, g)


class _NoScheme(Scheme):
    order = 0

    def interval_defects(self, F, iv):  # type: ignore[no-untyped-def]  # pragma: no cover
        raise NotImplementedError


def row_names(model: Model, scheme: Scheme, count: int, item: str) -> tuple[str, ...]:
    """Readable names of one item's defect rows (best effort by the model's equations)."""
    eq = [f"equation {i} ({name_of(x)}')" for i, x in enumerate(model.states)]
    if count == len(eq):
        return tuple(f"{scheme.name} {item} defect, {e}" for e in eq)
    return tuple(f"{scheme.name} {item} defect {i}" for i in range(count))
