"""The result of a solve: trajectories, parameters and solver statistics, as data."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
import sympy as sm

from colloc.model.symbols import name_of
from colloc.nlp.residuals import systematic_misfit
from colloc.solve.status import SolveStatus

if TYPE_CHECKING:
    import pandas as pd

    from colloc.nlp.problem import Problem
    from colloc.solve.result import SolveResult


@dataclass
class Solution:
    """Trajectories, parameters and statistics of a solved :class:`colloc.Problem`.

    Attributes
    ----------
    times : ndarray
        Node times.
    trajectories : dict
        Symbol -> values at the nodes, for states, free inputs and known inputs.
    parameters : dict
        Parameter symbol -> value: the identified unknowns and the known values.
    unknown_parameters : tuple
        The symbols that were estimated.
    status : SolveStatus
        The solver's outcome, with what the answer depends on beyond it:
        ``status.at_bounds`` (parameters that ended at a bound) and ``status.notes`` (a
        watchdog's fallback; tracked signals whose residuals are systematic, not noise,
        as a worse local optimum or an unmodelled disturbance leaves them). Both are in
        ``str(status)`` and ``stats["message"]``.
    stats : SolveStats
        A dict: ``iterations``, ``objective``, ``constraint_violation``, ``status``,
        ``message``, ``hint``, ``build_time`` (the problem's construction: derivation or cache
        load and assembly, not Python's imports nor the model's own derivation by SymPy
        mechanics), ``times`` (``derive``, ``build``, ``solve``), ``solve_time``,
        ``cache_hit``, ``ipopt_log``, ``history``, ...; printed, the log and the history are
        summarised (the values are whole).
    z : ndarray
        The free vector at the solution.
    """

    times: np.ndarray
    trajectories: dict[sm.Basic, np.ndarray]
    parameters: dict[sm.Symbol, float]
    unknown_parameters: tuple[sm.Symbol, ...]
    status: SolveStatus
    stats: dict[str, Any]
    z: np.ndarray
    multipliers: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0))

    @classmethod
    def from_result(cls, problem: Problem, result: SolveResult) -> Solution:
        """Unpack an :class:`SolveResult` with the problem's layout."""
        lay = problem.layout
        X = lay.node_matrix(result.x)
        node_funcs = list(problem.model.states) + list(problem.partition.free_inputs)
        traj: dict[sm.Basic, np.ndarray] = {s: X[:, j].copy() for j, s in enumerate(node_funcs)}
        traj.update({r: v.copy() for r, v in problem.known_trajectories.items()})
        params: dict[sm.Symbol, float] = dict(problem.known_parameters)
        est = result.x[lay.parameter_offset :]
        params.update(zip(problem.partition.unknown_parameters, map(float, est), strict=True))
        status = replace(
            result.status,
            at_bounds=_at_bounds(problem, est),
            notes=result.status.notes + tuple(systematic_misfit(problem, result.x)),
        )
        stats = {
            "status": result.status.name,
            "status_code": result.status.code,
            "success": result.status.success,
            "message": str(status),
            "at_bounds": list(status.at_bounds),
            "hint": result.status.hint,
            "iterations": result.iterations,
            "objective": result.objective,
            "constraint_violation": result.constraint_violation,
            "build_time": problem.build_time,
            "solve_time": result.solve_time,
            # derive: SymPy -> CasADi translation and differentiation (or the cache load);
            # build: the rest of the problem's construction (layout, index arrays, data).
            "times": {
                "derive": problem.derive_time,
                "build": problem.build_time - problem.derive_time,
                "solve": result.solve_time,
            },
            "cache_hit": problem.cache_hit,
            "num_variables": lay.num_variables,
            "num_constraints": lay.num_constraints,
            "nnz_jacobian": problem.nlp.nnz_jacobian,
            "nnz_hessian": problem.nlp.nnz_hessian,
            "scheme": problem.scheme.name,
            "ipopt_options": result.options,
            "history": result.history,
            "ipopt_log": result.log,
        }
        return cls(
            problem.grid.times.copy(),
            traj,
            params,
            problem.partition.unknown_parameters,
            status,
            SolveStats(stats),
            result.x.copy(),
            result.multipliers,
        )

    @property
    def success(self) -> bool:
        """Whether IPOPT reported an optimum."""
        return self.status.success

    def to_pandas(self) -> pd.DataFrame:
        """Trajectories as a DataFrame indexed by time, one column per symbol name."""
        import pandas as pd  # pandas only for who asks for frames

        data = {name_of(s): v for s, v in self.trajectories.items()}
        return pd.DataFrame(data, index=pd.Index(self.times, name="time"))

    def parameters_frame(self) -> pd.DataFrame:
        """Parameters as a DataFrame: name, value, whether estimated."""
        import pandas as pd

        return pd.DataFrame(
            {
                "name": [name_of(p) for p in self.parameters],
                "value": list(self.parameters.values()),
                "estimated": [p in self.unknown_parameters for p in self.parameters],
            }
        )

    def __repr__(self) -> str:
        return (
            f"Solution(status={self.status.name}, iterations={self.stats['iterations']}, "
            f"objective={self.stats['objective']:.6g}, "
            f"unknown parameters={len(self.unknown_parameters)})"
        )


class SolveStats(dict):  # type: ignore[type-arg]
    """A solve's statistics: a plain dict whose printed form summarises the IPOPT log and the
    iteration history instead of dumping them (``stats["ipopt_log"]`` is the whole log)."""

    def __repr__(self) -> str:
        shown = {}
        for key, value in self.items():
            if key == "ipopt_log" and isinstance(value, str):
                shown[key] = _Elided(f"<IPOPT log: {value.count(chr(10)) + 1} lines>")
            elif key == "history" and isinstance(value, list | tuple):
                shown[key] = _Elided(f"<{len(value)} iterations>")
            else:
                shown[key] = value
        return repr(shown)

    __str__ = __repr__


class _Elided(str):
    """A placeholder printed without quotes."""

    def __repr__(self) -> str:
        return str(self)


def _at_bounds(problem: Problem, estimates: np.ndarray) -> tuple[str, ...]:
    """Names of the unknown parameters within ``1e-6 (1 + |bound|)`` of a finite bound."""
    lo, hi = problem.variable_bounds()
    offset = problem.layout.parameter_offset
    lo, hi = lo[offset:], hi[offset:]
    near = np.zeros(estimates.shape, bool)
    for bound in (lo, hi):
        finite = np.abs(bound) < 1e19  # unbounded is +-1e20
        near[finite] |= np.abs(estimates[finite] - bound[finite]) <= 1e-6 * (
            1.0 + np.abs(bound[finite])
        )
    return tuple(
        name_of(p)
        for p, flag in zip(problem.partition.unknown_parameters, near, strict=True)
        if flag
    )
