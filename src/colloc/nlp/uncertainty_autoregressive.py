"""The autoregressive covariance: the residuals' correlation to every lag, from a vector
autoregression of each trial's tracked signals (:mod:`colloc.nlp.autocorrelated`), plus the
priors' share from the noise model."""

from __future__ import annotations

from colloc.nlp.autocorrelated import autoregressive_covariance, autoregressive_obstacle
from colloc.nlp.uncertainty_base import (
    FitPoint,
    ParameterUncertainty,
    Request,
    UncertaintyMethod,
)


class CannotModel(ValueError):
    """The residuals met at the covariance cannot be modelled as a series per trial."""


class Autoregressive(UncertaintyMethod):
    """``method="autoregressive"``: needs every tracked signal at every node of a uniform
    grid (:func:`colloc.nlp.autocorrelated.autoregressive_obstacle`)."""

    name = "autoregressive"
    needs_slopes = True

    def refuse(self, request: Request) -> None:
        """Data it cannot model, or ``per_output`` (a KKT form), when asked for by name
        (``auto`` has checked the data before choosing it)."""
        if not request.asked:
            return
        assert request.residuals is not None  # the autoregression reads them
        obstacle = autoregressive_obstacle(request.design, request.residuals, request.owners)
        if obstacle:
            raise ValueError(
                f"method: 'autoregressive' models each trial's tracked residuals as one series "
                f"on a uniform grid, but {obstacle}; use method='sandwich'"
            )
        if request.per_output:
            raise ValueError("per_output: only for method='kkt' (the autoregression needs none)")

    def covariance(self, point: FitPoint) -> ParameterUncertainty:
        """The autoregression's covariance plus the priors' share.

        Raises
        ------
        CannotModel
            When the autoregression cannot be fitted to these residuals.
        """
        assert point.residuals is not None
        try:
            cov, orders = autoregressive_covariance(
                point.design,
                point.solution.z,
                point.hessian,
                point.kkt,
                point.residuals,
                point.owners,
                point.slopes,
            )
        except ValueError as exc:
            raise CannotModel(str(exc)) from exc
        cov += point.prior_share()
        return point.result(cov, "autoregressive", None, orders=orders)
