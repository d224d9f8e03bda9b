"""Standard errors of identified parameters from the KKT system at the optimum.

For an equality-constrained least-squares fit ``min J(z) = sum w (y(z) - y_m)^2`` subject
to ``c(z) = 0``, linearised at the optimum, the covariance of ``z`` is
``2 sigma^2 [K^-1]_zz`` with ``K = [[H, C^T], [C, 0]]``, ``H`` the Hessian of the
Lagrangian and ``C`` the constraint Jacobian; ``sigma^2`` is estimated from the residuals
as ``J* / (num_measurements - num_free)`` where ``num_free = n_z - m`` counts the
parameters and the initial states the constraints leave free. With ``H`` the exact
Hessian this is the reduced-Hessian covariance, which equals Gauss-Newton's for linear
outputs and vanishing multipliers.

Before any data are fitted, :func:`cramer_rao_bound` gives the same covariance at a chosen
point (the truth of a synthetic study) with the measurement noise given rather than
estimated: the smallest covariance any unbiased estimate from such data can have, which says
whether a planned experiment can identify the parameters at all.
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
        ``sigma^2`` per unit tracking weight: estimated from the residuals, or as given to
        :func:`cramer_rao_bound`.
    degrees_of_freedom : int or None
        ``num_measurements - num_free``; None for a bound (no residuals were used).
    """

    parameters: tuple[sm.Symbol, ...]
    standard_errors: dict[sm.Symbol, float]
    covariance: np.ndarray
    noise_variance: float
    degrees_of_freedom: int | None


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
    hessian = problem.nlp.hessian(solution.z, solution.multipliers, 1.0)
    block = _kkt_parameter_block(problem, solution.z, hessian)
    sigma2 = float(solution.stats["objective"]) / dof
    return _result(problem, 2.0 * sigma2 * block, sigma2, dof)


def cramer_rao_bound(
    problem: Problem, z: np.ndarray, noise_variance: float = 1.0
) -> ParameterUncertainty:
    """The Cramer-Rao bound of the unknown parameters for data measured around ``z``.

    The smallest covariance an unbiased estimate of the parameters can have when the
    tracked outputs are measured at the truth ``z`` with independent Gaussian noise of
    variance ``noise_variance / w`` (``w`` each output's tracking weight, so with weights
    ``1 / sigma^2`` the default ``1.0`` is right). Computed like
    :func:`parameter_uncertainty` but from the objective's Gauss-Newton Hessian
    ``2 J^T W J`` (no constraint curvature) and the constraint Jacobian at ``z``: the
    Fisher information of the tracked outputs, whatever the residuals at ``z`` (a
    discretization's small mismatch to noise-free data does not enter).
    Use it to ask whether a planned trial can identify a controller before fitting one.

    Parameters
    ----------
    problem : Problem
        A problem whose objective is a tracking least squares.
    z : ndarray
        The point, usually the truth of a synthetic study (``problem.initial_guess`` of the
        true trajectories and parameters).
    noise_variance : float
        ``sigma^2`` per unit tracking weight, > 0.

    Returns
    -------
    ParameterUncertainty
        ``standard_errors`` are the bound's standard deviations, ``degrees_of_freedom`` is
        None.

    Raises
    ------
    ValueError
        When there are no unknown parameters, ``z`` has the wrong shape, the noise variance
        is not a positive number, or the information matrix is singular (parameters the
        tracked outputs cannot identify at all).
    """
    nlp = problem.nlp
    if len(problem.layout.parameter_names) == 0:
        raise ValueError("problem: has no unknown parameters, so there is nothing to bound")
    z = np.asarray(z, dtype=float)
    if z.shape != (nlp.n,):
        raise ValueError(f"z: expected shape ({nlp.n},), found {z.shape}")
    if not (np.isfinite(noise_variance) and noise_variance > 0):
        raise ValueError(f"noise_variance: expected a number > 0, found {noise_variance!r}")
    block = _kkt_parameter_block(problem, z, nlp.gauss_newton_hessian(z))
    return _result(problem, 2.0 * float(noise_variance) * block, float(noise_variance), None)


def _kkt_parameter_block(problem: Problem, z: np.ndarray, hessian: np.ndarray) -> np.ndarray:
    """Symmetrised ``[K^-1]_pp`` of the KKT matrix at ``z`` with these Hessian nonzeros."""
    nlp, lay = problem.nlp, problem.layout
    n, m = nlp.n, nlp.m
    hr, hc = nlp.hessianstructure()
    H = sp.coo_matrix((hessian, (hr, hc)), shape=(n, n)).tocsc()
    H = H + sp.triu(H.T, k=1)
    jr, jc = nlp.jacobianstructure()
    C = sp.coo_matrix((nlp.jacobian(z), (jr, jc)), shape=(m, n)).tocsc()
    block = _parameter_block_of_kkt_inverse(H, C, lay.parameter_offset)
    return 0.5 * (block + block.T)


def _result(
    problem: Problem, cov: np.ndarray, sigma2: float, dof: int | None
) -> ParameterUncertainty:
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
