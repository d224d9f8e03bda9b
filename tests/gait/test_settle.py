"""settle_cycle: the settled stride is a periodic trajectory of the continuous model."""

from pathlib import Path

import numpy as np
import pytest
import scipy.integrate

from colloc.gait.design import ALL_STATES, REGULATED, design_controller
from colloc.gait.orbit import GaitDynamics
from colloc.gait.settle import CycleNotSettledError, settle_cycle
from colloc.gait.strikes import strike_phase
from colloc.gait.walking_cycle import WalkingCycle

CYCLE_FILE = Path(__file__).resolve().parent / "data" / "walking_cycle_60.npz"


@pytest.fixture(scope="module")
def dyn() -> GaitDynamics:
    return GaitDynamics.build()


@pytest.fixture(scope="module")
def cycles(dyn):
    cycle = WalkingCycle.from_npz(CYCLE_FILE)
    _, Tstar, K, info = design_controller(
        cycle, 120, dynamics=dyn, num_samples=241, feedback=ALL_STATES
    )
    # The hip-position mode (neutral, multiplier 1, without position feedback) is included
    # and regulated.
    assert info.multipliers.size == 18 and info.spectral_radius < 1
    assert np.all(K[:, :, 0] != 0.0)
    return cycle, settle_cycle(cycle, Tstar, K, ALL_STATES, dynamics=dyn, num_strides=8)


def test_settled_cycle_repeats_and_keeps_the_phase_origin(cycles):
    old, new = cycles
    assert new.stats["settle_residual"] < 1e-3
    assert np.abs(new.states[-1, 1:] - new.states[0, 1:]).max() < 1e-3
    assert new.states[0, 0] == 0.0
    # The hip's place on the treadmill is regulated too: the stride hardly drifts (measured
    # 1.3 mm per stride after 8 strides; 8.5 mm with the position left out).
    assert abs(new.stats["hip_drift_per_stride"]) < 3e-3
    assert new.times[0] == 0.0 and new.times[-1] == pytest.approx(new.duration)
    np.testing.assert_allclose(np.diff(new.times), 1e-3, rtol=0.01)
    # Same gait: the stride is within a few percent of the collocation cycle's, and the
    # right heel strikes at the same phase.
    assert new.duration == pytest.approx(old.duration, rel=0.05)
    assert strike_phase(new) == pytest.approx(strike_phase(old), abs=0.01)
    assert np.abs(new.state_at(0.5)[3:9] - old.state_at(0.5)[3:9]).max() < 0.15


def test_settled_cycle_is_a_trajectory_of_the_model_with_its_torques(cycles, dyn):
    """Replayed open loop by a second integrator (SciPy Radau), it stays on the stride."""
    old, new = cycles
    span = 0.05

    def replay(cycle):
        def torque(t):
            return np.array([np.interp(t, cycle.times, cycle.torques[:, j]) for j in range(6)])

        def rhs(t, x):
            return np.asarray(dyn.rhs(x, torque(t), cycle.belt_speed)).ravel()

        sol = scipy.integrate.solve_ivp(
            rhs, (0.0, span), cycle.states[0], method="Radau", rtol=1e-8, atol=1e-10,
            dense_output=True,
        )  # fmt: skip
        t = cycle.times[cycle.times <= span]
        return np.abs(sol.sol(t).T[:, 2:9] - cycle.state_at(t / cycle.duration)[:, 2:9]).max()

    drift_new, drift_old = replay(new), replay(old)
    assert drift_new < 2e-3  # rad
    # The collocation cycle is not (measured: ~0.1 rad within 50 ms).
    assert drift_old > 10 * drift_new


def test_settle_refuses_bad_arguments_and_a_loop_that_falls(cycles, dyn):
    old, _ = cycles
    P = 4
    with pytest.raises(ValueError, match=r"num_strides: expected an integer >= 3.*tol: expected"):
        settle_cycle(old, np.zeros((P, 6)), np.zeros((P, 6, 17)), REGULATED, num_strides=2, tol=0)
    # Open loop (no feedback, no feedforward): the walker falls.
    with pytest.raises(CycleNotSettledError, match="did not walk 3 strides"):
        settle_cycle(
            old, np.zeros((P, 6)), np.zeros((P, 6, 17)), REGULATED, dynamics=dyn, num_strides=3
        )
