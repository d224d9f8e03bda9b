"""One NLP made of several, their free vectors laid side by side and some entries shared.

Several trials of one study share the unknown parameters and nothing else: each trial's
problem keeps its own assembled callbacks, and the composite evaluates each at its share of
the whole free vector (an index table per part) and scatters the results back: constraint
rows one part after another, gradients and Hessian entries summed where the parts meet (the
shared parameters). Nothing is re-derived or re-assembled: a part whose data are swapped
(:meth:`colloc.Problem.replace_data`) is evaluated with its new data.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np

from colloc.solve.result import NLP


class _HasNLP(Protocol):
    """Anything holding an assembled NLP (a :class:`colloc.Problem`)."""

    @property
    def nlp(self) -> NLP: ...  # noqa: D102


class CompositeNLP:
    """The NLP callbacks of several parts over one free vector.

    Parameters
    ----------
    parts : sequence
        Objects with an ``nlp`` attribute (read at every call, so swapped data count).
    index : sequence of ndarray of int
        Part ``i``'s free variable ``j`` is entry ``index[i][j]`` of the whole free vector;
        no two entries of one part's table are equal.
    num_variables : int
        Length of the whole free vector; every entry belongs to at least one part.

    Raises
    ------
    ValueError
        When a table has another length than its part's free vector, repeats an entry,
        points outside the whole vector, or an entry belongs to no part.
    """

    def __init__(
        self, parts: Sequence[_HasNLP], index: Sequence[np.ndarray], num_variables: int
    ) -> None:
        if len(parts) != len(index):
            raise ValueError(
                f"index: expected {len(parts)} tables (one per part), found {len(index)}"
            )
        self.parts = tuple(parts)
        self.index = tuple(np.asarray(i, dtype=np.int64) for i in index)
        self.n = int(num_variables)
        covered = np.zeros(self.n, bool)
        for k, (part, idx) in enumerate(zip(self.parts, self.index, strict=True)):
            if idx.shape != (part.nlp.n,):
                raise ValueError(
                    f"index[{k}]: expected {part.nlp.n} entries (the part's free vector), "
                    f"found shape {idx.shape}"
                )
            if idx.size and (idx.min() < 0 or idx.max() >= self.n):
                raise ValueError(f"index[{k}]: entries outside 0..{self.n - 1}")
            if np.unique(idx).size != idx.size:
                raise ValueError(f"index[{k}]: an entry appears twice")
            covered[idx] = True
        if not covered.all():
            raise ValueError(
                f"index: entry {int(np.flatnonzero(~covered)[0])} of the free vector belongs "
                "to no part"
            )
        sizes = [part.nlp.m for part in self.parts]
        self.row_offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        self.m = int(self.row_offsets[-1])
        rows, cols = [], []
        for part, idx, offset in zip(self.parts, self.index, self.row_offsets, strict=False):
            r, c = part.nlp.jacobianstructure()
            rows.append(np.asarray(r, np.int64) + offset)
            cols.append(idx[np.asarray(c, np.int64)])
        self._jac_rows = np.concatenate(rows) if rows else np.zeros(0, np.int64)
        self._jac_cols = np.concatenate(cols) if cols else np.zeros(0, np.int64)
        keys = []
        for part, idx in zip(self.parts, self.index, strict=True):
            r, c = part.nlp.hessianstructure()
            gr, gc = idx[np.asarray(r, np.int64)], idx[np.asarray(c, np.int64)]
            # lower triangle in the whole vector's order too
            keys.append(np.maximum(gr, gc) * self.n + np.minimum(gr, gc))
        every = np.concatenate(keys) if keys else np.zeros(0, np.int64)
        unique, self._hess_inverse = np.unique(every, return_inverse=True)
        self._hess_rows, self._hess_cols = np.divmod(unique, self.n)
        self._num_hess = int(unique.size)

    def split(self, z: np.ndarray) -> list[np.ndarray]:
        """Each part's own free vector, taken from the whole ``z``."""
        z = np.asarray(z, dtype=float)
        return [z[idx] for idx in self.index]

    def split_rows(self, values: np.ndarray) -> list[np.ndarray]:
        """Each part's share of a vector over the constraint rows (e.g. multipliers)."""
        values = np.asarray(values, dtype=float)
        return [
            values[a:b] for a, b in zip(self.row_offsets[:-1], self.row_offsets[1:], strict=True)
        ]

    def objective(self, z: np.ndarray) -> float:
        """Sum of the parts' objectives."""
        return float(
            sum(p.nlp.objective(zi) for p, zi in zip(self.parts, self.split(z), strict=True))
        )

    def gradient(self, z: np.ndarray) -> np.ndarray:
        """Objective gradient: the parts' summed where they share entries."""
        out = np.zeros(self.n)
        for part, idx, zi in zip(self.parts, self.index, self.split(z), strict=True):
            out[idx] += part.nlp.gradient(zi)  # entries of one table are distinct
        return out

    def constraints(self, z: np.ndarray) -> np.ndarray:
        """The parts' constraints, one part after another."""
        values = [p.nlp.constraints(zi) for p, zi in zip(self.parts, self.split(z), strict=True)]
        return np.concatenate(values) if values else np.zeros(0)

    def jacobianstructure(self) -> tuple[np.ndarray, np.ndarray]:
        """Row and column of every Jacobian nonzero."""
        return self._jac_rows, self._jac_cols

    def jacobian(self, z: np.ndarray) -> np.ndarray:
        """Jacobian nonzeros in the order of :meth:`jacobianstructure`."""
        values = [p.nlp.jacobian(zi) for p, zi in zip(self.parts, self.split(z), strict=True)]
        return np.concatenate(values) if values else np.zeros(0)

    def hessianstructure(self) -> tuple[np.ndarray, np.ndarray]:
        """Row and column of every nonzero of the Lagrangian Hessian's lower triangle."""
        return self._hess_rows, self._hess_cols

    def hessian(self, z: np.ndarray, lagrange: np.ndarray, obj_factor: float) -> np.ndarray:
        """Lagrangian-Hessian nonzeros in the order of :meth:`hessianstructure`."""
        values = [
            p.nlp.hessian(zi, mu, obj_factor)
            for p, zi, mu in zip(self.parts, self.split(z), self.split_rows(lagrange), strict=True)
        ]
        return self._merge(values)

    def gauss_newton_hessian(self, z: np.ndarray) -> np.ndarray:
        """The parts' Gauss-Newton objective Hessians, merged like :meth:`hessian`."""
        values = [
            p.nlp.gauss_newton_hessian(zi) for p, zi in zip(self.parts, self.split(z), strict=True)
        ]
        return self._merge(values)

    def _merge(self, values: list[np.ndarray]) -> np.ndarray:
        if not values:
            return np.zeros(0)
        return np.bincount(
            self._hess_inverse, weights=np.concatenate(values), minlength=self._num_hess
        )

    @property
    def nnz_jacobian(self) -> int:
        """Number of Jacobian nonzeros."""
        return int(self._jac_rows.size)

    @property
    def nnz_hessian(self) -> int:
        """Number of (lower-triangle) Hessian nonzeros after merging the shared ones."""
        return self._num_hess
