"""Vector autoregressions: checked against the closed-form VAR(1), dense sums and simulation."""

import numpy as np
import pytest
import scipy.linalg as sl

from colloc.numeric.autoregression import (
    VectorAutoregression,
    default_order,
    fit_through_projection,
    quadratic_form,
    sample_autocovariances,
    yule_walker,
)

A1 = np.array([[0.7, 0.2], [-0.3, 0.5]])
NOISE = np.array([[1.0, 0.3], [0.3, 0.5]])


def _var1_autocovariances(lags: int) -> np.ndarray:
    """Gamma(h) = A^h Gamma(0), Gamma(0) = A Gamma(0) A^T + Sigma_w (discrete Lyapunov)."""
    gamma0 = sl.solve_discrete_lyapunov(A1, NOISE)
    return np.stack([np.linalg.matrix_power(A1, h) @ gamma0 for h in range(lags)])


def test_yule_walker_recovers_a_var1_from_its_exact_autocovariances():
    exact = _var1_autocovariances(12)
    model = yule_walker(exact[:2])
    np.testing.assert_allclose(model.coefficients[0], A1, atol=1e-12)
    np.testing.assert_allclose(model.noise_covariance, NOISE, atol=1e-12)
    np.testing.assert_allclose(model.autocovariances(12), exact, atol=1e-12)
    # a higher order finds nothing more: the extra coefficients vanish
    wider = yule_walker(exact[:4])
    np.testing.assert_allclose(wider.coefficients[1:], 0.0, atol=1e-12)
    assert wider.spectral_radius == pytest.approx(max(abs(np.linalg.eigvals(A1))), rel=1e-10)


def test_yule_walker_refuses_autocovariances_of_no_series():
    bad = np.array([[[1.0]], [[1.5]]])  # a lag-1 correlation of 1.5
    with pytest.raises(ValueError, match="not those of a stationary series"):
        yule_walker(bad)


def test_simulated_series_have_the_model_autocovariances():
    model = yule_walker(_var1_autocovariances(2))
    x = model.simulate(400, 300, np.random.default_rng(0))
    estimate = np.mean([sample_autocovariances(s, 3) for s in x], axis=0)
    exact = _var1_autocovariances(4)
    # 300 series of 400: the lag-h estimate's spread is a few % of Gamma(0); its bias is
    # h / N (the biased estimator)
    scale = np.abs(exact[0]).max()
    np.testing.assert_allclose(
        estimate, exact * (1 - np.arange(4) / 400)[:, None, None], atol=0.05 * scale
    )


def test_quadratic_form_equals_the_dense_double_sum():
    rng = np.random.default_rng(1)
    N, q, m = 60, 3, 2
    Y = rng.standard_normal((N, q, m))
    gammas = _var1_autocovariances(N)
    # the covariance of the stacked series, block (t, s) = Gamma(t - s)
    big = np.zeros((N * m, N * m))
    for t in range(N):
        for s in range(N):
            block = gammas[t - s] if t >= s else gammas[s - t].T
            big[t * m : (t + 1) * m, s * m : (s + 1) * m] = block
    stacked = np.concatenate([Y[t] for t in range(N)], axis=1)  # (q, N m)
    np.testing.assert_allclose(quadratic_form(Y, gammas), stacked @ big @ stacked.T, rtol=1e-10)


def test_the_projection_correction_undoes_the_fit_s_loss():
    # residuals r = M e of an AR(1) e with M taking out the mean and slow waves (what a
    # fit of an offset and slow modes absorbs): their variance is low; corrected it is not
    rng = np.random.default_rng(2)
    N, phi = 200, 0.9
    u = np.pi * np.arange(N) / N
    basis = np.stack([np.ones(N), np.cos(u), np.sin(u), np.cos(2 * u), np.sin(2 * u)], axis=1)
    Q, _ = np.linalg.qr(basis)

    def respond(noise: list[np.ndarray]) -> list[np.ndarray]:
        # each (probes, N, 1)
        return [e - np.einsum("ij,pjk->pik", Q @ Q.T, e) for e in noise]

    variance = 1 / (1 - phi**2)
    truth = VectorAutoregression(
        np.array([[[phi]]]), np.array([[1.0]]), np.array([[[variance]], [[phi * variance]]])
    )
    raw, corrected = [], []
    for seed in range(30):
        (r,) = respond([truth.simulate(N, 1, rng)])
        raw.append(sample_autocovariances(r[0], 1)[0, 0, 0])
        (model,) = fit_through_projection([r[0]], respond, np.random.default_rng(seed), orders=[1])
        corrected.append(model.autocovariances(1)[0, 0, 0])
    # measured: raw median 0.57 of the truth, corrected 0.87 (the mean 0.99; a few records
    # whose slow part the fit took almost whole are corrected far up)
    assert np.median(raw) < 0.7 * variance  # the loss is real
    gap = abs(np.median(raw) - variance)
    assert abs(np.median(corrected) - variance) < 0.4 * gap
    assert abs(np.mean(corrected) - variance) < 0.4 * gap


def test_default_order():
    assert default_order(1000) == 30
    assert default_order(20) == 5  # a quarter of a short series
    assert default_order(1) == 0
