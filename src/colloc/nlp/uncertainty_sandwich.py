"""The sandwich covariance over time blocks: robust to a wrong noise model.

Each parameter's response to the data is linearised through the KKT system,
``dtheta = [K^-1]_p,: dg``, and its spread taken from the residuals themselves, summed over
contiguous time blocks: ``nb / (nb - 1) sum_b u_b u_b^T`` with ``u_b = [K^-1]_p,: g_b`` and
``g_b`` the objective gradient of block ``b``'s residuals (a cluster-robust,
heteroskedasticity- and autocorrelation-consistent covariance). The priors' share comes from
the noise model (:meth:`colloc.nlp.uncertainty_base.FitPoint.prior_share`).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from colloc.nlp.sandwich_blocks import (
    block_gradients,
    check_blocks_per_parameter,
    trial_block_starts,
)
from colloc.nlp.scores import per_sample
from colloc.nlp.uncertainty_base import (
    FitPoint,
    ParameterUncertainty,
    Request,
    UncertaintyMethod,
)


class Sandwich(UncertaintyMethod):
    """``method="sandwich"``: over time blocks that never straddle two trials."""

    name = "sandwich"
    uses_blocks = True

    def refuse(self, request: Request) -> None:
        """Blocks that leave a parameter only one block, or ``per_output`` (a KKT form)."""
        design = request.design
        check_blocks_per_parameter(design, trial_block_starts(request.blocks, design))
        if request.per_output:
            raise ValueError("per_output: only for method='kkt' (the sandwich needs no variances)")

    def covariance(self, point: FitPoint) -> ParameterUncertainty:
        """The blocks' spread of the parameters' response, plus the priors' share."""
        design, z = point.design, point.solution.z
        starts = trial_block_starts(point.blocks, design)
        G = block_gradients(design, z, starts)
        assert point.residuals is not None  # the sandwich reads them
        first = np.concatenate([[0], np.cumsum([s.size for s in starts])])
        nb = int(first[-1])
        n = design.nlp.n
        # (no slopes without priors: then nothing below is a prior's)
        for prior, owner, (rows, slope) in zip(
            point.residuals, point.owners, point.slopes, strict=False
        ):
            if prior.kind == "tracking":
                continue
            # a disturbance (or a group's whitened combination) or a measured input's
            # correction: its residuals are shrunk by the fit, so its share is taken from the
            # noise model (prior_share) rather than from the residuals, and its gradient
            # (s_k r_k) is taken out of the blocks'
            used = prior.weights > 0
            r = np.where(used, prior.residuals, 0.0)
            nodes = np.arange(r.size)
            block = first[owner] + np.searchsorted(starts[owner], nodes, side="right") - 1
            in_block = sp.coo_matrix((np.ones(r.size), (nodes, block)), shape=(r.size, nb))
            G = G - (per_sample(rows, slope * r[:, None], n) @ in_block).tocsc()
        U = point.kkt.parameter_rows(G)
        cov = point.prior_share() + nb / (nb - 1) * (U @ U.T)
        return point.result(0.5 * (cov + cov.T), "sandwich", nb)
