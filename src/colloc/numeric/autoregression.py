"""Vector autoregressions of residual series: their fit, autocovariances and simulation.

A stationary series ``x_t`` (``m`` signals) is modelled as ``x_t = sum_k A_k x_(t-k) + w_t``
with white ``w_t`` of covariance ``Sigma_w``. The coefficients come from the Yule-Walker
equations on the biased sample autocovariances, whose block-Toeplitz matrix is positive
semi-definite, so the model reproduces the sample autocovariances at lags ``0..p`` and
extends them beyond by its recursion. This is what a long-range covariance of residuals
needs when the residuals stay correlated over a sizeable part of the record, where
sums over short blocks miss most of it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sl
from scipy.signal import fftconvolve

#: Largest modulus of the companion matrix's eigenvalues accepted as stationary.
STATIONARY_LIMIT = 0.9995


@dataclass(frozen=True)
class VectorAutoregression:
    """``x_t = sum_k A_k x_(t-k) + w_t``, fitted by Yule-Walker.

    Attributes
    ----------
    coefficients : ndarray, shape (p, m, m)
        ``A_1 .. A_p``.
    noise_covariance : ndarray, shape (m, m)
        ``Sigma_w``.
    head : ndarray, shape (p + 1, m, m)
        The autocovariances ``Gamma(h) = E[x_(t+h) x_t^T]`` at lags ``0..p`` (those it was
        fitted to).
    """

    coefficients: np.ndarray
    noise_covariance: np.ndarray
    head: np.ndarray

    @property
    def order(self) -> int:
        """``p``."""
        return int(self.coefficients.shape[0])

    @property
    def spectral_radius(self) -> float:
        """Largest modulus of the companion matrix's eigenvalues (below 1: stationary)."""
        p, m = self.order, self.head.shape[1]
        if p == 0:
            return 0.0
        companion = np.zeros((p * m, p * m))
        companion[:m] = np.concatenate(list(self.coefficients), axis=1)
        companion[m:, :-m] = np.eye((p - 1) * m)
        return float(np.max(np.abs(np.linalg.eigvals(companion))))

    def autocovariances(self, lags: int) -> np.ndarray:
        """``Gamma(0) .. Gamma(lags - 1)``, shape (lags, m, m).

        Parameters
        ----------
        lags : int
            How many lags (at least 1).

        Returns
        -------
        ndarray
        """
        p, m = self.order, self.head.shape[1]
        out = np.zeros((max(lags, p + 1), m, m))
        out[: p + 1] = self.head
        for h in range(p + 1, lags):
            # Gamma(h) = sum_k A_k Gamma(h - k)
            out[h] = np.einsum("kab,kbc->ac", self.coefficients, out[h - 1 : h - p - 1 : -1])
        return out[:lags]

    def simulate(self, length: int, count: int, rng: np.random.Generator) -> np.ndarray:
        """``count`` independent stationary series of ``length`` samples.

        The first ``p`` samples are drawn from the stationary distribution (the
        block-Toeplitz covariance of the head), so no burn-in is needed.

        Parameters
        ----------
        length : int
        count : int
        rng : numpy.random.Generator

        Returns
        -------
        ndarray, shape (count, length, m)
        """
        p, m = self.order, self.head.shape[1]
        start = max(p, 1)
        x = np.zeros((count, max(length, start), m))
        lagged = _block_toeplitz(self.head[:start])
        x[:, :start] = (rng.standard_normal((count, start * m)) @ _root(lagged).T).reshape(
            count, start, m
        )
        noise = rng.standard_normal((count, x.shape[1], m)) @ _root(self.noise_covariance).T
        for t in range(start, x.shape[1]):
            past = x[:, t - 1 : (t - p - 1 if t - p - 1 >= 0 else None) : -1]
            x[:, t] = np.einsum("kab,ckb->ca", self.coefficients, past) + noise[:, t]
        return x[:, :length]


def sample_autocovariances(x: np.ndarray, lags: int) -> np.ndarray:
    """Biased sample autocovariances ``(1/N) sum_t x_(t+h) x_t^T``, ``h = 0..lags``.

    The series is not centred: a residual's mean is part of what it contributes.

    Parameters
    ----------
    x : ndarray, shape (N, m)
    lags : int

    Returns
    -------
    ndarray, shape (lags + 1, m, m)
    """
    N = x.shape[0]
    return np.stack([x[h:].T @ x[: N - h] / N for h in range(lags + 1)])


