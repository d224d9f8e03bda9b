"""The marginal likelihood's correction to a maximum a posteriori estimate (Laplace).

With a noise model (``process_noise``, ``measured_inputs``) the fit estimates the
disturbances jointly with the parameters: it minimises ``J(theta, u) / s^2`` over the
parameters ``theta`` and the latent quantities ``u`` (the disturbances, the noisy inputs, the
initial state; the other states follow through the defects), ``s^2`` the noise variance per
unit weight. The likelihood of the parameters integrates the latent quantities out. To
second order in ``u`` (Laplace; exact for a linear model with Gaussian noise),

    -2 log p(y | theta) = J*(theta) / s^2 + log det H_u(theta) + const,

``J*`` the objective minimised over ``u`` at ``theta`` and ``H_u`` its Gauss-Newton Hessian in
``u``. The joint estimate leaves out the second term, which depends on the parameters
wherever they shape how the disturbances reach the measurements; that is a bias of the
order of a standard error that does not shrink with more data (``docs/process-noise.md``).

``H_u`` is never formed (the states depend on every earlier disturbance, so it is dense).
With ``K_s = [[H, C^T], [C, 0]]`` the KKT matrix in the free variables other than the
parameters and ``A`` the constraints' Jacobian in the states after the first node (square,
block bidiagonal in time), ``det K_s = +- det(A)^2 det(H_u)``, and both sparse
factorisations are cheap. The correction is Newton's step on the sum, with ``J*``'s
curvature in the parameters from the KKT system and the gradient of ``log det H_u`` by
central differences along the optimum's first-order path (the states follow the
parameters), repeated with the gradient at the corrected parameters until it settles.
"""

from __future__ import annotations

from dataclasses import dataclass
from numbers import Real
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import sympy as sm

from colloc.model.symbols import name_of
from colloc.nlp.kkt import ReducedKKT, constraint_jacobian, hessian_matrix, states_kkt
from colloc.nlp.trials import Trials, TrialsSolution, as_trials
from colloc.nlp.uncertainty import parameter_uncertainty

if TYPE_CHECKING:
    from colloc.nlp.problem import Problem
    from colloc.nlp.solution import Solution

#: Central-difference step of the log-determinant's gradient, in standard errors.
GRADIENT_STEP_SE = 0.01
#: The correction's iterations stop when a step changes no parameter by more than this many
#: standard errors.
SETTLED_SE = 1e-3


@dataclass(frozen=True)
class MarginalCorrection:
    """A maximum a posteriori estimate moved to the Laplace marginal likelihood's optimum.

    Attributes
    ----------
    parameters : dict
        The corrected estimate of every unknown parameter.
    shift : dict
        Corrected minus joint estimate, per parameter.
    shift_in_se : dict
        The shift in units of the KKT standard error (the joint fit's information).
    gradient : dict
        ``d log det H_u / d theta`` at the joint estimate.
    noise_variance : float
        ``s^2``, the noise variance per unit weight the step used.
    iterations : int
        Gradient evaluations until the step settled.
    """

    parameters: dict[sm.Symbol, float]
    shift: dict[sm.Symbol, float]
    shift_in_se: dict[sm.Symbol, float]
    gradient: dict[sm.Symbol, float]
    noise_variance: float
    iterations: int


