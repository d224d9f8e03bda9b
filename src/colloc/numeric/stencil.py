"""Derivatives of one item (an interval or a node), evaluated over many items at once.

An item's equations ``g(w, d)`` depend on a few free variables ``w`` (the stencil: the
states at its nodes, parameters) and on data ``d``. The exact Jacobian ``dg/dw`` and the
lower triangle of the Hessian of ``mu . g`` are differentiated once by CasADi for one
item and evaluated over all items in one vectorised call, so the cost of building them
does not grow with the number of items.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from colloc.numeric.casadi_payload import plain_function_problem

#: The functions of a stencil, in the order they are stored.
FUNCTION_FIELDS = ("values", "jacobian", "hessian")


def _nonzeros(expr: ca.SX) -> ca.SX:
    return expr.get_nz(False, ca.Slice())


@dataclass(frozen=True)
class StencilFunctions:
    """Values, Jacobian and Lagrangian-Hessian nonzeros of one item.

    Attributes
    ----------
    values : casadi.Function
        ``(w, d) -> g``.
    jacobian : casadi.Function
        ``(w, d) -> nonzeros of dg/dw`` in the order of ``jac_rows``/``jac_cols``.
    hessian : casadi.Function
        ``(w, d, mu) -> nonzeros of the lower triangle of d2(mu . g)/dw2``.
    jac_rows, jac_cols, hess_rows, hess_cols : ndarray of int
        Local sparsity (``hess_rows >= hess_cols``).
    """

    values: ca.Function
    jacobian: ca.Function
    hessian: ca.Function
    jac_rows: np.ndarray
    jac_cols: np.ndarray
    hess_rows: np.ndarray
    hess_cols: np.ndarray

    @classmethod
    def build(
        cls, name: str, w: ca.SX, d: ca.SX, g: ca.SX, curvature: ca.SX | None = None
    ) -> StencilFunctions:
        """Differentiate ``g(w, d)`` with respect to ``w``.

        Parameters
        ----------
        name : str
            Base name of the CasADi functions.
        w, d : casadi.SX
            Column symbols of the free variables and the data.
        g : casadi.SX
            Column expression of the item's equations (or a scalar objective).
        curvature : casadi.SX, optional
            For a scalar ``g``: a symmetric matrix in ``(w, d)`` added to its Hessian (times
            ``mu``), on the exact Hessian's sparsity pattern; e.g. a data switch from a
            least-squares term's exact Hessian to its Gauss-Newton part.
        """
        mu = ca.SX.sym("mu", g.numel())
        jac = ca.jacobian(g, w)
        exact = ca.hessian(ca.dot(mu, g), w)[0]
        if curvature is not None:
            exact = ca.project(exact + mu[0] * curvature, exact.sparsity())
        hess = ca.tril(exact)
        jr, jc = jac.sparsity().get_triplet()
        hr, hc = hess.sparsity().get_triplet()
        # Common-subexpression elimination roughly halves the instructions of the
        # derivative functions of Kane-form equations (measured on the 4-link pendulum).
        return cls(
            ca.Function(f"{name}_g", [w, d], [ca.cse(g)]),
            ca.Function(f"{name}_jac", [w, d], [ca.cse(_nonzeros(jac))]),
            ca.Function(f"{name}_hess", [w, d, mu], [ca.cse(_nonzeros(hess))]),
            np.asarray(jr, dtype=np.int64),
            np.asarray(jc, dtype=np.int64),
            np.asarray(hr, dtype=np.int64),
            np.asarray(hc, dtype=np.int64),
        )

    @property
    def num_outputs(self) -> int:
        """Number of equations per item."""
        return int(self.values.size1_out(0))

    @property
    def num_free(self) -> int:
        """Length of ``w``."""
        return int(self.values.size1_in(0))

    @property
    def num_data(self) -> int:
        """Length of ``d``."""
        return int(self.values.size1_in(1))

    def to_bytes(self) -> dict[str, object]:
        """A plain, pickle-free form for the on-disk cache."""
        return {
            "values": self.values.serialize(),
            "jacobian": self.jacobian.serialize(),
            "hessian": self.hessian.serialize(),
            "jac_rows": self.jac_rows.tolist(),
            "jac_cols": self.jac_cols.tolist(),
            "hess_rows": self.hess_rows.tolist(),
            "hess_cols": self.hess_cols.tolist(),
        }

    @classmethod
    def from_bytes(cls, blob: dict[str, object]) -> StencilFunctions:
        """Inverse of :meth:`to_bytes`.

        Each function is checked to be a plain SX function with JIT off before CasADi
        deserialises it (:func:`colloc.numeric.casadi_payload.plain_function_problem`).

        Raises
        ------
        ValueError
            When a payload holds anything else (it was not written by colloc).
        """
        for field in FUNCTION_FIELDS:
            problem = plain_function_problem(blob.get(field))
            if problem is not None:
                raise ValueError(f"{field}: {problem}")
        values, jacobian, hessian = (ca.Function.deserialize(blob[f]) for f in FUNCTION_FIELDS)
        return cls(
            values,
            jacobian,
            hessian,
            *(
                np.asarray(blob[k], dtype=np.int64)
                for k in ("jac_rows", "jac_cols", "hess_rows", "hess_cols")
            ),
        )


class MappedStencil:
    """:class:`StencilFunctions` evaluated over ``count`` items in one call each.

    Arrays are item-major and C-contiguous, shape ``(count, size)``, which is the
    column-major layout CasADi's mapped functions read and write, so they are bound to
    CasADi's evaluation buffers without any copy or conversion.

    Parameters
    ----------
    functions : StencilFunctions
    count : int
        Number of items.
    parallelization : str
        CasADi map parallelization ("serial" or "thread").
    """

    def __init__(
        self, functions: StencilFunctions, count: int, parallelization: str = "serial"
    ) -> None:
        self.functions = functions
        self.count = count
        threads = 2 if parallelization == "thread" else 1
        self._g = _Bound(functions.values.map(count, parallelization, threads))
        self._j = _Bound(functions.jacobian.map(count, parallelization, threads))
        self._h = _Bound(functions.hessian.map(count, parallelization, threads))

    def values(self, W: np.ndarray, D: np.ndarray) -> np.ndarray:
        """Equations of every item, shape ``(count, num_outputs)``."""
        return self._g(W, D)

    def jacobian(self, W: np.ndarray, D: np.ndarray) -> np.ndarray:
        """Jacobian nonzeros of every item, shape ``(count, nnz)``."""
        return self._j(W, D)

    def hessian(self, W: np.ndarray, D: np.ndarray, MU: np.ndarray) -> np.ndarray:
        """Lagrangian-Hessian nonzeros of every item, shape ``(count, nnz)``."""
        return self._h(W, D, MU)


class _Bound:
    """A CasADi function called through its zero-copy buffer interface."""

    def __init__(self, function: ca.Function) -> None:
        self.function = function
        self.buffer, self.evaluate = function.buffer()
        self.out_shape = (function.size2_out(0), function.size1_out(0))
        self.in_sizes = [function.nnz_in(i) for i in range(function.n_in())]

    def __call__(self, *args: np.ndarray) -> np.ndarray:
        keep = []
        for i, a in enumerate(args):
            arr = np.ascontiguousarray(a, dtype=float)
            if arr.size != self.in_sizes[i]:
                raise ValueError(
                    f"argument {i} of {self.function.name()}: expected {self.in_sizes[i]} "
                    f"values, found {arr.size}"
                )
            keep.append(arr)
            self.buffer.set_arg(i, memoryview(arr))  # type: ignore[call-arg,arg-type]
        out = np.empty(self.out_shape)
        self.buffer.set_res(0, memoryview(out))  # type: ignore[call-arg,arg-type]
        self.evaluate()
        return out
