"""What a solver takes (the NLP's callbacks) and returns (iterate, status, history, log)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from colloc.solve.status import SolveStatus


class Evaluations(Protocol):
    """Values, sparse derivatives and their patterns (lower-triangle Hessian): what IPOPT calls."""

    def objective(self, z: np.ndarray) -> float: ...  # noqa: D102
    def gradient(self, z: np.ndarray) -> np.ndarray: ...  # noqa: D102
    def constraints(self, z: np.ndarray) -> np.ndarray: ...  # noqa: D102
    def jacobian(self, z: np.ndarray) -> np.ndarray: ...  # noqa: D102
    def jacobianstructure(self) -> tuple[np.ndarray, np.ndarray]: ...  # noqa: D102
    def hessian(self, z: np.ndarray, lagrange: np.ndarray, obj_factor: float) -> np.ndarray: ...  # noqa: D102
    def hessianstructure(self) -> tuple[np.ndarray, np.ndarray]: ...  # noqa: D102


class NLP(Evaluations, Protocol):
    """The callbacks of an assembled problem, its sizes and its Gauss-Newton Hessian."""

    n: int
    m: int

    def gauss_newton_hessian(self, z: np.ndarray) -> np.ndarray: ...  # noqa: D102


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
