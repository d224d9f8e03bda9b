"""Standard errors when the residuals stay correlated over much of a trial.

The sandwich over time blocks (:func:`colloc.parameter_uncertainty`, ``method="sandwich"``)
needs blocks longer than the residuals' correlation time. A lightly damped plant pushed by a
disturbance the model leaves out rings for seconds, and in trials of a few seconds no block
is both that long and one of many. The parameters' covariance is then taken as
``[K^-1]_p,: S Sigma S^T [K^-1]_:,p`` with ``S`` each tracked sample's gradient of its
weighted square and ``Sigma`` the residuals' covariance, modelled per trial by a vector
autoregression (:mod:`colloc.numeric.autoregression`) of the trial's tracked signals, which
carries the correlation to every lag. The fit absorbs part of the noise (the initial states
follow much of a slow disturbance's response), so the autoregression is fitted to the
residuals with that loss added back: the linearised fit's response to simulated noise,
through one factorisation of the whole KKT matrix.

It needs every tracked signal of a trial sampled at every node of a uniform grid; the
reason it cannot be had otherwise is given by :func:`autoregressive_obstacle`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.sparse.linalg as spla

from colloc.nlp.kkt import ReducedKKT, constraint_jacobian, hessian_matrix, states_kkt
from colloc.nlp.residuals import SignalResiduals
from colloc.nlp.scores import per_sample
from colloc.nlp.trials import Trials
from colloc.numeric.autoregression import fit_through_projection, quadratic_form

#: Fewest samples of a trial for its residuals' autoregression.
MIN_SAMPLES = 25
#: Relative spread of a trial's time steps up to which its grid counts as uniform.
UNIFORM_RTOL = 1e-6


def autoregressive_obstacle(
    design: Trials, residuals: Sequence[SignalResiduals], owners: Sequence[int]
) -> str:
    """Why the residuals cannot be modelled as a series per trial; ``""`` when they can.

    Parameters
    ----------
    design : Trials
    residuals : sequence of SignalResiduals
        The least-squares signals (:func:`colloc.nlp.scores.trial_residuals`).
    owners : sequence of int
        The trial of each.

    Returns
    -------
    str
    """
    tracked = _tracked(residuals, owners)
    if not tracked:
        return "no tracked signal"
    for k, signals in tracked.items():
        name = design.names[k]
        steps = np.diff(design.problems[k].layout.times)
        if np.ptp(steps) > UNIFORM_RTOL * np.mean(steps):
            return f"{name}'s grid is not uniform"
        sizes = {residuals[i].residuals.size for i in signals}
        if len(sizes) > 1:
            return f"{name}'s tracked signals have different numbers of samples"
        if sizes.pop() < MIN_SAMPLES:
            return f"{name} has fewer than {MIN_SAMPLES} samples"
        for i in signals:
            if np.any(residuals[i].weights <= 0):
                return f"{residuals[i].name} in {name} leaves samples out"
    return ""


def autoregressive_covariance(
    design: Trials,
    z: np.ndarray,
    hessian: np.ndarray,
    kkt: ReducedKKT,
    residuals: Sequence[SignalResiduals],
    owners: Sequence[int],
    slopes: Sequence[tuple[np.ndarray, np.ndarray]],
    seed: int = 0,
) -> tuple[np.ndarray, tuple[int, ...]]:
    """The tracked residuals' share of the parameters' covariance (module description).

    Parameters
    ----------
    design : Trials
    z : ndarray
        The solution.
    hessian : ndarray
        The Lagrangian's Hessian values at ``z`` (the NLP's structure).
    kkt : ReducedKKT
        At ``z`` with that Hessian.
    residuals, owners : sequence
        As :func:`autoregressive_obstacle` (which must have returned ``""``).
    slopes : sequence of (ndarray, ndarray)
        Each signal's :func:`colloc.nlp.scores.signal_slopes`.
    seed : int
        Of the simulated noise that measures the fit's loss.

    Returns
    -------
    covariance : ndarray, shape (q, q)
    orders : tuple of int
        Each trial's autoregression order (trials with tracked signals, in order).

    Raises
    ------
    ValueError
        When a trial's residuals are not those of a stationary series.
    """
    n = design.nlp.n
    tracked = _tracked(residuals, owners)
    groups = list(tracked.values())
    S = [[per_sample(*slopes[i], n) for i in signals] for signals in groups]
    weights = [[residuals[i].weights for i in signals] for signals in groups]
    series = [np.stack([residuals[i].residuals for i in signals], axis=1) for signals in groups]
    H = hessian_matrix(design, hessian)
    C = constraint_jacobian(design, z)
    lu = spla.splu(states_kkt(H, C, n))  # the whole KKT matrix: every free variable
    m = C.shape[0]

    def respond(noise: list[np.ndarray]) -> list[np.ndarray]:
        # data d + e moves the optimum by K^-1 [S e; 0]; the residual y - d by grad y dz - e
        rhs = np.zeros((n + m, noise[0].shape[0]))
        for Ss, e in zip(S, noise, strict=True):
            for a, Sk in enumerate(Ss):
                rhs[:n] += Sk @ e[:, :, a].T
        dz = lu.solve(rhs)[:n]
        return [
            np.stack([(Sk.T @ dz).T / (2.0 * w) for Sk, w in zip(Ss, ws, strict=True)], axis=2) - e
            for Ss, ws, e in zip(S, weights, noise, strict=True)
        ]

    try:
        models = fit_through_projection(series, respond, np.random.default_rng(seed))
    except ValueError as exc:
        raise ValueError(
            "the tracked residuals are not those of a stationary series (all zero, or growing)"
        ) from exc
    q = len(design.unknown_parameters)
    cov = np.zeros((q, q))
    for Ss, model, r in zip(S, models, series, strict=True):
        Y = np.stack([kkt.parameter_rows(Sk).T for Sk in Ss], axis=2)
        cov += quadratic_form(Y, model.autocovariances(r.shape[0]))
    return cov, tuple(model.order for model in models)


def _tracked(residuals: Sequence[SignalResiduals], owners: Sequence[int]) -> dict[int, list[int]]:
    """Trial -> the indices of its tracked signals."""
    out: dict[int, list[int]] = {}
    for i, (signal, owner) in enumerate(zip(residuals, owners, strict=True)):
        if signal.kind == "tracking":
            out.setdefault(owner, []).append(i)
    return out
