"""The KKT covariance: the noise model taken as right.

``2 sigma^2 [K^-1]_pp`` with ``K`` the KKT matrix at the optimum and ``sigma^2`` pooled over
every tracked signal; or, ``per_output``, each tracked signal's variance per unit weight from
its own residuals and the covariance of the estimator the weights define,
``[K^-1]_p,: (sum_i 4 w_i^2 v_i grad r_i grad r_i^T) [K^-1]_:,p``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from colloc.nlp.residuals import SignalResiduals
from colloc.nlp.scores import per_sample
from colloc.nlp.uncertainty_base import FitPoint, ParameterUncertainty, UncertaintyMethod

#: Variance per unit weight of a tracked signal that is taken as absolute weighting
#: (``1 / sigma^2`` up to its noise level being off by a factor of ten) when priors are
#: present; outside it, per_output refuses (relative weights made SEs 120-170x too large).
PRIOR_UNIT_RANGE = (1e-2, 1e2)


class KKT(UncertaintyMethod):
    """``method="kkt"``: the reduced-Hessian covariance, pooled or per output."""

    name = "kkt"
    needs_residuals = False

    def covariance(self, point: FitPoint) -> ParameterUncertainty:
        """``2 sigma^2 [K^-1]_pp``, or with ``point.per_output`` each signal's own variance
        (:func:`per_output_covariance`)."""
        if not point.per_output:
            return point.result(2.0 * point.sigma2 * point.kkt.parameter_block(), "kkt")
        assert point.residuals is not None  # computed for per_output
        cov = per_output_covariance(
            point, point.dof / point.num_measurements, point.residuals, point.slopes
        )
        return point.result(cov, "kkt per output")


def per_output_covariance(
    point: FitPoint,
    dof_share: float,
    signals: Sequence[SignalResiduals],
    slopes: list[tuple[np.ndarray, np.ndarray]],
) -> np.ndarray:
    """``[K^-1]_p,: (sum_i 4 w_i^2 v_i g_i g_i^T) [K^-1]_:,p`` with each tracked signal's
    variance per unit weight from its own residuals (priors: their given variance).

    Parameters
    ----------
    point : FitPoint
    dof_share : float
        The degrees of freedom per measurement.
    signals : sequence of SignalResiduals
    slopes : list
        Each signal's ``(rows, 2 w grad r)``.

    Returns
    -------
    ndarray
        Symmetric, in the order of the design's unknown parameters.

    Raises
    ------
    ValueError
        When priors are present and a tracked signal's variance per unit weight lies
        outside :data:`PRIOR_UNIT_RANGE` (relative weights, which the priors' absolute ones
        cannot be balanced against).
    """
    design, kkt = point.design, point.kkt
    q = len(design.unknown_parameters)
    cov = np.zeros((q, q))
    has_priors = any(signal.kind != "tracking" for signal in signals)
    mismatched: list[str] = []
    for (rows, slope), signal in zip(slopes, signals, strict=True):
        w = signal.weights
        used = w > 0
        r = np.where(used, signal.residuals, 0.0)
        variance = 1.0  # a prior's weight is 1 / sigma^2
        if signal.kind == "tracking":
            variance = float(np.sum(w * r**2) / (dof_share * np.count_nonzero(used)))
            if has_priors and not PRIOR_UNIT_RANGE[0] <= variance <= PRIOR_UNIT_RANGE[1]:
                mismatched.append(f"{signal.name} ({variance:.3g})")
        # sample k's residual has variance v_k = variance / w_k
        root = np.where(used, np.sqrt(variance / np.where(used, w, 1.0)), 0.0)
        U = kkt.parameter_rows(per_sample(rows, slope * root[:, None], design.nlp.n))
        cov += U @ U.T
    if mismatched:
        # the fit itself weighed the priors against data in other units: no covariance of
        # it is honest, so none is given
        raise ValueError(
            "per_output: the priors of process_noise / measured_inputs are weighted 1 / sigma^2 "
            "(absolute), but the tracked signals' variance per unit weight is "
            f"{', '.join(mismatched)}, not about 1: their weights are relative, so the fit "
            "balanced priors and data in different units. Give the tracking weights as "
            "1 / sigma^2 of each signal's noise (then per_output refines them), or drop the "
            "priors"
        )
    return 0.5 * (cov + cov.T)
