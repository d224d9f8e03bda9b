"""periodic_output_feedback against an analytic cost, the algebraic LQR and Floquet theory."""

import numpy as np
import pytest

from colloc.control.lqr import lqr
from colloc.control.output_feedback import periodic_output_feedback, schedule_weights
from colloc.control.periodic_lqr import discrete_monodromy


def constant(num: int, a: np.ndarray, b: np.ndarray, period: float = 1.0):
    t = np.linspace(0.0, period, num)
    return t, np.repeat(a[None], num, axis=0), np.repeat(b[None], num, axis=0)


def test_schedule_weights_interpolate_linearly_and_periodically():
    w = schedule_weights(np.array([0.0, 0.125, 0.9, 1.0, 1.3]), 4)
    values = np.array([10.0, 20.0, 30.0, 40.0])  # at phi = 0, 0.25, 0.5, 0.75
    np.testing.assert_allclose(w.sum(axis=1), 1.0)
    np.testing.assert_allclose(
        w @ values, [10.0, 15.0, 0.4 * 40 + 0.6 * 10, 10.0, 0.8 * 20 + 0.2 * 30]
    )


def test_initial_cost_matches_the_scalar_closed_form():
    """x' = a x + b u, u = -k x: J = (q + r k^2) x0^2 (1 - e^{2 c H}) / (-2 c), c = a - b k."""
    a, b, k, q, r, horizon = 0.5, 2.0, 1.5, 3.0, 0.7, 2
    t, A, B = constant(801, np.array([[a]]), np.array([[b]]))
    res = periodic_output_feedback(
        A, B, t, [[q]], [[r]], [0], np.full((3, 1, 1), k), horizon=horizon, X0=[[1.0]], max_iter=1
    )
    c = a - b * k
    exact = (q + r * k**2) * (1 - np.exp(2 * c * horizon)) / (-2 * c)
    # Trapezoidal rule in the state and the cost: O(h^2).
    assert res.initial_log_cost == pytest.approx(np.log(exact), abs=1e-4)


def test_disturbance_cost_matches_the_scalar_closed_form():
    """x' = c x + d w: S(t) = e^{2ct} S0 + d^2 (e^{2ct} - 1) / (2c), J = (q + r k^2) int S."""
    a, b, k, q, r, d, horizon = 0.5, 2.0, 1.5, 3.0, 0.7, 0.8, 2
    t, A, B = constant(801, np.array([[a]]), np.array([[b]]))
    D = np.full((t.size, 1, 1), d)
    res = periodic_output_feedback(
        A, B, t, [[q]], [[r]], [0], np.full((3, 1, 1), k), horizon=horizon, X0=[[1.0]],
        disturbance=D, max_iter=1,
    )  # fmt: skip
    c, T = a - b * k, float(horizon)
    grow = np.expm1(2 * c * T) / (2 * c)
    exact = (q + r * k**2) * (grow + d**2 / (2 * c) * (grow - T))
    assert res.initial_log_cost == pytest.approx(np.log(exact), abs=1e-4)
    with pytest.raises(ValueError, match=r"disturbance: expected shape \(801, 1, d\)"):
        periodic_output_feedback(
            A, B, t, [[q]], [[r]], [0], np.full((3, 1, 1), k), disturbance=np.ones((5, 1, 1))
        )


def test_full_state_feedback_recovers_the_algebraic_lqr_gain():
    """Time-invariant double integrator, long horizon: the tuned constant gain is the CARE gain."""
    a = np.array([[0.0, 1.0], [0.0, 0.0]])
    b = np.array([[0.0], [1.0]])
    q, r = np.diag([4.0, 1.0]), np.array([[0.5]])
    t, A, B = constant(201, a, b, period=2.0)
    reference = lqr(a, b, q, r).K
    start = np.repeat((0.5 * reference)[None], 2, axis=0)
    res = periodic_output_feedback(A, B, t, q, r, [0, 1], start, horizon=8, max_iter=300)
    assert res.log_cost < res.initial_log_cost
    np.testing.assert_allclose(res.K[0], reference, rtol=0.02)
    np.testing.assert_allclose(res.K[1], reference, rtol=0.02)


