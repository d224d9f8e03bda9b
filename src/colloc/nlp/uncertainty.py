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

import dataclasses
import math
import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from colloc.model.symbols import name_of
from colloc.nlp.influence import effective_variance
from colloc.nlp.kkt import ReducedKKT
from colloc.nlp.scores import signal_slopes, trial_residuals
from colloc.nlp.trials import Trials, TrialsSolution, as_trials
from colloc.nlp.uncertainty_autoregressive import Autoregressive, CannotModel
from colloc.nlp.uncertainty_base import (
    Blocks,
    FitPoint,
    ParameterUncertainty,
    Request,
    UncertaintyMethod,
    make_result,
)
from colloc.nlp.uncertainty_choice import choose_method
from colloc.nlp.uncertainty_kkt import KKT, PRIOR_UNIT_RANGE
from colloc.nlp.uncertainty_sandwich import Sandwich

__all__ = [
    "METHODS",
    "PRIOR_UNIT_RANGE",
    "DiscretisationWarning",
    "ParameterUncertainty",
    "count_measurements",
    "cramer_rao_bound",
    "parameter_uncertainty",
]

if TYPE_CHECKING:
    from colloc.nlp.problem import Problem
    from colloc.nlp.solution import Solution


#: The covariance methods, by name.
_BY_NAME: dict[str, UncertaintyMethod] = {
    method.name: method for method in (KKT(), Sandwich(), Autoregressive())
}
#: The methods of :func:`parameter_uncertainty`: ``auto`` (:func:`choose_method`) and each
#: method's own.
METHODS = ("auto", *_BY_NAME)


class DiscretisationWarning(UserWarning):
    """The scheme's own error in a parameter is not small beside its standard error."""


#: Below this fraction of a parameter's magnitude, its discretisation error is not warned
#: of, however small the standard error: dynamics with a fast growing mode (Betts and
#: Huffman's 2003 problem) pin a parameter to 1e-27, beside which even Hermite-Simpson's
#: 1e-8 (3e-9 of the value) is large, but no use of the value can see it.
DISCRETISATION_RTOL = 1e-6