def marginal_correction(
    problem: Problem | Trials,
    solution: Solution | TrialsSolution,
    noise_variance: float | None = None,
    max_iterations: int = 5,
) -> MarginalCorrection:
    """The Laplace marginal likelihood's estimate from a maximum a posteriori fit.

    Parameters
    ----------
    problem : Problem or Trials
        A problem with a noise model (``process_noise`` or ``measured_inputs``) whose only
        constraints are the collocation defects.
    solution : Solution or TrialsSolution
        Its converged solve.
    noise_variance : float, optional
        ``s^2``, the noise variance per unit weight; default the pooled estimate of
        :func:`colloc.parameter_uncertainty` (``method="kkt"``), which is 1 when the weights
        are ``1 / sigma^2`` of the true noise.
    max_iterations : int
        Most gradient evaluations (the first is Newton's step from the joint estimate).

    Returns
    -------
    MarginalCorrection

    Raises
    ------
    ValueError
        When the problem has no noise model, constraints other than the defects, the
        solve did not converge, or the KKT matrix is singular.
    """
    design = as_trials(problem, solution)
    z = np.asarray(solution.z, dtype=float)
    problems = []
    if not solution.status.success:
        problems.append("solution: the solve did not converge; there is no optimum to correct")
    if not any(p.process_noise or p.measured_inputs for p in design.problems):
        problems.append(
            "problem: no noise model (process_noise or measured_inputs), so there are no "
            "latent disturbances to integrate out"
        )
    if (
        isinstance(max_iterations, bool)
        or not isinstance(max_iterations, int)
        or max_iterations < 1
    ):
        problems.append(f"max_iterations: expected a whole number >= 1, found {max_iterations!r}")
    if noise_variance is not None and not (
        isinstance(noise_variance, Real)
        and not isinstance(noise_variance, bool)
        and np.isfinite(noise_variance)
        and noise_variance > 0
    ):
        problems.append(f"noise_variance: expected a number > 0, found {noise_variance!r}")
    if problems:
        raise ValueError("marginal_correction: " + "; ".join(problems))
    dependent = _dependent_states(design)
    if noise_variance is None:
        noise_variance = parameter_uncertainty(
            problem, solution, method="kkt", discretisation=False
        ).noise_variance
    nlp = design.nlp
    p0 = design.parameter_offset
    kkt = ReducedKKT(design, z, nlp.gauss_newton_hessian(z))
    covariance = noise_variance * kkt.parameter_block()  # (curvature of J* / s^2)^-1
    se = np.sqrt(2.0 * np.diag(covariance))  # the KKT standard errors
    path = np.vstack([kkt.state_response(), np.eye(z.size - p0)])
    steps = GRADIENT_STEP_SE * se

    def at(delta: np.ndarray) -> np.ndarray:
        return z + path @ delta

    def gradient(delta: np.ndarray) -> np.ndarray:
        out = np.empty(delta.size)
        for i, h in enumerate(steps):
            e = np.zeros(delta.size)
            e[i] = h
            up = _log_det_latent(design, at(delta + e), dependent)
            down = _log_det_latent(design, at(delta - e), dependent)
            out[i] = (up - down) / (2.0 * h)
        return out

    delta = np.zeros(z.size - p0)
    first = gradient(delta)
    g, iterations = first, 1
    while True:
        new = -covariance @ g
        settled = np.max(np.abs(new - delta) / se) < SETTLED_SE
        delta = new
        if settled or iterations >= max_iterations:
            break
        g = gradient(delta)
        iterations += 1
    names = design.unknown_parameters
    estimate = z[p0:]
    return MarginalCorrection(
        {p: float(estimate[i] + delta[i]) for i, p in enumerate(names)},
        {p: float(delta[i]) for i, p in enumerate(names)},
        {p: float(delta[i] / se[i]) for i, p in enumerate(names)},
        {p: float(first[i]) for i, p in enumerate(names)},
        float(noise_variance),
        iterations,
    )


def _dependent_states(design: Trials) -> np.ndarray:
    """The free-vector columns of every trial's states after its first node: as many as the
    constraints, or a ValueError."""
    columns = []
    for problem, offset in zip(design.problems, design.offsets, strict=True):
        layout = problem.layout
        for x in problem.model.states:
            columns.append(offset + layout.node_indices(name_of(x))[1:])
    dependent = np.concatenate(columns)
    if dependent.size != design.nlp.m:
        raise ValueError(
            f"marginal_correction: the problem has {design.nlp.m} constraints for "
            f"{dependent.size} state values after the first node; the correction needs the "
            "collocation defects as the only constraints (a scheme without interval states, "
            "no path or boundary constraints)"
        )
    return dependent


def _log_det_latent(design: Trials, z: np.ndarray, dependent: np.ndarray) -> float:
    """``log det H_u`` at ``z``: ``log |det K_s| - 2 log |det A|``."""
    p0 = design.parameter_offset
    H = hessian_matrix(design, design.nlp.gauss_newton_hessian(z))
    C = constraint_jacobian(design, z)
    return _log_abs_det(states_kkt(H, C, p0)) - 2.0 * _log_abs_det(C[:, dependent])


def _log_abs_det(matrix: sp.spmatrix) -> float:
    """``log |det M|`` of a square sparse matrix from its LU factors (``L`` has a unit
    diagonal, the permutations determinant 1 in size)."""
    try:
        diagonal = spla.splu(sp.csc_matrix(matrix)).U.diagonal()
    except RuntimeError as exc:
        raise ValueError(
            "marginal_correction: a singular matrix at the solution (the states are not "
            "determined by the latent quantities and the data)"
        ) from exc
    return float(np.sum(np.log(np.abs(diagonal))))
