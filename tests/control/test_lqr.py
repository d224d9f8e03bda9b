"""colloc.control.lqr against a hand-solved case and python-control."""

import numpy as np
import pytest

import control
from colloc.control.lqr import LQRResult, lqr


@pytest.mark.parametrize(("q1", "q2", "r"), [(1.0, 1.0, 1.0), (4.0, 0.5, 0.25), (10.0, 0.0, 3.0)])
def test_double_integrator_closed_form(q1, q2, r):
    # Riccati equation of x'' = u solved by hand: s12 = sqrt(q1 r),
    # s22 = sqrt(r (2 s12 + q2)), s11 = s12 s22 / r.
    s12 = np.sqrt(q1 * r)
    s22 = np.sqrt(r * (2 * s12 + q2))
    s11 = s12 * s22 / r
    res = lqr([[0, 1], [0, 0]], [[0], [1]], np.diag([q1, q2]), r)
    np.testing.assert_allclose(res.S, [[s11, s12], [s12, s22]], rtol=1e-10)
    np.testing.assert_allclose(res.K, [[s12 / r, s22 / r]], rtol=1e-10)
    # Closed loop s^2 + k2 s + k1.
    expected = np.roots([1.0, s22 / r, s12 / r])
    np.testing.assert_allclose(np.sort_complex(res.eigenvalues), np.sort_complex(expected))


def test_matches_python_control_on_random_system():
    rng = np.random.default_rng(20240613)
    n, m = 5, 2
    a = rng.normal(size=(n, n))
    b = rng.normal(size=(n, m))
    c = rng.normal(size=(n, n))
    q = c @ c.T + 0.1 * np.eye(n)
    d = rng.normal(size=(m, m))
    r = d @ d.T + 0.5 * np.eye(m)
    res = lqr(a, b, q, r)
    k_ref, s_ref, e_ref = control.lqr(a, b, q, r)
    np.testing.assert_allclose(res.K, k_ref, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(res.S, s_ref, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(
        np.sort_complex(res.eigenvalues), np.sort_complex(np.asarray(e_ref)), rtol=1e-8
    )
    assert np.all(res.eigenvalues.real < 0)


def test_inverted_pendulum_is_stabilized_and_unpacks():
    g, length = 9.81, 1.0
    a = np.array([[0.0, 1.0], [g / length, 0.0]])
    b = np.array([[0.0], [1.0]])
    k, s, eig = lqr(a, b, np.eye(2), np.array([[1.0]]))
    res = lqr(a, b, np.eye(2), np.array([[1.0]]))
    assert isinstance(res, LQRResult)
    np.testing.assert_allclose(k, res.K)
    # Riccati residual vanishes: A'S + SA - S B R^-1 B' S + Q = 0.
    resid = a.T @ s + s @ a - s @ b @ b.T @ s + np.eye(2)
    np.testing.assert_allclose(resid, 0.0, atol=1e-10)
    np.testing.assert_allclose(np.sort_complex(eig), np.sort_complex(np.linalg.eigvals(a - b @ k)))
    assert "LQRResult" in repr(res)


def test_shape_errors_are_reported_together():
    with pytest.raises(ValueError, match=r"B: expected shape \(2, m\).*Q: expected shape \(2, 2\)"):
        lqr(np.zeros((2, 2)), np.zeros((3, 1)), np.eye(3), np.eye(1))


def test_nonsquare_a_and_r_mismatch():
    with pytest.raises(ValueError, match=r"A: expected a square"):
        lqr(np.zeros((2, 3)), np.zeros((2, 1)), np.eye(2), np.eye(1))
    with pytest.raises(ValueError, match=r"R: expected shape \(1, 1\).*found \(2, 2\)"):
        lqr(np.zeros((2, 2)), np.ones((2, 1)), np.eye(2), np.eye(2))
    with pytest.raises(ValueError, match=r"B: expected shape \(2, m\) \(2-D"):
        lqr(np.zeros((2, 2)), np.ones(2), np.eye(2), np.eye(1))


def test_weight_errors():
    a, b = [[0, 1], [0, 0]], [[0], [1]]
    with pytest.raises(ValueError, match=r"Q: expected a symmetric matrix"):
        lqr(a, b, [[1, 1], [0, 1]], [[1]])
    with pytest.raises(ValueError, match=r"Q: expected positive semi-definite.*-1"):
        lqr(a, b, np.diag([1.0, -1.0]), [[1]])
    with pytest.raises(ValueError, match=r"R: expected positive definite"):
        lqr(a, b, np.eye(2), [[0.0]])
    with pytest.raises(ValueError, match=r"A: expected finite entries"):
        lqr([[np.nan, 1], [0, 0]], b, np.eye(2), [[1]])
    with pytest.raises(ValueError, match=r"Q: expected a numeric array"):
        lqr(a, b, "identity", [[1]])


def test_unstabilizable_system():
    # The second state is unstable and the input cannot reach it.
    with pytest.raises(ValueError, match=r"no stabilizing solution"):
        lqr([[-1.0, 0.0], [0.0, 1.0]], [[1.0], [0.0]], np.eye(2), [[1.0]])
