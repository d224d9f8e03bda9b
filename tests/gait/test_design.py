"""Linearisation along a cycle (vs finite differences) and the controller design."""

import numpy as np
import pytest
import scipy.optimize

from colloc.gait.design import (
    JOINT_STATES,
    REGULATED,
    design_controller,
    joint_feedback_multipliers,
)
from colloc.gait.orbit import GaitDynamics, cycle_linearization
from colloc.gait.walking_cycle import WalkingCycle
from colloc.models.gait2d_params import load_parameters


@pytest.fixture(scope="module")
def dyn() -> GaitDynamics:
    return GaitDynamics.build()


@pytest.fixture(scope="module")
def standing(dyn) -> WalkingCycle:
    """Quiet standing on a belt at rest: a (trivially) periodic cycle."""

    def accel(z):
        x = standing_state(z)
        return np.asarray(dyn.rhs(x, z[1:7], 0.0)).ravel()[9:]

    z = scipy.optimize.least_squares(accel, np.r_[0.93, np.zeros(7)]).x
    x = standing_state(z)
    num, duration = 21, 1.0
    return WalkingCycle(
        times=np.linspace(0, duration, num),
        states=np.repeat(x[None], num, 0),
        torques=np.repeat(z[None, 1:7], num, 0),
        contact_forces=np.repeat(np.asarray(dyn.contact_forces(x, 0.0)).T, num, 0),
        belt_speed=0.0,
        duration=duration,
    )


def standing_state(z):
    x = np.zeros(18)
    x[1] = z[0]
    x[3:9] = [0.1, -0.1, z[7], 0.1, -0.1, z[7]]
    return x


def numpy_rhs(dyn):
    """Independent explicit dynamics from the SymPy lambdified M and f."""
    mf = dyn.gait.dynamics_function()
    p = dyn.gait.constant_array(load_parameters())

    def f(x, torque, v):
        mass, forcing = mf(x[:9], x[9:], torque, v, p)
        return np.r_[x[9:], np.linalg.solve(mass, forcing)]

    return f


def test_linearization_matches_central_differences(dyn):
    rng = np.random.default_rng(3)
    f = numpy_rhs(dyn)
    for _ in range(3):
        x = np.r_[0.0, 0.92, 0.05 * rng.standard_normal(7), 0.3 * rng.standard_normal(9)]
        torque, v = 20 * rng.standard_normal(6), 1.2
        A, B = dyn.linearize(x[None], torque[None], v)
        h = 1e-6
        A_fd = np.column_stack(
            [(f(x + h * e, torque, v) - f(x - h * e, torque, v)) / (2 * h) for e in np.eye(18)]
        )
        B_fd = np.column_stack(
            [(f(x, torque + h * e, v) - f(x, torque - h * e, v)) / (2 * h) for e in np.eye(6)]
        )
        np.testing.assert_allclose(A[0], A_fd, rtol=1e-5, atol=1e-5 * np.abs(A_fd).max())
        np.testing.assert_allclose(B[0], B_fd, rtol=1e-5, atol=1e-6 * np.abs(B_fd).max())
        np.testing.assert_allclose(
            np.asarray(dyn.rhs(x, torque, v)).ravel(), f(x, torque, v), rtol=1e-9, atol=1e-9
        )


def test_belt_sensitivity_matches_central_differences(dyn, standing):
    rng = np.random.default_rng(4)
    f = numpy_rhs(dyn)
    # Feet down and slipping slowly on the belt: friction in its smooth, unsaturated range.
    x = standing.states[0] + np.r_[np.zeros(9), 1e-3 * rng.standard_normal(9)]
    torque, v, h = 20 * rng.standard_normal(6), 0.005, 1e-6
    expected = (f(x, torque, v + h) - f(x, torque, v - h)) / (2 * h)
    assert np.abs(expected).max() > 1.0  # a foot touches: the belt speed matters
    got = dyn.belt_sensitivity(np.stack([x, x]), np.stack([torque, torque]), v)
    assert got.shape == (2, 18)
    np.testing.assert_allclose(got[0], expected, rtol=1e-5, atol=1e-6 * np.abs(expected).max())
    np.testing.assert_allclose(got[1], got[0])


