"""What every covariance of the identified parameters shares: the result
(:class:`ParameterUncertainty`), the fit it is read at (:class:`FitPoint`), and the method's
form (:class:`UncertaintyMethod`), which each method's module fills in
(:mod:`colloc.nlp.uncertainty_kkt`, :mod:`colloc.nlp.uncertainty_sandwich`,
:mod:`colloc.nlp.uncertainty_autoregressive`), as the schemes fill in
:mod:`colloc.transcription.base`."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import sympy as sm

from colloc.nlp.kkt import ReducedKKT
from colloc.nlp.residuals import SignalResiduals
from colloc.nlp.scores import per_sample
from colloc.nlp.trials import Trials, TrialsSolution

if TYPE_CHECKING:
    from colloc.nlp.solution import Solution

#: The sandwich's blocks as :func:`colloc.nlp.uncertainty.parameter_uncertainty` takes them.
Blocks = int | Sequence[int] | Sequence[Sequence[int]] | None


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
        :func:`colloc.nlp.uncertainty.cramer_rao_bound`.
    degrees_of_freedom : float or None
        ``num_measurements - num_free``; with priors the tracked samples less
        ``effective_parameters``; None for a bound (no residuals were used).
    method : str
        ``"kkt"`` (the noise model taken as right), ``"sandwich"`` (robust to a wrong one,
        over time blocks), ``"autoregressive"`` (robust, the residuals' covariance from an
        autoregression per trial) or ``"cramer-rao"`` (a bound at a chosen point).
    blocks : int or None
        Number of time blocks of the sandwich estimate.
    reason : str
        Why ``method`` is the one used (asked for, or the automatic choice's grounds).
    at_bounds : tuple of sympy.Symbol
        Parameters the solve left at one of their bounds (``solution.status.at_bounds``):
        the bound holds them, not the data, so their standard error is NaN and their row
        and column of ``covariance`` too; the others' are computed as if they were free
        (the larger, unconditional spread).
    discretisation_errors : dict
        Symbol -> the scheme's estimated error in the value (Richardson from a grid twice
        as fine, :func:`colloc.nlp.refinement.discretisation_error`), beside the standard
        error, which does not count it; empty when not asked for, NaN when not estimated.
    discretisation_note : str
        How it was estimated, or why not.
    effective_parameters : float or None
        With priors (``process_noise``, ``measured_inputs``): the trace of the tracked
        samples' influence matrix (:func:`colloc.nlp.influence.influence_trace`), the
        quantities the data determine; ``noise_variance`` is then the tracked residuals'
        ``sum w r^2`` over ``degrees_of_freedom = n_y - effective_parameters``. None
        without priors.
    orders : tuple of int
        ``"autoregressive"``: each trial's autoregression order; empty otherwise.
    """

    parameters: tuple[sm.Symbol, ...]
    standard_errors: dict[sm.Symbol, float]
    covariance: np.ndarray
    noise_variance: float
    degrees_of_freedom: float | None
    method: str = "kkt"
    blocks: int | None = None
    reason: str = ""
    at_bounds: tuple[sm.Symbol, ...] = ()
    discretisation_errors: dict[sm.Symbol, float] = dataclasses.field(default_factory=dict)
    discretisation_note: str = ""
    effective_parameters: float | None = None
    orders: tuple[int, ...] = ()


@dataclass(frozen=True)
class Request:
    """What was asked of a covariance, before any work on the KKT system.

    Attributes
    ----------
    design : Trials
    residuals : list of SignalResiduals or None
        Every least-squares signal's residuals (None where none are needed).
    owners : list of int
        The trial of each.
    blocks : Blocks
        The sandwich's blocks as asked.
    per_output : bool
    asked : bool
        Whether the user named the method (not ``auto``'s choice).
    """

    design: Trials
    residuals: list[SignalResiduals] | None
    owners: list[int]
    blocks: Blocks
    per_output: bool
    asked: bool


