"""The KKT matrix of a solved problem with the unknown parameters eliminated.

Shared by the standard errors (:mod:`colloc.nlp.uncertainty`) and the marginal
likelihood's correction (:mod:`colloc.nlp.marginal`): both need ``[K^-1]`` in the
parameters' rows, and the correction also the states' first-order response to the
parameters.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from colloc.nlp.trials import Trials


def hessian_matrix(design: Trials, hessian: np.ndarray) -> sp.csc_matrix:
    """The full symmetric sparse Hessian from its values in ``hessianstructure`` order.

    Parameters
    ----------
    design : Trials
    hessian : ndarray
        Values at the NLP's Hessian structure (one triangle).

    Returns
    -------
    scipy.sparse.csc_matrix, shape (n, n)
    """
    nlp = design.nlp
    hr, hc = nlp.hessianstructure()
    H = sp.coo_matrix((hessian, (hr, hc)), shape=(nlp.n, nlp.n)).tocsc()
    return (H + sp.triu(H.T, k=1)).tocsc()


def constraint_jacobian(design: Trials, z: np.ndarray) -> sp.csc_matrix:
    """The constraints' sparse Jacobian at ``z``.

    Parameters
    ----------
    design : Trials
    z : ndarray, shape (n,)

    Returns
    -------
    scipy.sparse.csc_matrix, shape (m, n)
    """
    nlp = design.nlp
    jr, jc = nlp.jacobianstructure()
    return sp.coo_matrix((nlp.jacobian(z), (jr, jc)), shape=(nlp.m, nlp.n)).tocsc()


def states_kkt(H: sp.spmatrix, C: sp.spmatrix, p0: int) -> sp.csc_matrix:
    """``K_s = [[H_ss, C_s^T], [C_s, 0]]``: the KKT matrix of the free variables before the
    parameters (the first ``p0``) and the constraints.

    Parameters
    ----------
    H : sparse matrix, shape (n, n)
        The full symmetric Hessian.
    C : sparse matrix, shape (m, n)
        The constraints' Jacobian.
    p0 : int
        Where the parameters start in the free vector.

    Returns
    -------
    scipy.sparse.csc_matrix
    """
    Cs = C[:, :p0]
    return sp.bmat([[H[:p0, :p0], Cs.T], [Cs, None]], format="csc")


def eliminate_states(
    design: Trials, z: np.ndarray, hessian: np.ndarray
) -> tuple[int, np.ndarray, np.ndarray]:
    """The states and constraints eliminated from the KKT matrix at ``z``.

    Parameters
    ----------
    design : Trials
    z : ndarray, shape (n,)
    hessian : ndarray
        ``H``'s values in the NLP's Hessian structure.

    Returns
    -------
    p0 : int
        Where the parameters start in the free vector.
    X : ndarray, shape (n_s + m, n_p)
        ``K_s^-1 B`` with ``B = [H_sp; C_p]``.
    S : ndarray, shape (n_p, n_p)
        The parameters' Schur complement ``H_pp - B^T K_s^-1 B``, symmetrised: with the
        Gauss-Newton ``H`` of a likelihood, twice the parameters' Fisher information with
        every other free variable unknown. It may be singular (data that cannot identify
        some parameter).

    Raises
    ------
    ValueError
        When ``K_s`` is singular.
    """
    p0 = design.parameter_offset
    H = hessian_matrix(design, hessian)
    C = constraint_jacobian(design, z)
    Hpp = H[p0:, p0:].toarray()
    B = sp.vstack([H[:p0, p0:], C[:, p0:]]).tocsc()
    try:
        lu = spla.splu(states_kkt(H, C, p0))
    except RuntimeError as exc:
        raise ValueError(
            "the KKT matrix at the solution is singular: the states are not determined by "
            "the data and the dynamics"
        ) from exc
    # A parameter that no state or constraint sees (a schedule point a short window never
    # reaches) has an empty column in B, and so in X: solve for the others only. B stays
    # sparse in the product B^T X (a few per cent of it is filled).
    seen = np.flatnonzero(np.diff(B.indptr) > 0)
    X = np.zeros(B.shape)
    S = Hpp.copy()
    if seen.size:
        B_seen = B[:, seen]
        X[:, seen] = lu.solve(B_seen.toarray())  # K_s's factors are freed after
        S[np.ix_(seen, seen)] -= np.asarray(B_seen.T @ X[:, seen])
    return p0, X, 0.5 * (S + S.T)


class ReducedKKT:
    """The KKT matrix ``K = [[H, C^T], [C, 0]]`` at ``z``, with the parameters eliminated.

    The parameter columns couple every interval, so a direct factorisation of ``K`` fills
    in badly. Without them ``K_s`` (states and constraints only) is banded in time and
    factorises cheaply; the parameter rows of ``K^-1`` are then
    ``S^-1 [-B^T K_s^-1, I]`` with ``B = [H_sp; C_p]`` and the Schur complement
    ``S = H_pp - B^T K_s^-1 B``.

    Parameters
    ----------
    design : Trials
        The problem as trials (a single problem is one trial).
    z : ndarray, shape (n,)
        The free vector (the solution).
    hessian : ndarray
        ``H``'s values in the NLP's Hessian structure (Gauss-Newton or exact).

    Raises
    ------
    ValueError
        When ``K_s`` or the parameters' Schur complement is singular.
    """

    def __init__(self, design: Trials, z: np.ndarray, hessian: np.ndarray) -> None:
        self.p0, self.X, S = eliminate_states(design, z, hessian)
        try:
            self.S_inv = np.linalg.inv(S)
        except np.linalg.LinAlgError as exc:
            raise ValueError(
                "the reduced Hessian of the parameters is singular: some unknown parameters "
                "cannot be identified from these data"
            ) from exc

    def parameter_block(self) -> np.ndarray:
        """Symmetrised ``[K^-1]_pp``."""
        return 0.5 * (self.S_inv + self.S_inv.T)

    def state_response(self) -> np.ndarray:
        """``d z_s / d theta = -[K_s^-1 B]_s``: how the states and other free variables of
        the optimum follow the parameters to first order, shape ``(p0, n_p)``."""
        return -self.X[: self.p0]

    def parameter_columns(self, index: np.ndarray) -> np.ndarray:
        """``[K^-1]_p,i`` for free variables ``i`` (not parameters): ``-S^-1 X_i^T``."""
        return -self.S_inv @ self.X[index].T

    def parameter_rows(self, G: sp.csc_matrix) -> np.ndarray:
        """``[K^-1]_p,: [G; 0]`` for gradient columns ``G`` (free-vector rows).

        ``K_s`` is symmetric, so ``B^T K_s^-1 = X^T`` with ``X = K_s^-1 B`` already solved:
        no further solve, and ``G`` stays sparse.
        """
        G = sp.csc_matrix(G)
        Gs, Gp = G[: self.p0], G[self.p0 :].toarray()
        return self.S_inv @ (Gp - np.asarray((Gs.T @ self.X[: self.p0]).T))
