"""What a solver returns: the iterate, its status, multipliers, history and log."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from colloc.solve.status import SolveStatus


@dataclass
class SolveResult:
    """The raw outcome of a solve (IPOPT's or the Gauss-Newton solver's)."""

    x: np.ndarray
    status: SolveStatus
    objective: float
    constraint_violation: float
    iterations: int
    solve_time: float
    multipliers: np.ndarray
    log: str
    history: list[dict[str, float]] = field(default_factory=list)
    options: dict[str, Any] = field(default_factory=dict)