def yule_walker(head: np.ndarray) -> VectorAutoregression:
    """The autoregression of order ``p = len(head) - 1`` with these autocovariances.

    Parameters
    ----------
    head : ndarray, shape (p + 1, m, m)
        ``Gamma(0) .. Gamma(p)``.

    Returns
    -------
    VectorAutoregression

    Raises
    ------
    ValueError
        When the autocovariances are not those of a stationary series (their block
        Toeplitz matrix is not positive definite).
    """
    p, m = head.shape[0] - 1, head.shape[1]
    if p == 0:
        return VectorAutoregression(np.zeros((0, m, m)), head[0].copy(), head.copy())
    R = _block_toeplitz(head[:p])
    # sum_k Gamma(k - h) A_k^T = Gamma(h)^T, h = 1..p
    rhs = np.concatenate([head[h].T for h in range(1, p + 1)], axis=0)
    try:
        solved = sl.solve(R, rhs, assume_a="pos")
    except (np.linalg.LinAlgError, sl.LinAlgError) as exc:
        raise ValueError("autocovariances: not those of a stationary series") from exc
    A = np.stack([solved[k * m : (k + 1) * m].T for k in range(p)])
    noise = head[0] - sum(A[k] @ head[k + 1].T for k in range(p))
    noise = 0.5 * (noise + noise.T)
    if np.any(np.linalg.eigvalsh(noise) <= 0):
        # the (p + 1)-block Toeplitz matrix is not positive definite
        raise ValueError("autocovariances: not those of a stationary series")
    return VectorAutoregression(A, noise, head.copy())


