"""Which covariance of the identified parameters a fit gets when none is named
(``method="auto"`` of :func:`colloc.nlp.uncertainty.parameter_uncertainty`), and why."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from colloc.nlp.autocorrelated import autoregressive_obstacle
from colloc.nlp.residuals import SignalResiduals
from colloc.nlp.trials import Trials

#: Fewest nodes for ``method="auto"`` to take the sandwich (five blocks of five nodes).
AUTO_SANDWICH_MIN_NODES = 25


def choose_method(
    design: Trials,
    residuals: Sequence[SignalResiduals],
    owners: Sequence[int],
    per_output: bool,
    blocks: int | Sequence[int] | Sequence[Sequence[int]] | None = None,
) -> tuple[str, str]:
    """``method="auto"``: the method, and why, from the residuals at the solution.

    Parameters
    ----------
    design : Trials
    residuals : sequence of SignalResiduals
        Every signal's residuals at the solution.
    owners : sequence of int
        The trial of each signal.
    per_output : bool
        Whether each signal's variance is asked for on its own (a form of the KKT covariance).
    blocks : optional
        The sandwich's blocks when the caller gave them.

    Returns
    -------
    (str, str)
        The method (``"kkt"``, ``"sandwich"`` or ``"autoregressive"``) and the reason.
    """
    if per_output:
        return "kkt", "per_output=True is a form of the KKT covariance"
    modelled = sorted({r.kind for r in residuals if r.kind != "tracking"})
    N = design.num_nodes
    if modelled:
        # the worst signal against its own trial's limit 3 / sqrt(N_i)
        worst, limit = 0.0, 3.0 / np.sqrt(design.problems[0].layout.num_nodes)
        for signal, owner in zip(residuals, owners, strict=True):
            r = signal.residuals[signal.weights > 0]
            if signal.kind == "tracking" and r.size > 2 and np.std(r) > 0:
                value = abs(float(np.corrcoef(r[1:], r[:-1])[0, 1]))
                own = 3.0 / np.sqrt(design.problems[owner].layout.num_nodes)
                if value / own > worst / limit:
                    worst, limit = value, own
        if worst <= limit:
            return "kkt", (
                f"the noise is modelled ({', '.join(modelled)}) and the tracked residuals are "
                f"white (lag-1 autocorrelation {worst:.2f} <= {limit:.2f})"
            )
        why = (
            f"the noise is modelled ({', '.join(modelled)}) but the tracked residuals are "
            f"correlated (lag-1 autocorrelation {worst:.2f} > {limit:.2f})"
        )
    elif N < AUTO_SANDWICH_MIN_NODES:
        return "kkt", (
            f"{N} nodes are too few for the sandwich's blocks (at least "
            f"{AUTO_SANDWICH_MIN_NODES}); the KKT errors take the noise model as right"
        )
    else:
        why = "the noise is not modelled"
    if blocks is not None:
        return "sandwich", (
            f"{why}: the sandwich over the given time blocks stays right when the weights or "
            "the noise model are wrong or the residuals correlated within a block"
        )
    obstacle = autoregressive_obstacle(design, residuals, owners)
    if obstacle:
        return "sandwich", (
            f"{why}: the sandwich over time blocks stays right when the weights or the noise "
            "model are wrong or the residuals correlated within a block (the autoregressive "
            f"errors cannot be had: {obstacle})"
        )
    return "autoregressive", (
        f"{why}: the residuals' covariance from an autoregression per trial stays right when "
        "the weights or the noise model are wrong or the residuals correlated, however long"
    )