def test_standing_cycle_is_an_equilibrium_and_hip_x_is_neutral(dyn, standing):
    t, A, B = cycle_linearization(dyn, standing)
    assert np.abs(np.asarray(dyn.rhs(standing.states[0], standing.torques[0], 0.0))).max() < 1e-8
    # Nothing depends on the hip's forward position: its column of A is zero.
    assert np.abs(A[:, :, 0]).max() == 0.0


def test_full_state_design_on_standing_has_constant_gains_and_exact_multipliers(dyn, standing):
    ctrl, Tstar, K, info = design_controller(standing, 8, dynamics=dyn, feedback=REGULATED)
    assert Tstar.shape == (8, 6) and K.shape == (8, 6, 17)
    s = standing.states[0, REGULATED]
    # On the cycle the controller gives the cycle's torque.
    np.testing.assert_allclose(ctrl.torque(0.3, s, Tstar, K)[0], standing.torques[0], atol=1e-8)
    # A constant cycle gives constant gains, and the full-state LQR loop is stable.
    np.testing.assert_allclose(K, np.repeat(K[:1], 8, 0), rtol=1e-6, atol=1e-6)
    assert np.max(np.abs(info.lqr_multipliers)) < 1.0
    assert "tuning" not in info.extra
    # The multipliers agree with the eigenvalues of the constant closed loop.
    t, A, B = cycle_linearization(dyn, standing)
    full = np.zeros((6, 18))
    full[:, REGULATED] = K[0]
    acl = (A[0] - B[0] @ full)[1:, 1:]
    expected = np.exp(np.linalg.eigvals(acl) * standing.duration)
    # Products of stiff matrix exponentials carry ~1e-4 round-off on tiny multipliers.
    np.testing.assert_allclose(
        np.sort(np.abs(info.multipliers)), np.sort(np.abs(expected)), rtol=1e-3, atol=1e-4
    )
    again = joint_feedback_multipliers(t, A, B, K, REGULATED)
    np.testing.assert_allclose(np.abs(again), np.abs(info.multipliers))


def test_joint_only_design_on_standing_is_tuned_to_stability(dyn, standing):
    ctrl, Tstar, K, info = design_controller(
        standing, 8, dynamics=dyn, num_samples=41, tune_iterations=40
    )
    assert K.shape == (8, 6, 12)
    s = standing.states[0, JOINT_STATES]
    np.testing.assert_allclose(ctrl.torque(0.3, s, Tstar, K)[0], standing.torques[0], atol=1e-8)
    tuning = info.extra["tuning"]
    assert tuning["log_cost"] < tuning["initial_log_cost"]
    assert info.spectral_radius < 1.0
    t, A, B = cycle_linearization(dyn, standing, 41)
    np.testing.assert_allclose(
        np.abs(joint_feedback_multipliers(t, A, B, K)), np.abs(info.multipliers)
    )
    # Belt-speed noise reaches the cost through the belt sensitivity: same start, more cost.
    *_, noisy = design_controller(
        standing, 8, dynamics=dyn, num_samples=41, tune_iterations=1, belt_noise=0.02
    )
    assert noisy.extra["tuning"]["initial_log_cost"] > tuning["initial_log_cost"] + 0.01


def test_stance_substitution_recovers_the_body_motion_that_keeps_both_feet_put(dyn, standing):
    """A perturbation that leaves both loaded feet in place: C maps its joints to its body part."""
    from colloc.gait.stance import contact_point_jacobian, substitution_matrices

    x = standing.states[0]
    G = np.asarray(contact_point_jacobian(dyn)(x))  # rows: x, y of r-heel, r-toe, l-heel, l-toe
    rng = np.random.default_rng(0)
    body = 1e-3 * rng.standard_normal(3)
    # Each leg's joints that keep its foot's two points fixed for this body motion (the foot
    # is rigid, so the four equations have rank three and are solved exactly).
    dq = np.r_[body, np.zeros(6)]
    for rows, joints in ((slice(0, 4), [3, 4, 5]), (slice(4, 8), [6, 7, 8])):
        sol, *_ = np.linalg.lstsq(G[rows][:, joints], -G[rows][:, :3] @ body, rcond=None)
        dq[joints] = sol
    assert np.abs(G @ dq).max() < 1e-12
    C = substitution_matrices(dyn, x[None], 0.0, np.arange(3, 9), regularisation=1e-9)[0]
    np.testing.assert_allclose(C @ dq[3:], body, rtol=1e-5, atol=1e-12)