def default_order(length: int) -> int:
    """``floor(10 log10 N)``, the customary largest order for a series of ``N`` samples,
    at most a quarter of it.

    Parameters
    ----------
    length : int

    Returns
    -------
    int
    """
    return max(0, min(int(10 * math.log10(max(length, 1))), length // 4))


def fit_through_projection(
    residuals: Sequence[np.ndarray],
    respond: Callable[[list[np.ndarray]], list[np.ndarray]],
    rng: np.random.Generator,
    orders: Sequence[int] | None = None,
    iterations: int = 20,
    probes: int = 20,
    tolerance: float = 0.001,
) -> list[VectorAutoregression]:
    """Autoregressions of the noise behind fitted residuals, whose fit absorbed part of it.

    A fit's residuals are ``r = M e`` with ``M`` the linearised fit's complement, which
    takes out the parts of the noise ``e`` the free quantities can follow (a slow
    disturbance's response, much of it, by the initial states). Their autocovariances
    underestimate the noise's. By the method of moments, each series' target
    autocovariances are its residuals' plus the loss ``E[Gamma(e) - Gamma(M e)]`` under the
    current model, estimated from ``probes`` simulated series passed through ``respond``;
    the model is refitted to the target until no series' lag-0 variances change by more
    than ``tolerance`` (relative), at most ``iterations`` times. A correction that would
    leave a non-stationary model is halved until it does not. Each series' order is then
    the one of least Akaike criterion up to its largest.

    Parameters
    ----------
    residuals : sequence of ndarray, each (N_i, m_i)
        The fitted residuals, one series per independent record (trial).
    respond : callable
        Maps noise series (one array per record, each ``(probes, N_i, m_i)``) to the
        residuals the fit would leave of them (``M e``, same shapes).
    rng : numpy.random.Generator
        For the probes.
    orders : sequence of int, optional
        Each record's largest order; :func:`default_order` by default.
    iterations, probes : int
    tolerance : float

    Returns
    -------
    list of VectorAutoregression

    Raises
    ------
    ValueError
        When a record's residuals are not those of a stationary series.
    """
    if orders is None:
        orders = [default_order(r.shape[0]) for r in residuals]
    observed = [sample_autocovariances(r, p) for r, p in zip(residuals, orders, strict=True)]
    models = [yule_walker(g) for g in observed]
    # the same random numbers in every iteration: the map is then one deterministic function,
    # whose fixed point the iteration approaches instead of wandering with fresh draws
    common = int(rng.integers(2**63))
    for _ in range(iterations):
        draws = np.random.default_rng(common)
        noise = [
            model.simulate(r.shape[0], probes, draws)
            for model, r in zip(models, residuals, strict=True)
        ]
        left = respond(noise)
        loss = [
            np.mean(
                [
                    sample_autocovariances(a, p) - sample_autocovariances(b, p)
                    for a, b in zip(e, r, strict=True)
                ],
                axis=0,
            )
            for e, r, p in zip(noise, left, orders, strict=True)
        ]
        before = [np.diag(model.head[0]) for model in models]
        models = [
            _stationary(g, d, fallback)
            for g, d, fallback in zip(observed, loss, models, strict=True)
        ]
        change = max(
            float(np.max(np.abs(np.diag(model.head[0]) / b - 1.0)))
            for model, b in zip(models, before, strict=True)
        )
        if change < tolerance:
            break
    return [_akaike(model, r.shape[0]) for model, r in zip(models, residuals, strict=True)]


def _akaike(model: VectorAutoregression, length: int) -> VectorAutoregression:
    """The order up to ``model``'s with the least Akaike criterion
    ``N log det Sigma_w + 2 p m^2`` on ``model``'s autocovariances."""
    m = model.head.shape[1]
    best, chosen = math.inf, model
    for p in range(model.order + 1):
        candidate = yule_walker(model.head[: p + 1])
        sign, logdet = np.linalg.slogdet(candidate.noise_covariance)
        score = length * logdet + 2 * p * m * m if sign > 0 else math.inf
        if score < best:
            best, chosen = score, candidate
    return chosen


def quadratic_form(Y: np.ndarray, gammas: np.ndarray) -> np.ndarray:
    """``sum_(t,s) Y_t Gamma(t - s) Y_s^T`` for a series of ``(q, m)`` matrices ``Y_t``.

    The covariance of ``sum_t Y_t x_t`` for a stationary ``x`` with autocovariances
    ``Gamma``, by FFT convolution along time.

    Parameters
    ----------
    Y : ndarray, shape (N, q, m)
    gammas : ndarray, shape (N, m, m)
        ``Gamma(0) .. Gamma(N - 1)``.

    Returns
    -------
    ndarray, shape (q, q)
    """
    N, q, m = Y.shape
    V = np.zeros_like(Y)
    for a in range(m):
        for b in range(m):
            # kernel(h) = Gamma_ab(h) for h >= 0, Gamma_ba(-h) for h < 0, h = -(N-1)..N-1
            kernel = np.concatenate([gammas[:0:-1, b, a], gammas[:, a, b]])
            V[:, :, a] += fftconvolve(kernel[:, None], Y[:, :, b], axes=0)[N - 1 : 2 * N - 1]
    cov = np.einsum("tia,tja->ij", Y, V)
    return 0.5 * (cov + cov.T)


def _stationary(
    observed: np.ndarray, loss: np.ndarray, fallback: VectorAutoregression
) -> VectorAutoregression:
    """The model of ``observed + f loss`` for the largest ``f`` in 1, 1/2, ... that is
    stationary; the previous model when none is."""
    factor = 1.0
    while factor > 1e-3:
        try:
            model = yule_walker(observed + factor * loss)
        except ValueError:
            model = None
        if model is not None and model.spectral_radius < STATIONARY_LIMIT:
            return model
        factor *= 0.5
    return fallback


def _block_toeplitz(head: np.ndarray) -> np.ndarray:
    """``[Gamma(j - i)]_(i,j)`` for ``i, j < len(head)``, with ``Gamma(-h) = Gamma(h)^T``."""
    p, m = head.shape[0], head.shape[1]
    R = np.zeros((p * m, p * m))
    for i in range(p):
        for j in range(p):
            block = head[j - i] if j >= i else head[i - j].T
            R[i * m : (i + 1) * m, j * m : (j + 1) * m] = block
    return R


def _root(cov: np.ndarray) -> np.ndarray:
    """A matrix square root ``L`` with ``L L^T = cov`` (symmetric PSD)."""
    values, vectors = np.linalg.eigh(0.5 * (cov + cov.T))
    return vectors * np.sqrt(np.clip(values, 0.0, None))
