"""The result of a solve: trajectories, parameters and solver statistics, as data.

A :class:`Solution` holds no problem: :func:`colloc.nlp.problem.solution_from_result` makes
one from a solve's raw result with the problem's layout, and diagnostics are functions over a
problem and a solution (:mod:`colloc.nlp.residuals`, :mod:`colloc.nlp.uncertainty`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import sympy as sm

from colloc.model.symbols import name_of
from colloc.solve.status import SolveStatus

if TYPE_CHECKING:
    import pandas as pd

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

    @classmethod
    def from_result(
        cls,
        result: SolveResult,
        status: SolveStatus,
        build_time: float,
        derive_time: float,
        cache_hit: bool,
        **sizes: Any,
    ) -> SolveStats:
        """The statistics of a solve: its outcome (``status`` with the solution's bounds and
        notes), the problem's build times (``derive``: SymPy to CasADi and differentiation,
        or the cache load; ``build``: the rest of its construction), then ``sizes`` (counts
        and names of what was solved), IPOPT's options, history and log."""
        return cls(
            {
                "status": result.status.name,
                "status_code": result.status.code,
                "success": result.status.success,
                "message": str(status),
                "at_bounds": list(status.at_bounds),
                "hint": result.status.hint,
                "iterations": result.iterations,
                "objective": result.objective,
                "constraint_violation": result.constraint_violation,
                "build_time": build_time,
                "solve_time": result.solve_time,
                "times": {
                    "derive": derive_time,
                    "build": build_time - derive_time,
                    "solve": result.solve_time,
                },
                "cache_hit": cache_hit,
                **sizes,
                "ipopt_options": result.options,
                "history": result.history,
                "ipopt_log": result.log,
            }
        )

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
