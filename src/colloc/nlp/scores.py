"""Each tracked sample's share of the objective's gradient, for the standard errors.

The sandwich and autoregressive standard errors (:mod:`colloc.nlp.uncertainty`) take the
parameters' response to the data sample by sample: each tracked signal's residuals and
the gradient of its weighted square, ``2 w_k grad r_k``, at the free-vector entries it
depends on.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from colloc.nlp.residuals import SignalResiduals, signal_columns, tracking_residuals
from colloc.nlp.trials import Trials


def trial_residuals(design: Trials, z: np.ndarray) -> tuple[list[SignalResiduals], list[int]]:
    """Every trial's least-squares signals at the whole ``z`` (trial by trial), and the
    trial each belongs to."""
    signals: list[SignalResiduals] = []
    owners: list[int] = []
    for k, (p, zk) in enumerate(zip(design.problems, design.split(z), strict=True)):
        mine = tracking_residuals(p, zk)
        signals += mine
        owners += [k] * len(mine)
    return signals, owners


def signal_slopes(design: Trials, z: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per least-squares signal (in :func:`trial_residuals`' order): the whole free
    vector's index of each entry and, per node, ``2 w_k grad r_k`` at those entries
    ((count, width)), with the signal's own weights and its term's quadrature factors."""
    out = []
    for problem, zk, index in zip(design.problems, design.split(z), design.index, strict=True):
        p = problem.nlp.objective_placement
        if p is None:
            continue  # a trial without least squares has no signals
        local = p.gather(zk)
        for cols in signal_columns(problem):
            # d/dz [w (y - d)^2 - w (y - d - 1)^2] = 2 w grad y
            data = cols.alone(p.data)
            g0 = p.mapped.jacobian(local, data)
            data[:, cols.measurement] += 1.0
            slope = (g0 - p.mapped.jacobian(local, data)).reshape(p.count, -1)
            out.append((index[p.jac_cols], slope))
    return out


def per_sample(rows: np.ndarray, values: np.ndarray, n: int) -> sp.csc_matrix:
    """``(n, count)``: column ``k`` holds node ``k``'s ``values`` at the free-vector ``rows``
    (the objective placement's Jacobian columns)."""
    count = values.shape[0]
    items = np.repeat(np.arange(count), values.shape[1])
    return sp.coo_matrix((values.ravel(), (rows, items)), shape=(n, count)).tocsc()