def mathieu(num: int):
    """x'' + (0.25 + 0.3 cos t) x = u over one period: unstable open loop (first tongue)."""
    t = np.linspace(0.0, 2 * np.pi, num)
    A = np.zeros((num, 2, 2))
    A[:, 0, 1] = 1.0
    A[:, 1, 0] = -(0.25 + 0.3 * np.cos(t))
    B = np.zeros((num, 2, 1))
    B[:, 1, 0] = 1.0
    return t, A, B


def radius(t, A, B, K, feedback):
    w = schedule_weights((t - t[0]) / (t[-1] - t[0]), K.shape[0])
    gains = np.einsum("np,pij->nij", w, K)
    full = np.zeros((t.size, B.shape[2], A.shape[1]))
    full[:, :, feedback] = gains
    return np.max(np.abs(np.linalg.eigvals(discrete_monodromy(A - B @ full, t))))


def test_rate_only_feedback_stabilises_the_mathieu_oscillator():
    t, A, B = mathieu(401)
    start = np.zeros((8, 1, 1))
    assert radius(t, A, B, start, [1]) > 1.0  # open loop unstable
    res = periodic_output_feedback(
        A, B, t, np.eye(2), np.array([[1.0]]), [1], start, horizon=3, max_iter=200
    )
    assert res.log_cost < res.initial_log_cost - 1.0
    # Checked with the matrix-exponential monodromy, not the tuner's own discretisation.
    assert radius(t, A, B, res.K, [1]) < 0.9


def test_masked_gains_stay_zero_and_the_tuned_point_is_a_local_minimum():
    t, A, B = mathieu(201)
    start = np.full((4, 1, 2), 0.2)
    mask = np.array([[False, True]])
    res = periodic_output_feedback(
        A, B, t, np.eye(2), np.array([[1.0]]), [0, 1], start, mask=mask, max_iter=300
    )
    assert np.all(res.K[:, 0, 0] == 0.0)
    # No small step along a coordinate lowers the cost (finite differences of the cost).
    for p in range(4):
        for step in (-1e-2, 1e-2):
            trial = res.K.copy()
            trial[p, 0, 1] += step
            probe = periodic_output_feedback(
                A, B, t, np.eye(2), np.array([[1.0]]), [0, 1], trial, mask=mask, max_iter=1
            )
            assert probe.initial_log_cost >= res.log_cost - 1e-6


def test_bad_arguments_are_all_reported():
    t, A, B = mathieu(11)
    with pytest.raises(ValueError) as err:
        periodic_output_feedback(
            A, B[:, :, :], t, np.eye(3), -np.eye(1), [0, 5], np.zeros((2, 1, 1)), horizon=0
        )
    text = str(err.value)
    for part in (
        "Q: expected shape (2, 2)",
        "R: expected a positive definite",
        "feedback:",
        "horizon:",
    ):
        assert part in text


def test_multi_input_gain_layout_matches_the_lyapunov_cost():
    """m = 2 inputs, 2 of 3 states fed back, distinct gains: the cost the tuner evaluates is
    the continuous one, int_0^T tr(W e^{A t} X0 e^{A^T t}) dt, from a Lyapunov equation."""
    import scipy.linalg

    a = np.array([[0.0, 1.0, 0.0], [-2.0, -0.3, 1.0], [0.5, 0.0, -1.0]])
    b = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 2.0]])
    k = np.array([[1.5, -0.4], [0.3, 2.2]])  # rows: inputs; columns: states 0 and 2
    feedback = [0, 2]
    q, r = np.diag([1.0, 2.0, 3.0]), np.diag([0.5, 0.25])
    x0 = np.diag([1.0, 0.5, 2.0])
    t, A, B = constant(2001, a, b, period=2.0)
    res = periodic_output_feedback(
        A, B, t, q, r, feedback, np.repeat(k[None], 3, axis=0), X0=x0, horizon=1, max_iter=1
    )
    full = np.zeros((2, 3))
    full[:, feedback] = k
    acl = a - b @ full
    w = q + full.T @ r @ full
    end = scipy.linalg.expm(acl * 2.0)
    y = scipy.linalg.solve_continuous_lyapunov(acl, end @ x0 @ end.T - x0)
    assert res.initial_log_cost == pytest.approx(np.log(np.trace(w @ y)), abs=1e-5)
