"""Standard errors of identified parameters from the KKT system at the optimum.

For an equality-constrained least-squares fit ``min J(z) = sum w (y(z) - y_m)^2`` subject
to ``c(z) = 0``, linearised at the optimum, the covariance of ``z`` is
``2 sigma^2 [K^-1]_zz`` with ``K = [[H, C^T], [C, 0]]``, ``H`` the Hessian of the
Lagrangian and ``C`` the constraint Jacobian; ``sigma^2`` is estimated from the residuals
as ``J* / (num_measurements - num_free)`` where ``num_free = n_z - m`` counts the
parameters and the initial states the constraints leave free. With ``H`` the exact
Hessian this is the reduced-Hessian covariance, which equals Gauss-Newton's for linear
outputs and vanishing multipliers.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import sympy as sm

if TYPE_CHECKING:
    from colloc.nlp.problem import Problem
    from colloc.nlp.solution import Solution


@dataclass(frozen=True)
class ParameterUncertainty:
    """Standard errors and covariance of the unknown parameters.

    Attributes
    ----------
    parameters : tuple of sympy.Symbol
    standard_errors : dict
        Symbol -> standard error.
    covariance : ndarray
        In the order of ``parameters``.
    noise_variance : float
        Estimated ``sigma^2`` per unit tracking weight.
    degrees_of_freedom : int
        ``num_measurements - num_free``.
    """

    parameters: tuple[sm.Symbol, ...]
    standard_errors: dict[sm.Symbol, float]
    covariance: np.ndarray
    noise_variance: float
    degrees_of_freedom: int


def parameter_uncertainty(
    problem: Problem, solution: Solution, num_measurements: int
) -> ParameterUncertainty:
    """Standard errors of ``solution``'s unknown parameters.

    Parameters
    ----------
    problem : Problem
        The problem that was solved (its objective must be a tracking least squares).
    solution : Solution
    num_measurements : int
        Number of measured samples that entered the tracking objective.

    Returns
    -------
    ParameterUncertainty

    Raises
    ------
    ValueError
        When there are no unknown parameters, no more measurements than free quantities,
        or the KKT matrix is singular (unidentifiable parameters).
    """
    nlp, lay = problem.nlp, problem.layout
    q = len(lay.parameter_names)
    if q == 0:
        raise ValueError("problem: has no unknown parameters, so there is nothing to estimate")
    n, m = nlp.n, nlp.m
    dof = num_measurements - (n - m)
    if dof <= 0:
        raise ValueError(
            f"num_measurements: expected more than the {n - m} free quantities, "
            f"found {num_measurements}"
        )
    z = solution.z
    hr, hc = nlp.hessianstructure()
    hv = nlp.hessian(z, solution.multipliers, 1.0)
    H = sp.coo_matrix((hv, (hr, hc)), shape=(n, n)).tocsc()
    H = H + sp.triu(H.T, k=1)
    jr, jc = nlp.jacobianstructure()
    C = sp.coo_matrix((nlp.jacobian(z), (jr, jc)), shape=(m, n)).tocsc()
    block = _parameter_block_of_kkt_inverse(H, C, lay.parameter_offset)
    sigma2 = float(solution.stats["objective"]) / dof
    cov = 2.0 * sigma2 * 0.5 * (block + block.T)
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    params = problem.partition.unknown_parameters
    return ParameterUncertainty(
        params, dict(zip(params, map(float, se), strict=True)), cov, sigma2, dof
    )


def _parameter_block_of_kkt_inverse(H: sp.csc_matrix, C: sp.csc_matrix, p0: int) -> np.ndarray:
    """``[K^-1]_pp`` for ``K = [[H, C^T], [C, 0]]`` and parameters ``z[p0:]``.

    The parameter columns couple every interval, so a direct factorisation of ``K`` fills
    in badly. Without them ``K_s`` (states and constraints only) is banded in time and
    factorises cheaply; the parameter block is then the inverse of the Schur complement
    ``S = H_pp - B^T K_s^-1 B`` with ``B = [H_sp; C_p]``.
    """
    H = H.tocsc()
    C = C.tocsc()
    Hss, Hsp, Hpp = H[:p0, :p0], H[:p0, p0:], H[p0:, p0:].toarray()
    Cs, Cp = C[:, :p0], C[:, p0:]
    Ks = sp.bmat([[Hss, Cs.T], [Cs, None]], format="csc")
    B = sp.vstack([Hsp, Cp]).toarray()
    try:
        lu = spla.splu(Ks)
    except RuntimeError as exc:
        raise ValueError(
            "the KKT matrix at the solution is singular: the states are not determined by "
            "the data and the dynamics"
        ) from exc
    S = Hpp - B.T @ lu.solve(B)
    try:
        return np.linalg.inv(S)
    except np.linalg.LinAlgError as exc:
        raise ValueError(
            "the reduced Hessian of the parameters is singular: some unknown parameters "
            "cannot be identified from these data"
        ) from exc