@dataclass(frozen=True)
class FitPoint:
    """A fit at its solution, as every covariance method reads it.

    Attributes
    ----------
    design : Trials
        What was solved (one problem is a design of one trial).
    solution : Solution or TrialsSolution
    kkt : ReducedKKT
        The KKT system at the solution, with the Lagrangian's exact Hessian.
    hessian : ndarray
        That Hessian's nonzeros.
    sigma2 : float
        The noise variance per unit weight.
    dof : float
        The degrees of freedom ``sigma2`` was read over.
    num_measurements : int
    effective : float or None
        With priors, the tracked samples' effective parameters.
    residuals : list of SignalResiduals or None
        Every least-squares signal's residuals (None where no method needs them).
    owners : list of int
        The trial of each.
    slopes : list
        Each signal's ``(rows, 2 w grad r)`` (:func:`colloc.nlp.scores.signal_slopes`);
        empty where none is needed.
    blocks : Blocks
        The sandwich's blocks as asked.
    per_output : bool
        Each tracked signal's variance on its own (the KKT form only).
    reason : str
        Why the method is the one used.
    asked : bool
        Whether the user named the method (not ``auto``'s choice).
    """

    design: Trials
    solution: Solution | TrialsSolution
    kkt: ReducedKKT
    hessian: np.ndarray
    sigma2: float
    dof: float
    num_measurements: int
    effective: float | None
    residuals: list[SignalResiduals] | None
    owners: list[int]
    slopes: list[tuple[np.ndarray, np.ndarray]]
    blocks: Blocks
    per_output: bool
    reason: str
    asked: bool

    def result(
        self,
        cov: np.ndarray,
        method: str,
        blocks: int | None = None,
        **extra: Any,
    ) -> ParameterUncertainty:
        """The :class:`ParameterUncertainty` of covariance ``cov`` by ``method``."""
        return dataclasses.replace(
            make_result(
                self.design,
                cov,
                self.sigma2,
                self.dof,
                method,
                blocks,
                self.reason,
                self.effective,
            ),  # fmt: skip
            **extra,
        )

    def prior_share(self) -> np.ndarray:
        """The priors' share of the robust covariances, from the noise model:
        ``sum_k sigma^2 / w_k Y_k Y_k^T``, ``Y_k = [K^-1]_p,: 2 w_k grad r_k``, over every
        sample of a disturbance or measured input (their residuals are shrunk by the fit, so
        they say little of the noise). Zero without priors."""
        q = len(self.design.unknown_parameters)
        cov = np.zeros((q, q))
        for prior, (rows, slope) in zip(self.residuals or [], self.slopes, strict=False):
            if prior.kind == "tracking":
                continue
            used = prior.weights > 0
            root = np.where(used, np.sqrt(self.sigma2 / np.where(used, prior.weights, 1.0)), 0.0)
            Y = self.kkt.parameter_rows(per_sample(rows, slope * root[:, None], self.design.nlp.n))
            cov += Y @ Y.T
        return cov


class UncertaintyMethod:
    """One way to the parameters' covariance at a fit.

    Attributes
    ----------
    name : str
        As :func:`colloc.nlp.uncertainty.parameter_uncertainty`'s ``method`` names it.
    uses_blocks : bool
        Whether it reads the sandwich's time blocks.
    needs_residuals : bool
        Whether it reads the residuals even without priors or ``per_output``.
    needs_slopes : bool
        Whether it reads each signal's slopes even without priors or ``per_output``.
    """

    name: ClassVar[str]
    uses_blocks: ClassVar[bool] = False
    needs_residuals: ClassVar[bool] = True
    needs_slopes: ClassVar[bool] = False

    def refuse(self, request: Request) -> None:
        """Raise ValueError, naming why, when this method cannot serve the fit (before any
        work on its KKT system). Nothing by default."""

    def covariance(self, point: FitPoint) -> ParameterUncertainty:
        """The covariance at ``point``."""
        raise NotImplementedError


def make_result(
    design: Trials,
    cov: np.ndarray,
    sigma2: float,
    dof: float | None,
    method: str,
    blocks: int | None = None,
    reason: str = "",
    effective: float | None = None,
) -> ParameterUncertainty:
    """A :class:`ParameterUncertainty` of ``design``'s unknown parameters from ``cov``.

    Parameters
    ----------
    design : Trials
    cov : ndarray
        In the order of ``design.unknown_parameters``.
    sigma2 : float
    dof : float or None
    method : str
    blocks : int, optional
    reason : str
    effective : float, optional

    Returns
    -------
    ParameterUncertainty
        The standard errors the roots of ``cov``'s diagonal (negative round-off as 0).
    """
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    params = design.unknown_parameters
    return ParameterUncertainty(
        params,
        dict(zip(params, map(float, se), strict=True)),
        cov,
        sigma2,
        dof,
        method,
        blocks,
        reason,
        effective_parameters=effective,
    )
