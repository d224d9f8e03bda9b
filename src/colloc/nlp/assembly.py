"""Scatter per-item values and derivatives into the global NLP vectors and sparse patterns.

Each :class:`Placement` is one template placed over ``count`` items with a table of the
global index of every local free variable. All index arithmetic is precomputed here, once;
the evaluation path is one vectorised CasADi call per template plus NumPy gathers and one
``bincount`` for the Hessian (whose entries overlap where items share nodes or parameters).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from colloc.numeric.stencil import MappedStencil, StencilFunctions


@dataclass
class Placement:
    """A template placed on the grid.

    Attributes
    ----------
    functions : StencilFunctions
    index : ndarray of int, shape (count, num_free)
        Global free-vector index of every local variable of every item.
    data : ndarray, shape (count, num_data)
        Data of every item.
    row_offset : int
        First constraint row (constraint placements only).
    """

    functions: StencilFunctions
    index: np.ndarray
    data: np.ndarray
    row_offset: int = 0

    def __post_init__(self) -> None:
        self.index = np.ascontiguousarray(self.index, dtype=np.int64)
        self.data = np.ascontiguousarray(self.data, dtype=float)
        self.count = int(self.index.shape[0])
        self.mapped = MappedStencil(self.functions, self.count)
        f = self.functions
        k = np.arange(self.count)
        n_out = f.num_outputs
        # nonzero e of item k sits at flat position e + nnz * k (item-major)
        self.jac_rows = (self.row_offset + n_out * k[:, None] + f.jac_rows[None, :]).ravel()
        self.jac_cols = self.index[:, f.jac_cols].ravel()
        hr = self.index[:, f.hess_rows].ravel()
        hc = self.index[:, f.hess_cols].ravel()
        self.hess_rows, self.hess_cols = np.maximum(hr, hc), np.minimum(hr, hc)

    def gather(self, z: np.ndarray) -> np.ndarray:
        """Local free variables of every item, shape ``(count, num_free)``."""
        return z[self.index]


class AssembledNLP:
    """The NLP callbacks IPOPT needs, assembled from placements.

    Parameters
    ----------
    num_variables : int
    constraints : list of Placement
        In constraint-row order.
    objective : Placement or None
        Node objective (scalar per item).
    """

    def __init__(
        self, num_variables: int, constraints: list[Placement], objective: Placement | None
    ) -> None:
        self.n = num_variables
        self.constraint_placements = constraints
        self.objective_placement = objective
        self.m = sum(p.count * p.functions.num_outputs for p in constraints)
        self._jac_rows = np.concatenate([p.jac_rows for p in constraints] or [np.zeros(0, int)])
        self._jac_cols = np.concatenate([p.jac_cols for p in constraints] or [np.zeros(0, int)])
        everything = list(constraints) + ([objective] if objective is not None else [])
        rows = np.concatenate([p.hess_rows for p in everything] or [np.zeros(0, int)])
        cols = np.concatenate([p.hess_cols for p in everything] or [np.zeros(0, int)])
        keys = rows.astype(np.int64) * self.n + cols
        unique, self._hess_inverse = np.unique(keys, return_inverse=True)
        self._hess_rows, self._hess_cols = np.divmod(unique, self.n)
        self._num_hess = unique.size

    # -------------------------------------------------------------------- objective
    def objective(self, z: np.ndarray) -> float:
        """Objective value."""
        p = self.objective_placement
        if p is None:
            return 0.0
        return float(p.mapped.values(p.gather(z), p.data).sum())

    def gradient(self, z: np.ndarray) -> np.ndarray:
        """Objective gradient."""
        p = self.objective_placement
        if p is None:
            return np.zeros(self.n)
        vals = p.mapped.jacobian(p.gather(z), p.data).ravel()
        return np.bincount(p.jac_cols, weights=vals, minlength=self.n)

    # -------------------------------------------------------------------- constraints
    def constraints(self, z: np.ndarray) -> np.ndarray:
        """Constraint values, in row order."""
        if not self.constraint_placements:
            return np.zeros(0)
        return np.concatenate(
            [p.mapped.values(p.gather(z), p.data).ravel() for p in self.constraint_placements]
        )

    def jacobianstructure(self) -> tuple[np.ndarray, np.ndarray]:
        """Row and column of every Jacobian nonzero."""
        return self._jac_rows, self._jac_cols

    def jacobian(self, z: np.ndarray) -> np.ndarray:
        """Jacobian nonzeros in the order of :meth:`jacobianstructure`."""
        if not self.constraint_placements:
            return np.zeros(0)
        return np.concatenate(
            [p.mapped.jacobian(p.gather(z), p.data).ravel() for p in self.constraint_placements]
        )

    # -------------------------------------------------------------------- Hessian
    def hessianstructure(self) -> tuple[np.ndarray, np.ndarray]:
        """Row and column of every nonzero of the lower triangle of the Lagrangian Hessian."""
        return self._hess_rows, self._hess_cols

    def hessian(self, z: np.ndarray, lagrange: np.ndarray, obj_factor: float) -> np.ndarray:
        """Lagrangian-Hessian nonzeros in the order of :meth:`hessianstructure`."""
        parts = []
        for p in self.constraint_placements:
            n_out = p.functions.num_outputs
            mu = lagrange[p.row_offset : p.row_offset + n_out * p.count]
            parts.append(p.mapped.hessian(p.gather(z), p.data, mu).ravel())
        o = self.objective_placement
        if o is not None:
            mu = np.full(o.count, float(obj_factor))
            parts.append(o.mapped.hessian(o.gather(z), o.data, mu).ravel())
        if not parts:
            return np.zeros(0)
        return np.bincount(
            self._hess_inverse, weights=np.concatenate(parts), minlength=self._num_hess
        )

    def gauss_newton_hessian(self, z: np.ndarray) -> np.ndarray:
        """The objective's Hessian with each least-squares term (tracking) replaced by its
        Gauss-Newton part ``2 J^T W J``, in the order of :meth:`hessianstructure`.

        Positive semidefinite for tracking objectives, whatever the residuals; the
        constraints' curvature is left out.
        """
        o = self.objective_placement
        if o is None:
            return np.zeros(self._num_hess)
        data = o.data.copy()
        data[:, -1] = 1.0
        vals = o.mapped.hessian(o.gather(z), data, np.ones(o.count)).ravel()
        offset = sum(p.hess_rows.size for p in self.constraint_placements)
        return np.bincount(self._hess_inverse[offset:], weights=vals, minlength=self._num_hess)

    @property
    def nnz_jacobian(self) -> int:
        """Number of Jacobian nonzeros."""
        return int(self._jac_rows.size)

    @property
    def nnz_hessian(self) -> int:
        """Number of (lower-triangle) Hessian nonzeros after merging overlaps."""
        return int(self._num_hess)
