"""The NLP in scaled variables ``z = s * zs``: what IPOPT sees when variables are scaled.

IPOPT's own gradient-based scaling acts on the objective and constraints; the variables it
leaves as they are, so a gain of 1e3 and one of 1e-1 share one step-size scale and one
barrier. Solving in ``zs = z / s`` with ``s`` each variable's typical magnitude puts them on
one scale. Values and constraints are unchanged; the gradient, the Jacobian's columns and
the Hessian's rows and columns are multiplied by ``s``.
"""

from __future__ import annotations

import numpy as np

from colloc.solve.result import NLP


class ScaledNLP:
    """``nlp`` in the variables ``zs = z / scale`` (an :class:`NLP` itself).

    Parameters
    ----------
    nlp : NLP
    scale : ndarray, shape (n,)
        Positive typical magnitude of each variable (1 for those not scaled).
    """

    def __init__(self, nlp: NLP, scale: np.ndarray) -> None:
        s = np.asarray(scale, dtype=float)
        if s.shape != (nlp.n,) or not np.all(np.isfinite(s) & (s > 0)):
            raise ValueError(f"scale: expected {nlp.n} positive finite values, found {s.shape}")
        self.nlp, self.scale = nlp, s
        self.n, self.m = nlp.n, nlp.m
        _, jc = nlp.jacobianstructure()
        hr, hc = nlp.hessianstructure()
        self._jac_factor = s[jc]
        self._hess_factor = s[hr] * s[hc]

    def unscale(self, zs: np.ndarray) -> np.ndarray:
        """``z`` from ``zs``."""
        return self.scale * zs

    def objective(self, zs: np.ndarray) -> float:  # noqa: D102
        return self.nlp.objective(self.scale * zs)

    def gradient(self, zs: np.ndarray) -> np.ndarray:  # noqa: D102
        return self.scale * self.nlp.gradient(self.scale * zs)

    def constraints(self, zs: np.ndarray) -> np.ndarray:  # noqa: D102
        return self.nlp.constraints(self.scale * zs)

    def jacobian(self, zs: np.ndarray) -> np.ndarray:  # noqa: D102
        return self._jac_factor * self.nlp.jacobian(self.scale * zs)

    def jacobianstructure(self) -> tuple[np.ndarray, np.ndarray]:  # noqa: D102
        return self.nlp.jacobianstructure()

    def hessian(self, zs: np.ndarray, lagrange: np.ndarray, obj_factor: float) -> np.ndarray:  # noqa: D102
        return self._hess_factor * self.nlp.hessian(self.scale * zs, lagrange, obj_factor)

    def hessianstructure(self) -> tuple[np.ndarray, np.ndarray]:  # noqa: D102
        return self.nlp.hessianstructure()

    def gauss_newton_hessian(self, zs: np.ndarray) -> np.ndarray:  # noqa: D102
        return self._hess_factor * self.nlp.gauss_newton_hessian(self.scale * zs)
