"""Place the templates on the grid: global indices and data of every interval and node.

All arrays are item-major ``(count, size)``. Scheduled parameters are bound per item to
the two schedule points that bracket the phase where the item evaluates the residual.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import sympy as sm

from colloc.nlp.assembly import AssembledNLP, Placement
from colloc.nlp.layout import ConstraintBlock, Layout
from colloc.nlp.objective import NodeTerm
from colloc.nlp.templates import Partition, row_names
from colloc.numeric.stencil import StencilFunctions
from colloc.transcription.base import Scheme, TimeGrid
from colloc.transcription.interpolation import CubicInterpolation, Interpolation


@dataclass(frozen=True)
class GridData:
    """What changes with a new data set: known trajectories and parameter values.

    ``interpolations`` says how each known trajectory is evaluated between the nodes
    (cubic where it names none).
    """

    known_trajectories: Mapping[sm.Basic, np.ndarray]
    known_parameters: Mapping[sm.Symbol, float]
    interpolations: Mapping[sm.Basic, Interpolation] = field(default_factory=dict)


def _slots(
    part: Partition,
    lay: Layout,
    data: GridData,
    phase_at: Mapping[sm.Basic, np.ndarray],
    count: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Free-slot global indices and slot data (known slots, then weights) per item."""
    unknown_pos = {p: lay.parameter_offset + i for i, p in enumerate(part.unknown_parameters)}
    free, known, weights = [], [], []
    for sched, is_unknown in zip(part.model.schedules, part.schedule_is_unknown, strict=True):
        a, b, w = sched.bracket(phase_at[sched.phase])
        if is_unknown:
            pos = np.array([[unknown_pos[p] for p in point] for point in sched.points])
            free += [pos[a], pos[b]]
        else:
            vals = np.array(
                [[data.known_parameters[p] for p in point] for point in sched.points], float
            )
            known += [vals[a], vals[b]]
        weights.append(w[:, None])
    idx = np.hstack(free) if free else np.zeros((count, 0), np.int64)
    dat = np.hstack(known + weights) if known or weights else np.zeros((count, 0))
    return idx, dat


def assemble(
    part: Partition,
    scheme: Scheme,
    grid: TimeGrid,
    lay: Layout,
    templates: Mapping[str, StencilFunctions | None],
    node_terms: Sequence[NodeTerm],
    ic_locs: Sequence[tuple[int, int]],
    data: GridData,
) -> AssembledNLP:
    """Build every placement and the callbacks IPOPT uses; resets ``lay.blocks``."""
    lay.blocks.clear()
    N = grid.num_nodes
    n_nv, n_iv = lay.num_node_variables, lay.num_interval_variables
    unknown_pos = {p: lay.parameter_offset + i for i, p in enumerate(part.unknown_parameters)}
    plain = np.array([unknown_pos[p] for p in part.plain_unknown], np.int64)
    node_idx = n_nv * np.arange(N)[:, None] + np.arange(n_nv)[None, :]
    R = np.column_stack(
        [data.known_trajectories[r] for r in part.known_inputs] or [np.zeros((N, 0))]
    )
    cubic = CubicInterpolation()
    Rm = np.column_stack(
        [
            data.interpolations.get(r, cubic).midpoint_values(grid, data.known_trajectories[r])
            for r in part.known_inputs
        ]
        or [np.zeros((N - 1, 0))]
    )
    pk = np.array([data.known_parameters[p] for p in part.plain_known], float)
    t, h = grid.times, grid.steps
    fraction = 0.5 if scheme.interval_evaluation is None else scheme.interval_evaluation
    phases = {s.phase: data.known_trajectories[s.phase] for s in part.model.schedules}
    at_interval = {k: v[:-1] + fraction * np.diff(v) for k, v in phases.items()}
    slot_i, slot_di = _slots(part, lay, data, at_interval, N - 1)
    slot_n, slot_dn = _slots(part, lay, data, phases, N)

    interval_index = np.hstack(
        [
            node_idx[:-1],
            node_idx[1:],
            lay.interval_offset + n_iv * np.arange(N - 1)[:, None] + np.arange(n_iv)[None, :],
            np.broadcast_to(plain, (N - 1, plain.size)),
            slot_i,
        ]
    )
    interval_data = np.hstack(
        [
            R[:-1],
            R[1:],
            Rm,
            np.broadcast_to(pk, (N - 1, pk.size)),
            t[:-1, None],
            h[:, None],
            slot_di,
        ]
    )
    node_plain = np.hstack([node_idx, np.broadcast_to(plain, (N, plain.size))])
    node_data = np.hstack([R, np.broadcast_to(pk, (N, pk.size)), t[:, None]])

    placements = []
    fi = templates["interval"]
    assert fi is not None
    blk = lay.add_block(
        ConstraintBlock(
            "interval",
            fi.num_outputs,
            N - 1,
            "interval",
            row_names(part.model, scheme, fi.num_outputs, "interval"),
        )
    )
    placements.append(Placement(fi, interval_index, interval_data, blk.offset))
    fn = templates.get("node")
    if fn is not None:
        blk = lay.add_block(
            ConstraintBlock(
                "node",
                fn.num_outputs,
                N,
                "node",
                row_names(part.model, scheme, fn.num_outputs, "node"),
            )
        )
        placements.append(
            Placement(
                fn, np.hstack([node_plain, slot_n]), np.hstack([node_data, slot_dn]), blk.offset
            )
        )
    fc = templates.get("instance")
    if fc is not None:
        blk = lay.add_block(ConstraintBlock("instance", fc.num_outputs, 1, "instance"))
        idx = np.array([k * n_nv + j for k, j in ic_locs] + list(plain), np.int64)[None, :]
        placements.append(Placement(fc, idx, pk[None, :], blk.offset))
    objective = None
    fo = templates.get("objective")
    if node_terms and fo is not None:
        extra = [term.data for term in node_terms] + [term.factors[:, None] for term in node_terms]
        exact = np.zeros((N, 1))  # the Gauss-Newton switch, off: IPOPT's exact Hessian
        objective = Placement(
            fo, np.hstack([node_plain, slot_n]), np.hstack([node_data, slot_dn, *extra, exact])
        )
    return AssembledNLP(lay.num_variables, placements, objective)