def parameter_uncertainty(
    problem: Problem | Trials,
    solution: Solution | TrialsSolution,
    num_measurements: int | None = None,
    method: str = "auto",
    blocks: int | Sequence[int] | Sequence[Sequence[int]] | None = None,
    per_output: bool = False,
    discretisation: bool = True,
) -> ParameterUncertainty:
    """Standard errors of ``solution``'s unknown parameters, and the scheme's own error.

    ``method="kkt"`` trusts the noise model: ``2 sigma^2 [K^-1]_pp`` with the pooled
    ``sigma^2 = J* / dof`` (right when the weights are ``1 / sigma_j^2`` up to one common
    factor, the residuals independent, and the dynamics exact or their disturbances in
    ``process_noise``). ``method="sandwich"`` does not: each parameter's response to the
    data is linearised through the KKT system, ``dtheta = [K^-1]_p,: dg``, and its spread is
    taken from the residuals themselves, summed over contiguous time blocks (a cluster-
    robust, heteroskedasticity- and autocorrelation-consistent covariance
    ``nb / (nb - 1) sum_b u_b u_b^T`` with ``u_b = [K^-1]_p,: g_b`` and ``g_b`` the objective
    gradient of block ``b``'s residuals). It stays honest when the noise levels are wrong
    or the residuals are correlated within a block (process noise left out, coloured
    noise); it needs many blocks longer than the residuals' correlation time.
    ``method="autoregressive"`` takes the same response but the residuals' covariance from a
    vector autoregression of each trial's tracked signals, fitted with the part of the noise
    the fit absorbs added back (:mod:`colloc.nlp.autocorrelated`): it carries the
    correlation to every lag, so it stays honest when the residuals ring for a sizeable part
    of a trial, where no block is both long enough and one of many. It needs every tracked
    signal sampled at every node of a uniform grid.

    Several trials sharing the parameters (:class:`colloc.Trials`) are one estimate: their
    residuals are independent between trials, so the sandwich's blocks never straddle two
    trials, and ``sigma^2`` is pooled over all of them.

    Parameters
    ----------
    problem : Problem or Trials
        What was solved (its objective must be a tracking least squares).
    solution : Solution or TrialsSolution
        Its solve.
    num_measurements : int, optional
        Number of measured samples in the objective; by default counted from the problem's
        least-squares terms (samples with a positive weight, including the process-noise
        penalty's zero pseudo-measurements, whose disturbances are free quantities).
    method : {"auto", "kkt", "sandwich", "autoregressive"}
        ``"auto"`` (default) chooses, and says why in ``reason``: the KKT form when the noise
        is modelled (``process_noise`` or ``measured_inputs``) and the tracked residuals are
        white (lag-1 autocorrelation within ``3 / sqrt(n)``), or with ``per_output``, or with
        fewer than :data:`~colloc.nlp.uncertainty_choice.AUTO_SANDWICH_MIN_NODES` nodes; otherwise the autoregressive
        errors where the sampling allows them and ``blocks`` is not given, else the sandwich
        over blocks. On the gallery's problems the KKT errors of a fit without a noise model
        were 3-12 times too small (20-57 % of the parameters within 3 SE); on four trials of
        a ringing plant with an unmodelled disturbance the blocks' errors were 2-3 times too
        small, the autoregressive ones about right (``docs/process-noise.md``).
    blocks : int or sequence, optional
        Sandwich only: the number of equal time blocks, or the first node of each block
        (e.g. each stride's heel strike). Default ``round(sqrt(N))`` blocks. With
        :class:`colloc.Trials`: the blocks of each trial (default ``round(sqrt(N_i))``,
        at least 2, in trial ``i`` of ``N_i`` nodes), a number for every trial, or one
        sequence of first nodes per trial (a trial may be one block, ``[0]``).
    per_output : bool
        KKT only. False (default): one noise variance per unit weight, pooled over every
        tracked signal, so the weights must be ``1 / sigma_j^2`` up to one common factor
        for the errors to mean anything. True: each tracked signal's variance per unit
        weight is estimated from its own residuals (``sum w r^2`` over its share
        ``n_j dof / num_measurements`` of the degrees of freedom), and the covariance is
        that of the estimator the weights define,
        ``[K^-1]_p,: (sum_i 4 w_i^2 v_i grad r_i grad r_i^T) [K^-1]_:,p`` with ``v_i`` the
        sample's variance: right whatever the weights, when the noise is white. The
        priors of ``process_noise`` and ``measured_inputs`` keep their given variances
        (their weights are taken as ``1 / sigma^2``), so with priors the tracking weights
        must be ``1 / sigma^2`` too: a tracked signal whose variance per unit weight is
        outside :data:`PRIOR_UNIT_RANGE` is refused by name. ``noise_variance`` is then the
        pooled value, for reference.
    discretisation : bool
        Estimate each parameter's discretisation error too (default): one more solve, on
        a grid twice as fine (:func:`colloc.nlp.refinement.discretisation_error`). The
        standard error counts the data's noise only; on noise-free data with the midpoint
        rule it fell to 1e-30 while the estimate was 6.6e-4 off.

    Returns
    -------
    ParameterUncertainty

    Raises
    ------
    ValueError
        When there are no unknown parameters, no more measurements than free quantities,
        the KKT matrix is singular (unidentifiable parameters), ``method`` or ``blocks`` is
        not one of the accepted values, ``method="autoregressive"`` meets data it cannot
        model (a non-uniform grid, samples left out, fewer than 25 per trial), the blocks
        would leave a parameter only one block (a trial's own parameter in a one-block trial), or ``solution`` is not a solve of
        ``problem`` (another free vector's length).

    Warns
    -----
    UserWarning
        When ``solution`` is not a converged solve (a failed solve, or ``max_iter=0``):
        the errors then describe a point that is not the estimate's optimum.
    DiscretisationWarning
        When a parameter's discretisation error exceeds half its standard error (and
        :data:`DISCRETISATION_RTOL` of its value): refine the grid or take a higher-order
        scheme before reading the error bar.
    """
    design = as_trials(problem, solution)
    result = _uncertainty(design, solution, num_measurements, method, blocks, per_output)
    if not discretisation:
        return result
    return _with_discretisation(design, solution, result)


def _uncertainty(
    design: Trials,
    solution: Solution | TrialsSolution,
    num_measurements: int | None,
    method: str,
    blocks: Blocks,
    per_output: bool,
) -> ParameterUncertainty:
    """:func:`parameter_uncertainty` without the discretisation error."""
    if not solution.status.success:
        warnings.warn(
            f"solution: the solve did not converge ({solution.status.name}); standard errors "
            "at a point that is not an optimum do not describe an estimate",
            UserWarning,
            stacklevel=2,
        )
    if method not in METHODS:
        raise ValueError(f"method: expected one of {list(METHODS)}, found {method!r}")
    if blocks is not None and method != "auto" and not _BY_NAME[method].uses_blocks:
        raise ValueError(
            f"blocks: only the sandwich estimate uses time blocks, but method={method!r} was "
            "asked for; drop blocks= or use method='sandwich' (or 'auto')"
        )
    reason = "asked for"
    asked = method != "auto"
    priors = any(p.process_noise or p.measured_inputs for p in design.problems)
    needed = not asked or _BY_NAME[method].needs_residuals or priors or per_output
    residuals, owners = trial_residuals(design, solution.z) if needed else (None, [])
    if not asked:
        assert residuals is not None
        method, reason = choose_method(design, residuals, owners, per_output, blocks)
    chosen = _BY_NAME[method]
    request = Request(design, residuals, owners, blocks, per_output, asked)
    chosen.refuse(request)
    nlp = design.nlp
    if num_measurements is None:
        num_measurements = count_measurements(design)
    n, m = nlp.n, nlp.m
    dof: float = num_measurements - (n - m)
    if dof <= 0:
        raise ValueError(
            f"num_measurements: expected more than the {n - m} free quantities, "
            f"found {num_measurements}"
        )
    hessian = nlp.hessian(solution.z, solution.multipliers, 1.0)
    kkt = ReducedKKT(design, solution.z, hessian)
    sigma2 = float(solution.stats["objective"]) / dof
    effective = None
    # each least-squares signal's residual gradients, for the priors' and per-output shares
    slopes = (
        signal_slopes(design, solution.z) if priors or per_output or chosen.needs_slopes else []
    )
    if priors:
        # the disturbances' (and measured inputs') priors shrink them: they use up fewer
        # degrees of freedom than they count, so the noise is read from the tracked
        # residuals over their effective degrees of freedom
        assert residuals is not None
        sigma2, effective, dof = effective_variance(design, solution.z, hessian, residuals, slopes)
    point = FitPoint(
        design, solution, kkt, hessian, sigma2, dof, num_measurements, effective, residuals,
        owners, slopes, blocks, per_output, reason, asked,
    )  # fmt: skip
    try:
        result = chosen.covariance(point)
    except CannotModel as exc:
        if asked:
            raise ValueError(
                f"method: '{chosen.name}' cannot model these residuals ({exc}); use "
                "method='sandwich'"
            ) from exc
        fallback = _BY_NAME["sandwich"]
        fallback.refuse(request)
        point = dataclasses.replace(
            point, reason=f"{reason}; but {exc}, so the sandwich over time blocks instead"
        )
        result = fallback.covariance(point)
    return _mark_bounds(solution, result)