def test_design_argument_errors(dyn, standing):
    with pytest.raises(ValueError, match=r"Q: expected shape \(18, 18\).*R: expected shape"):
        design_controller(standing, 8, Q=np.eye(3), R=np.eye(2), dynamics=dyn)
    with pytest.raises(ValueError, match=r"feedback: expected distinct state indices in \[0, 18\)"):
        design_controller(standing, 8, dynamics=dyn, feedback=[0, 3])
    with pytest.raises(ValueError, match=r"feedback: .*found \[3, 3\]"):
        design_controller(standing, 8, dynamics=dyn, feedback=[3, 3])
    with pytest.raises(ValueError, match=r"tune_horizon: expected an integer >= 1.*belt_noise"):
        design_controller(standing, 8, dynamics=dyn, tune_horizon=0, belt_noise=-1.0)
    with pytest.raises(ValueError, match="num_points: expected an integer >= 2"):
        design_controller(standing, 1, dynamics=dyn)
    with pytest.raises(ValueError, match="num_samples: expected an integer >= 3"):
        cycle_linearization(dyn, standing, 2)
    with pytest.raises(ValueError, match=r"states, torques: expected shapes"):
        dyn.linearize(np.zeros((2, 17)), np.zeros((2, 6)), 0.0)


def test_fitted_tstar_recovers_an_exact_schedule_and_beats_sampling_at_the_points():
    """T* in least squares: exact when the cycle's torques are a P-point schedule's, and
    never worse than sampling T_cycle + K s_cycle at the points (both scored by
    GainScheduled.torque, the controller's own interpolation)."""
    from sympy.physics.mechanics import dynamicsymbols

    from colloc.control.gain_scheduled import GainScheduled
    from colloc.gait.design import fitted_tstar

    rng = np.random.default_rng(3)
    P, n_s, num = 7, 4, 4001
    phase = np.linspace(0.0, 1.0, num)
    states = np.zeros((num, 18))
    feedback = np.array([3, 4, 12, 13])
    for j, col in enumerate(feedback):  # smooth, periodic, not linear between points
        states[:, col] = np.sin(2 * np.pi * (j + 1) * phase + j) + 0.3 * np.cos(6 * np.pi * phase)
    ctrl = GainScheduled(
        P, feedback=dynamicsymbols(f"s0:{n_s}"), inputs=dynamicsymbols("T0:6"),
        phase=dynamicsymbols("phi"),
    )  # fmt: skip
    K = rng.normal(0.0, 50.0, (P, 6, n_s))
    G = rng.normal(0.0, 20.0, (P, 6))
    # torques a P-point schedule with T* = G applies on exactly these states
    exact = ctrl.torque(phase, states[:, feedback], G, K)
    cycle = WalkingCycle(phase, states, exact, np.zeros((num, 8)), 1.0, 1.0)
    np.testing.assert_allclose(fitted_tstar(ctrl, cycle, K, feedback), G, atol=1e-8)

    # torques of no P-point schedule: the fit scores no worse than sampling at the points
    other = exact + 15.0 * np.sin(10 * np.pi * phase)[:, None]
    cycle = WalkingCycle(phase, states, other, np.zeros((num, 8)), 1.0, 1.0)
    points = np.arange(P) * (num - 1) // P
    sampled = other[points] + np.einsum("pij,pj->pi", K, states[points][:, feedback])
    fitted = fitted_tstar(ctrl, cycle, K, feedback)

    def rms(tstar):
        return np.sqrt(np.mean((ctrl.torque(phase, states[:, feedback], tstar, K) - other) ** 2))

    assert rms(fitted) < rms(sampled)
    # and it is the least-squares optimum: any nudge of one point's torque scores worse
    for p, j in [(0, 0), (3, 5), (6, 2)]:
        nudged = fitted.copy()
        nudged[p, j] += 0.5
        assert rms(nudged) > rms(fitted)
