"""The interface every collocation scheme implements, and the time grid.

A scheme turns the model residual ``F(x', x, r, t)`` into the defects of one interval
(and, for schemes with derivative variables, of one node). Assembly replicates these
templates over the grid; nothing outside a scheme's own file knows which scheme it is.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar

import casadi as ca
import numpy as np

#: ``F(xdot, x, r, t) -> residual`` with the parameters already bound.
Residual = Callable[[ca.SX, ca.SX, ca.SX, ca.SX], ca.SX]


@dataclass(frozen=True)
class NodeView:
    """Symbolic values at one node: state ``x``, its derivative variable ``v``, inputs ``r``."""

    x: ca.SX
    v: ca.SX | None
    r: ca.SX
    t: ca.SX


@dataclass(frozen=True)
class IntervalView:
    """Symbolic values on one interval ``[t0, t0 + h]``.

    ``start``/``end`` are the nodes, ``extra`` the scheme's own interval variables
    (empty when it has none), ``r_mid`` the inputs at the interval midpoint.
    """

    start: NodeView
    end: NodeView
    extra: ca.SX
    r_mid: ca.SX
    t0: ca.SX
    h: ca.SX


class Scheme(ABC):
    """A collocation scheme.

    Subclasses set :attr:`order` (the global order of accuracy of the states),
    :attr:`node_derivatives` (whether each node carries derivative variables ``v = x'``)
    and implement :meth:`interval_defects`; schemes with derivative variables also
    implement :meth:`node_defects`, and schemes with variables inside the interval return
    their count from :meth:`num_interval_variables`.
    """

    order: ClassVar[int]
    node_derivatives: ClassVar[bool] = False
    #: Where in the interval (fraction of h) the interval defects evaluate the residual;
    #: None when they do not evaluate it at one place. Scheduled parameters are bracketed
    #: there (at the midpoint when None).
    interval_evaluation: ClassVar[float | None] = None
    #: Whether the node values satisfy the model residual with the scheme's own rates (the
    #: nodes are where a solution's states, inputs and forces are dynamically consistent);
    #: False when the dynamics hold between the nodes only (the midpoint rule).
    dynamics_at_nodes: ClassVar[bool] = False

    def num_interval_variables(self, num_states: int) -> int:
        """Number of extra variables the scheme places inside each interval."""
        return 0

    def interval_variable_names(self, state_names: list[str]) -> list[str]:
        """Names of the interval variables, for layouts and error messages."""
        return [f"extra{j}" for j in range(self.num_interval_variables(len(state_names)))]

    def interval_guess(self, states: np.ndarray, grid: TimeGrid) -> np.ndarray:
        """Initial values of the interval variables from node state guesses ``(N, n)``."""
        return np.zeros((grid.num_nodes - 1, self.num_interval_variables(states.shape[1])))

    @abstractmethod
    def interval_defects(self, F: Residual, iv: IntervalView) -> ca.SX:
        """Defects of one interval (a column SX), zero when the scheme's relation holds."""

    def node_defects(self, F: Residual, nv: NodeView) -> ca.SX | None:
        """Defects at one node, or ``None`` for schemes without node equations."""
        return None

    @property
    def name(self) -> str:
        """The class name, used in records and cache keys."""
        return type(self).__name__

    def __repr__(self) -> str:
        return f"{self.name}()"

    def __eq__(self, other: object) -> bool:
        return type(self) is type(other)

    def __hash__(self) -> int:
        return hash(type(self))


@dataclass(frozen=True)
class TimeGrid:
    """Strictly increasing collocation times ``t_0 < t_1 < ... < t_{N-1}``."""

    times: np.ndarray

    def __post_init__(self) -> None:
        t = np.asarray(self.times, dtype=float)
        if t.ndim != 1 or t.size < 2:
            raise ValueError(
                f"times: expected a 1-D array of at least 2 times, found shape {t.shape}"
            )
        if not np.all(np.isfinite(t)):
            raise ValueError("times: expected finite values, found NaN or inf")
        steps = np.diff(t)
        if np.any(steps <= 0):
            i = int(np.argmax(steps <= 0))
            raise ValueError(
                f"times: expected strictly increasing values, found t[{i}]={float(t[i])!r} "
                f"followed by t[{i + 1}]={float(t[i + 1])!r}"
            )
        object.__setattr__(self, "times", t)

    @classmethod
    def uniform(cls, duration: float, num_nodes: int, start: float = 0.0) -> TimeGrid:
        """``num_nodes`` equally spaced times over ``[start, start + duration]``."""
        if not duration > 0:
            raise ValueError(f"duration: expected a positive number, found {duration!r}")
        if num_nodes < 2:
            raise ValueError(f"num_nodes: expected at least 2, found {num_nodes!r}")
        return cls(np.linspace(start, start + duration, num_nodes))

    @property
    def num_nodes(self) -> int:
        """``N``."""
        return int(self.times.size)

    @property
    def steps(self) -> np.ndarray:
        """Interval lengths ``h_k`` (length ``N - 1``)."""
        return np.diff(self.times)

    def midpoint_values(self, values: np.ndarray) -> np.ndarray:
        """Values at interval midpoints from node values, to fourth order on smooth data.

        Uses the four nodes around each interval (cubic Lagrange interpolation, one-sided
        at the ends) so that data interpolation does not limit Hermite-Simpson's order.

        Parameters
        ----------
        values : ndarray, shape (N,) or (N, m)

        Returns
        -------
        ndarray, shape (N - 1,) or (N - 1, m)
        """
        v = np.asarray(values, dtype=float)
        t = self.times
        n = t.size
        if n < 4:
            return 0.5 * (v[:-1] + v[1:])
        k = np.arange(n - 1)
        first = np.clip(k - 1, 0, n - 4)
        idx = first[:, None] + np.arange(4)[None, :]
        tm = 0.5 * (t[:-1] + t[1:])
        tt = t[idx]
        weights = np.ones((n - 1, 4))
        for j in range(4):
            for m in range(4):
                if m != j:
                    weights[:, j] *= (tm - tt[:, m]) / (tt[:, j] - tt[:, m])
        if v.ndim == 1:
            return np.einsum("kj,kj->k", weights, v[idx])
        return np.einsum("kj,kjm->km", weights, v[idx])