def count_measurements(problem: Problem | Trials) -> int:
    """Samples with a positive weight in the problem's least-squares terms.

    Parameters
    ----------
    problem : Problem or Trials
        Of several trials, all their samples.

    Returns
    -------
    int
    """
    total = 0
    for part in problem.problems if isinstance(problem, Trials) else (problem,):
        for term in part.node_terms:
            m = len(term.signals)
            if m:
                total += int(np.count_nonzero(term.data[:, m : 2 * m] > 0))
    return total


def cramer_rao_bound(
    problem: Problem | Trials, z: np.ndarray, noise_variance: float = 1.0
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
    problem : Problem or Trials
        A problem whose objective is a tracking least squares, or several trials sharing
        the parameters (the bound of the whole design).
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
    if not isinstance(problem, Trials) and not problem.partition.unknown_parameters:
        raise ValueError("problem: has no unknown parameters, so there is nothing to bound")
    design = as_trials(problem)
    nlp = design.nlp
    z = np.asarray(z, dtype=float)
    if z.shape != (nlp.n,):
        raise ValueError(f"z: expected shape ({nlp.n},), found {z.shape}")
    if not (np.isfinite(noise_variance) and noise_variance > 0):
        raise ValueError(f"noise_variance: expected a number > 0, found {noise_variance!r}")
    block = ReducedKKT(design, z, nlp.gauss_newton_hessian(z)).parameter_block()
    return make_result(
        design, 2.0 * float(noise_variance) * block, float(noise_variance), None, "cramer-rao"
    )


def _with_discretisation(
    design: Trials, solution: Solution | TrialsSolution, result: ParameterUncertainty
) -> ParameterUncertainty:
    """``result`` with each parameter's discretisation error; a warning naming those whose
    error is not small beside their standard error."""
    from colloc.nlp.refinement import discretisation_error

    if not solution.status.success:
        return dataclasses.replace(
            result, discretisation_note="not estimated: the solve did not converge"
        )
    estimate = discretisation_error(design, solution)
    large = []
    for p, error in estimate.errors.items():
        se = result.standard_errors.get(p, math.nan)
        floor = DISCRETISATION_RTOL * abs(solution.parameters[p])
        if abs(error) > max(0.5 * se, floor) and not math.isnan(se):
            large.append(f"{name_of(p)} ({error:.3g} against SE {se:.3g})")
    if large:
        warnings.warn(
            f"discretisation error above half the standard error: {', '.join(large)}; the "
            f"error bar does not count it: refine the grid or use a higher-order scheme "
            f"({design.problems[0].scheme.name}, order {estimate.order})",
            DiscretisationWarning,
            stacklevel=3,
        )
    return dataclasses.replace(
        result, discretisation_errors=estimate.errors, discretisation_note=estimate.note
    )


def _mark_bounds(
    solution: Solution | TrialsSolution, result: ParameterUncertainty
) -> ParameterUncertainty:
    """NaN for the standard errors (and covariance rows) of the parameters a bound holds."""
    held = set(solution.status.at_bounds)
    index = [i for i, p in enumerate(result.parameters) if name_of(p) in held]
    if not index:
        return result
    cov = result.covariance.copy()
    cov[index, :] = np.nan
    cov[:, index] = np.nan
    symbols = tuple(result.parameters[i] for i in index)
    note = (
        f"{', '.join(map(name_of, symbols))} at a bound: no standard error (the bound holds "
        "it, not the data; widen the bound or check the model), the others' as if it were free"
    )
    return dataclasses.replace(
        result,
        standard_errors={
            p: (math.nan if p in symbols else se) for p, se in result.standard_errors.items()
        },
        covariance=cov,
        reason=f"{result.reason}; {note}" if result.reason else note,
        at_bounds=symbols,
    )
