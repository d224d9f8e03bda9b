"""periodic_lqr against the algebraic LQR, the Riccati ODE itself and an RK4 monodromy."""

import numpy as np
import pytest
import scipy.linalg

from colloc.control.lqr import lqr
from colloc.control.periodic_lqr import (
    RiccatiBreakdownError,
    discrete_monodromy,
    monodromy,
    periodic_lqr,
    sampled_periodic_lqr,
)

DELTA, EPS = 0.25, 0.3  # inside the first Mathieu instability tongue


def mathieu(num: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``x'' + (DELTA + EPS cos t) x = u`` sampled over one period ``2 pi``."""
    t = np.linspace(0.0, 2 * np.pi, num)
    A = np.zeros((num, 2, 2))
    A[:, 0, 1] = 1.0
    A[:, 1, 0] = -(DELTA + EPS * np.cos(t))
    B = np.zeros((num, 2, 1))
    B[:, 1, 0] = 1.0
    return t, A, B


def rk4_monodromy(a_of, t0: float, t1: float, steps: int) -> np.ndarray:
    n = a_of(t0).shape[0]
    phi, h, t = np.eye(n), (t1 - t0) / steps, t0
    for _ in range(steps):
        k1 = a_of(t) @ phi
        k2 = a_of(t + h / 2) @ (phi + h / 2 * k1)
        k3 = a_of(t + h / 2) @ (phi + h / 2 * k2)
        k4 = a_of(t + h) @ (phi + h * k3)
        phi = phi + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        t += h
    return phi


def test_constant_system_matches_algebraic_lqr():
    A0 = np.array([[0.0, 1.0, 0.0], [2.0, -0.1, 1.0], [0.0, 0.0, -3.0]])
    B0 = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, 1.0]])
    Q, R = np.diag([10.0, 1.0, 0.1]), np.diag([1.0, 2.0])
    t = np.linspace(0.0, 1.3, 7)
    res = periodic_lqr(np.repeat(A0[None], 7, 0), np.repeat(B0[None], 7, 0), t, Q, R)
    ref = lqr(A0, B0, Q, R)
    np.testing.assert_allclose(res.K, np.repeat(ref.K[None], 7, 0), rtol=1e-6, atol=1e-8)
    np.testing.assert_allclose(res.S, np.repeat(ref.S[None], 7, 0), rtol=1e-6, atol=1e-8)
    expected = np.exp(ref.eigenvalues * 1.3)
    np.testing.assert_allclose(
        np.sort(np.abs(res.floquet_multipliers)), np.sort(np.abs(expected)), rtol=1e-6
    )


def test_mathieu_open_loop_unstable_closed_loop_stable():
    t, A, B = mathieu(401)
    open_loop = np.abs(np.linalg.eigvals(monodromy(A, t)))
    assert open_loop.max() > 1.1
    Q, R = np.eye(2), np.array([[0.5]])
    res = periodic_lqr(A, B, t, Q, R)
    assert res.spectral_radius < 1.0
    # Independent monodromy: RK4 with the returned gain interpolated linearly.
    Acl = A - B @ res.K

    def a_of(tau: float) -> np.ndarray:
        return np.array([[np.interp(tau, t, Acl[:, i, j]) for j in range(2)] for i in range(2)])

    mu = np.linalg.eigvals(rk4_monodromy(a_of, 0.0, 2 * np.pi, 4000))
    np.testing.assert_allclose(
        np.sort(np.abs(mu)), np.sort(np.abs(res.floquet_multipliers)), rtol=2e-3
    )


def test_mathieu_solution_satisfies_the_riccati_ode_and_is_periodic():
    t, A, B = mathieu(801)
    Q, R = np.diag([2.0, 0.5]), np.array([[0.3]])
    res = periodic_lqr(A, B, t, Q, R)
    S, h = res.S, t[1] - t[0]
    dS = (S[2:] - S[:-2]) / (2 * h)
    a, b, s = A[1:-1], B[1:-1], S[1:-1]
    sb = s @ b
    rhs = -(np.transpose(a, (0, 2, 1)) @ s + s @ a - sb @ np.transpose(sb, (0, 2, 1)) / 0.3 + Q)
    scale = np.max(np.abs(rhs))
    assert np.max(np.abs(dS - rhs)) < 1e-4 * scale
    np.testing.assert_allclose(S[0], S[-1])
    # S varies over the period (so the ODE check is not trivially met by a constant).
    assert np.ptp(S[:, 0, 0]) > 0.05 * np.abs(S[:, 0, 0]).max()
    np.testing.assert_allclose(res.K, B.transpose(0, 2, 1) @ S / 0.3, rtol=1e-12)


def test_monodromy_of_constant_matrix_is_expm():
    A0 = np.array([[-1.0, 2.0], [-3.0, -0.5]])
    t = np.linspace(0.0, 0.7, 5)
    np.testing.assert_allclose(
        monodromy(np.repeat(A0[None], 5, 0), t), scipy.linalg.expm(0.7 * A0), rtol=1e-6
    )


def test_bad_arguments_are_all_reported():
    t, A, B = mathieu(11)
    with pytest.raises(ValueError, match=r"B: expected shape \(11, 2, m\).*Q: expected shape"):
        periodic_lqr(A, B[:, :1], t, np.eye(3), np.eye(1))
    with pytest.raises(ValueError, match="times: expected finite, strictly increasing"):
        periodic_lqr(A, B, t[::-1], np.eye(2), np.eye(1))
    bad = A.copy()
    bad[-1, 1, 0] += 1.0
    with pytest.raises(ValueError, match="A: expected the last sample to equal the first"):
        periodic_lqr(bad, B, t, np.eye(2), np.eye(1))
    with pytest.raises(ValueError, match="R: expected shape .1, 1.*tol: expected a positive"):
        periodic_lqr(A, B, t, np.eye(2), np.eye(2), tol=0.0)
    with pytest.raises(ValueError, match="max_cycles: expected a positive integer"):
        periodic_lqr(A, B, t, np.eye(2), np.eye(1), max_cycles=0)
    with pytest.raises(ValueError, match="Q: expected a symmetric matrix"):
        periodic_lqr(A, B, t, np.array([[1.0, 1.0], [0.0, 1.0]]), np.eye(1))
    with pytest.raises(ValueError, match="Q: expected positive semi-definite"):
        periodic_lqr(A, B, t, -np.eye(2), np.eye(1))
    with pytest.raises(ValueError, match="R: expected positive definite"):
        periodic_lqr(A, B, t, np.eye(2), np.zeros((1, 1)))
    with pytest.raises(ValueError, match="A: expected finite entries"):
        periodic_lqr(A * np.nan, B, t, np.eye(2), np.eye(1))
    with pytest.raises(ValueError, match=r"monodromy: A: expected shape \(11, n, n\)"):
        monodromy(A[:, :1], t)


def test_unstabilisable_system_does_not_converge():
    t, A, _ = mathieu(21)
    with pytest.raises(ValueError, match="did not converge within max_cycles=5"):
        periodic_lqr(A, np.zeros((21, 2, 1)), t, np.eye(2), np.eye(1), max_cycles=5)


def test_sampled_lqr_tends_to_the_continuous_one():
    A0 = np.array([[0.0, 1.0], [2.0, -0.1]])
    B0 = np.array([[0.0], [1.0]])
    Q, R = np.diag([10.0, 1.0]), np.array([[0.5]])
    ref = lqr(A0, B0, Q, R)
    errors = []
    for num in (11, 101):
        t = np.linspace(0.0, 1.0, num)
        res = sampled_periodic_lqr(
            np.repeat(A0[None], num, 0), np.repeat(B0[None], num, 0), t, Q, R
        )
        errors.append(np.abs(res.K[0] - ref.K).max())
    assert errors[1] < 0.02 * np.abs(ref.K).max()
    assert errors[1] < errors[0] / 5  # first order in the sample spacing


def test_sampled_lqr_stabilises_mathieu_like_the_ode_version():
    # 401 samples: at 201 the ODE iteration's change between periods sat at its integration
    # noise (5e-8, above tol 1e-8) and took 42 periods, 26 s, to dip below it by chance
    t, A, B = mathieu(401)
    Q, R = np.eye(2), np.array([[0.5]])
    sampled = sampled_periodic_lqr(A, B, t, Q, R)
    ode = periodic_lqr(A, B, t, Q, R)
    np.testing.assert_allclose(sampled.K, ode.K, rtol=0.05, atol=0.05 * np.abs(ode.K).max())
    mu = np.linalg.eigvals(discrete_monodromy(A - B @ sampled.K, t))
    # Compare decay rates per period (the multipliers themselves are ~1e-3).
    np.testing.assert_allclose(
        np.log(np.sort(np.abs(mu))), np.log(np.sort(np.abs(ode.floquet_multipliers))), rtol=0.05
    )
    assert sampled.spectral_radius < 1.0
    with pytest.raises(ValueError, match="did not converge within max_cycles=3"):
        sampled_periodic_lqr(A, np.zeros_like(B), t, Q, R, max_cycles=3)
    with pytest.raises(ValueError, match=r"discrete_monodromy: A: expected shape"):
        discrete_monodromy(A[:, :1], t)


def test_a_sampled_recursion_that_overflows_stops_at_once_with_its_place():
    """A fast unstable mode no input reaches: S grows by e^(2 * 400) a period and overflows in
    the first; the recursion says where instead of running its 500 periods on infinities
    (or numpy's bare 'Singular matrix')."""
    t = np.linspace(0.0, 1.0, 21)
    A = np.repeat(np.diag([400.0, -1.0])[None], t.size, 0)
    B = np.repeat(np.array([[0.0], [1.0]])[None], t.size, 0)
    with pytest.raises(RiccatiBreakdownError, match=r"broke down at sample \d+ in period 1 "
                       r"\(S overflowed\); check that \(A, B\) is stabilisable"):  # fmt: skip
        sampled_periodic_lqr(A, B, t, np.eye(2), np.eye(1))
    assert issubclass(RiccatiBreakdownError, ValueError)  # callers that catch ValueError


def test_sampled_periodic_lqr_handles_thousands_of_samples():
    """The monodromy is a loop, not numpy's recursive multi_dot (which failed beyond ~1000)."""
    t, A, B = mathieu(2001)
    res = sampled_periodic_lqr(A, B, t, np.eye(2), np.eye(1))
    closed = A - B @ res.K
    expected = np.linalg.eigvals(discrete_monodromy(closed, t))
    # Zero-order hold on the left sample vs the interval mean: O(h) apart (0.9 % here).
    np.testing.assert_allclose(
        np.sort(np.abs(res.floquet_multipliers)), np.sort(np.abs(expected)), rtol=0.02
    )
