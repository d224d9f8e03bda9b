"""The designed controller walks the gait model: closed-loop runs on real walking cycles.

Both use a stored cycle (``data/walking_cycle_60.npz``, see ``data/SOURCE.md``): the fast
test follows one stride, the slow one walks 20 s on a constant-speed belt.
"""

from pathlib import Path

import numpy as np
import pytest

from colloc.gait.closed_loop import simulate_walking
from colloc.gait.design import design_controller
from colloc.gait.orbit import GaitDynamics
from colloc.gait.strikes import strike_phase
from colloc.gait.walking_cycle import WalkingCycle

CYCLE_FILE = Path(__file__).resolve().parent / "data" / "walking_cycle_60.npz"
#: Full-state feedback (all states but the hip's forward position).
FULL_STATE = np.arange(1, 18)
#: Torque weight that walks (R = I / 5^2, the design default; I / 50^2 gives gains up to
#: 1.4e4 and a closed loop that CVODES cannot follow through heel strike).
R_WALK = np.eye(6) / 5.0**2


@pytest.fixture(scope="module")
def dyn() -> GaitDynamics:
    return GaitDynamics.build()


def _walk(cycle, dyn, duration, num_points, belt=None):
    _, Tstar, K, info = design_controller(
        cycle, num_points, R=R_WALK, dynamics=dyn, num_samples=241, feedback=FULL_STATE
    )
    assert info.spectral_radius < 1
    return simulate_walking(cycle, Tstar, K, duration, belt, dynamics=dyn, feedback=FULL_STATE)


def test_first_stride_follows_the_cycle_and_the_phase_resets_to_its_strike_phase(dyn):
    cycle = WalkingCycle.from_npz(CYCLE_FILE)
    rec = _walk(cycle, dyn, 1.3, 120)
    assert not rec.fell
    stride = rec.times <= 1.15
    reference = cycle.state_at(rec.times[stride] / cycle.duration)
    # The continuous model's stride differs from the 20-ms BackwardEuler cycle (measured:
    # up to 0.21 rad in the right ankle around toe-off, 0.025 rad in the trunk, 11 mm in
    # hip height); open loop it leaves the cycle by 0.16 rad within 40 ms.
    assert np.abs(rec.states[stride, 3:9] - reference[:, 3:9]).max() < 0.25  # joints, rad
    assert np.abs(rec.states[stride, 2] - reference[:, 2]).max() < 0.05  # trunk, rad
    assert np.abs(rec.states[stride, 1] - reference[:, 1]).max() < 0.02  # hip height, m
    # The detector fires on the simulation near where it fires on the cycle, and from there
    # the controller's phase continues at phi_0 (not 0) of the next stride.
    phi0 = strike_phase(cycle)
    assert 0.0 < phi0 < 0.05
    first = rec.right_heel_strikes[0]
    # The heel loads more slowly than on the cycle's coarse grid: 29 ms instead of 11 ms.
    assert first == pytest.approx(phi0 * cycle.duration, abs=0.025)
    after = np.searchsorted(rec.times, first) + 1
    expected = 1 + phi0 + (rec.times[after] - first) / cycle.duration
    assert rec.phase[after] == pytest.approx(expected, abs=1e-9)


@pytest.mark.slow
def test_the_controller_walks_20_s_and_every_stride_is_detected(dyn):
    cycle = WalkingCycle.from_npz(CYCLE_FILE)
    rec = _walk(cycle, dyn, 20.0, 200)
    assert not rec.fell, rec.message
    strides = np.diff(rec.right_heel_strikes)
    # One right heel strike per stride, none missed, none doubled.
    assert rec.right_heel_strikes.size == pytest.approx(20.0 / cycle.duration, abs=1.5)
    assert np.all(np.abs(strides / cycle.duration - 1) < 0.1)
    left = rec.left_heel_strikes
    assert left.size == pytest.approx(rec.right_heel_strikes.size, abs=1)
    qay = rec.states[:, 1]
    assert (
        cycle.states[:, 1].min() - 0.05 < qay.min() and qay.max() < cycle.states[:, 1].max() + 0.05
    )


@pytest.mark.slow
def test_the_default_trial_walks_the_perturbed_belt(tmp_path):
    """``colloc gait simulate`` defaults, 60 s: no fall, every stride detected."""
    from colloc.gait.workflow import GaitSimulationSettings, simulate_trial

    settings = GaitSimulationSettings(duration=60.0, out=tmp_path, animation_seconds=1.0)
    result = simulate_trial(settings)
    assert not result.fell, result.summary["message"]
    record = result.record
    strides = np.diff(record.right_heel_strikes)
    assert np.all((strides > 0.9) & (strides < 1.5))
    assert record.right_heel_strikes.size == pytest.approx(60.0 / result.cycle.duration, abs=3)
    assert result.summary["cycle"]["settle_residual"] < 1e-3
    assert result.design_info.spectral_radius < 1
