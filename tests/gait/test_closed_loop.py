"""Closed-loop simulation machinery: controller inside the integrator, events, belt, seeds."""

from pathlib import Path

import numpy as np
import pytest
import scipy.optimize

from colloc.data.belt import perturbation_belt_speed
from colloc.gait.closed_loop import c_compiler, simulate_walking
from colloc.gait.design import JOINT_STATES, design_controller
from colloc.gait.orbit import GaitDynamics
from colloc.gait.strikes import (
    LANDING_FORCE,
    StrikeDetector,
    strike_phase,
    threshold_crossing,
)
from colloc.gait.walking_cycle import WalkingCycle

BELT_FILE = (  # the copy the package ships (src/colloc/gait/reference/SOURCE.md)
    Path(__file__).resolve().parents[2] / "src/colloc/gait/reference/RandomSlowSpeed1.txt"
)


@pytest.fixture(scope="module")
def dyn() -> GaitDynamics:
    return GaitDynamics.build()


@pytest.fixture(scope="module")
def standing(dyn) -> WalkingCycle:
    def accel(z):
        return np.asarray(dyn.rhs(_state(z), z[1:7], 0.0)).ravel()[9:]

    z = scipy.optimize.least_squares(accel, np.r_[0.93, np.zeros(7)]).x
    x = _state(z)
    return WalkingCycle(
        times=np.linspace(0, 1.0, 11),
        states=np.repeat(x[None], 11, 0),
        torques=np.repeat(z[None, 1:7], 11, 0),
        contact_forces=np.repeat(np.asarray(dyn.contact_forces(x, 0.0)).T, 11, 0),
        belt_speed=0.0,
        duration=1.0,
    )


def _state(z):
    x = np.zeros(18)
    x[1] = z[0]
    x[3:9] = [0.1, -0.1, z[7], 0.1, -0.1, z[7]]
    return x


@pytest.fixture(scope="module")
def controller(dyn, standing):
    return design_controller(standing, 8, dynamics=dyn)


def test_equilibrium_stays_put_and_carries_body_weight(dyn, standing, controller):
    _, Tstar, K, _ = controller
    rec = simulate_walking(standing, Tstar, K, 0.5, dynamics=dyn)
    assert not rec.fell
    np.testing.assert_allclose(
        rec.states, np.repeat(standing.states[:1], rec.times.size, 0), atol=1e-6
    )
    weight = dyn.gait.total_mass.subs(dyn.constants) * 9.81
    np.testing.assert_allclose(rec.vertical_grf.sum(1), float(weight), rtol=1e-6)
    np.testing.assert_allclose(rec.phase, np.minimum(rec.times / standing.duration, 1.0))


def test_recorded_torques_follow_the_gain_scheduled_law(dyn, standing, controller):
    ctrl, Tstar, K, _ = controller
    x0 = standing.states[0].copy()
    x0[12:18] += [0.2, -0.2, 0.1, -0.1, 0.2, 0.0]
    rec = simulate_walking(standing, Tstar, K, 0.2, dynamics=dyn, initial_state=x0)
    expected = ctrl.torque(rec.phase, rec.states[:, JOINT_STATES], Tstar, K)
    np.testing.assert_allclose(rec.torques, expected, rtol=1e-9, atol=1e-9)
    # The states move (the check above is not on a constant record).
    assert np.ptp(rec.states[:, 12]) > 0.05


def test_seeded_motor_noise_is_reproducible(dyn, standing, controller):
    _, Tstar, K, _ = controller
    runs = [
        simulate_walking(standing, Tstar, K, 0.1, dynamics=dyn, seed=s, torque_noise=2.0)
        for s in (5, 5, 6)
    ]
    np.testing.assert_array_equal(runs[0].states, runs[1].states)
    assert np.abs(runs[0].states - runs[2].states).max() > 1e-6


def test_threshold_crossing_is_interpolated():
    assert threshold_crossing(1.0, 1.01, 5.0, 45.0, 25.0) == pytest.approx(1.005)
    assert threshold_crossing(1.0, 1.01, 30.0, 45.0, 25.0) is None
    assert threshold_crossing(1.0, 1.01, 45.0, 5.0, 25.0) is None


def test_strike_phase_is_where_the_detector_fires_on_the_cycle(standing):
    # Right foot: unloaded, then a ramp from 0 to 800 N between nodes 2 and 3 (t = 0.2, 0.3
    # of a 1 s stride), so the 100 N crossing is at t = 0.2 + 0.1 * 100 / 800; an earlier
    # graze below the threshold (60 N at node 1) does not count.
    forces = np.zeros((11, 8))
    forces[:, 1] = [0.0, 60.0, 0.0] + [800.0] * 8
    cycle = WalkingCycle(
        standing.times, standing.states, standing.torques, forces, 0.0, standing.duration
    )
    assert strike_phase(cycle, 100.0) == pytest.approx(0.2 + 0.1 / 8)
    assert strike_phase(cycle, 50.0) == pytest.approx(0.1 * 50 / 60)
    # Never crossed (the standing fixture is loaded throughout): phase 0.
    assert strike_phase(standing, 100.0) == 0.0


def test_perturbation_record_is_rescaled_and_continued_mirrored():
    t, v = perturbation_belt_speed(BELT_FILE, 1.0, 800.0)
    assert t[-1] == pytest.approx(800.0) and np.diff(t) == pytest.approx(0.01)
    first = v[t <= 349.99]
    assert first.mean() == pytest.approx(1.0, abs=0.01)
    # Mirrored continuation: no jump where the record ends, and v(L + d) == v(L - d).
    length = 349.995
    np.testing.assert_allclose(
        np.interp(length + 3.0, t, v), np.interp(length - 3.0, t, v), atol=5e-3
    )
    assert np.abs(np.diff(v)).max() < 0.1


def test_bad_arguments_are_all_reported(standing):
    with pytest.raises(ValueError, match=r"K: expected shape \(4, 6, n_s\).*duration: expected"):
        simulate_walking(standing, np.zeros((4, 6)), np.zeros((3, 6, 12)), -1.0)
    with pytest.raises(ValueError, match="K: has 11 gain columns but feedback names 12 states"):
        simulate_walking(standing, np.zeros((4, 6)), np.zeros((4, 6, 11)), 1.0)
    with pytest.raises(ValueError, match=r"belt_speed: expected samples covering \[0, 5"):
        simulate_walking(
            standing,
            np.zeros((4, 6)),
            np.zeros((4, 6, 12)),
            5.0,
            belt_speed=(np.array([0.0, 1.0]), np.array([1.0, 1.0])),
        )
    with pytest.raises(ValueError, match="torque_noise: expected a non-negative"):
        simulate_walking(standing, np.zeros((4, 6)), np.zeros((4, 6, 12)), 1.0, torque_noise=-1)
    with pytest.raises(ValueError, match="duration: expected a positive number"):
        perturbation_belt_speed(BELT_FILE, 1.2, 0.0)


def test_the_record_carries_each_foots_ground_reaction(dyn, standing, controller):
    _, Tstar, K, _ = controller
    rec = simulate_walking(standing, Tstar, K, 0.3, dynamics=dyn)
    grf = rec.ground_reactions
    np.testing.assert_allclose(grf[:, [1, 4]], rec.vertical_grf)  # the same vertical forces
    fx = rec.contact_forces[:, 0::2]
    np.testing.assert_allclose(
        grf[:, [0, 3]], np.column_stack([fx[:, :2].sum(1), fx[:, 2:].sum(1)])
    )
    # standing on both feet: each centre of pressure lies between its heel and toe
    x = np.asarray(dyn.contact_positions.map(rec.times.size)(rec.states.T)).T
    for cop, heel, toe in ((grf[:, 2], x[:, 0], x[:, 1]), (grf[:, 5], x[:, 2], x[:, 3])):
        assert np.all((cop >= np.minimum(heel, toe) - 1e-9) & (cop <= np.maximum(heel, toe) + 1e-9))


def test_a_joint_that_turns_over_is_a_fall_even_when_the_hip_holds(dyn, standing, controller):
    """A diverging simulation once kept its hip in range while an ankle spun to 22 rad; the
    trial writer caught it as "degrees?". A half turn of any joint now ends the walk."""
    _, Tstar, K, _ = controller
    spin = Tstar.copy()
    spin[:, 2] += 400.0  # the right ankle's torque: the foot spins about the ankle
    rec = simulate_walking(
        standing, spin, np.zeros_like(K), 0.5, dynamics=dyn, hip_height_range=(0.0, 3.0)
    )
    assert rec.fell and "the right ankle turned to" in rec.message, rec.message
    assert "degrees of dorsiflexion (beyond +/-180)" in rec.message, rec.message
    assert np.all(np.abs(rec.states[:-1, 2:9]) <= np.pi)


def test_an_integrator_failure_is_said_in_the_integrators_words_not_casadis_call_chain():
    from colloc.gait.closed_loop import _solver_says

    chain = (
        "Error in Function::call for 'walk' [CvodesInterface] at .../function.cpp:1655:\n"
        "Error in Function::call for 'walk' [CvodesInterface] at .../function.cpp:514:\n"
        '.../cvodes_interface.cpp:403: CVode returned "{}". Consult CVODES documentation.'
    )
    said = _solver_says(RuntimeError(chain.format("CV_TOO_MUCH_WORK")))
    assert said.startswith("CVODES took too many steps") and "function.cpp" not in said
    assert _solver_says(RuntimeError(chain.format("CV_CONV_FAILURE"))) == "CVODES: CV_CONV_FAILURE"
    assert _solver_says(RuntimeError("plain words")) == "plain words"


def test_jit_needs_a_compiler_and_is_said_in_the_stats(dyn, standing, controller, monkeypatch):
    _, Tstar, K, _ = controller
    monkeypatch.setenv("CC", "no-such-compiler-colloc")
    assert c_compiler() is None
    with pytest.raises(ValueError, match="jit: True needs a C compiler"):
        simulate_walking(standing, Tstar, K, 0.1, dynamics=dyn, jit=True)
    with pytest.raises(ValueError, match="jit: expected True, False or None"):
        simulate_walking(standing, Tstar, K, 0.1, dynamics=dyn, jit="yes")
    # a compiler that fails: the walk falls back to the interpreted expression, unchanged
    monkeypatch.setenv("CC", "false")
    assert c_compiler() is not None
    fallback = simulate_walking(standing, Tstar, K, 0.2, dynamics=dyn, jit=True)
    plain = simulate_walking(standing, Tstar, K, 0.2, dynamics=dyn, jit=False)
    assert fallback.stats["compiled"] is False and plain.stats["compiled"] is False
    np.testing.assert_array_equal(fallback.states, plain.states)
    # a short walk is not compiled by default (compiling costs more than it saves)
    short = simulate_walking(standing, Tstar, K, 0.2, dynamics=dyn)
    assert short.stats["compiled"] is False


@pytest.mark.slow
def test_the_compiled_walk_is_the_interpreted_walk(dyn, standing, controller):
    _, Tstar, K, _ = controller
    x0 = standing.states[0].copy()
    x0[12:18] += [0.2, -0.2, 0.1, -0.1, 0.2, 0.0]
    runs = [
        simulate_walking(
            standing, Tstar, K, 0.5, dynamics=dyn, initial_state=x0, torque_noise=2.0, jit=jit
        )
        for jit in (True, False)
    ]
    assert [r.stats["compiled"] for r in runs] == [True, False]
    assert np.ptp(runs[1].states[:, 12]) > 0.05  # the walk moves
    # the same expression, evaluated in C: agreement to CVODES' tolerance (rtol 1e-6)
    np.testing.assert_allclose(runs[0].states, runs[1].states, rtol=1e-5, atol=1e-6)


def test_a_toe_grazing_the_belt_is_not_a_heel_strike():
    detector = StrikeDetector(100.0)
    # swing toe grazes: the foot's force passes 100 N on the toe alone, then falls
    assert detector.update(0.00, 0.01, 60.0, 108.0, 0.0) is None
    assert detector.update(0.01, 0.02, 108.0, 70.0, 0.0) is None
    assert detector.pending is None
    # a heel strike: the crossing, interpolated, at once (the toe is in the air)
    assert detector.update(0.10, 0.11, 50.0, 250.0, 250.0) == pytest.approx(0.1025)
    # mid-stance the heel leaves and strikes again while the toe holds the load: no crossing
    assert detector.update(0.30, 0.31, 600.0, 700.0, 650.0) is None


def test_a_foot_landing_toe_first_strikes_when_its_heel_or_its_load_says_so():
    detector = StrikeDetector(100.0)
    assert detector.update(0.00, 0.01, 0.0, 120.0, 10.0) is None  # toe first
    assert detector.update(0.01, 0.02, 120.0, 200.0, 70.0) is None  # heel 35 %
    # the heel carries half: the strike is the foot's crossing, reported now
    assert detector.update(0.02, 0.03, 200.0, 260.0, 130.0) == pytest.approx(0.01 / 1.2)
    assert detector.pending is None
    # a foot landing on its toe and staying there: a strike once it bears LANDING_FORCE
    detector = StrikeDetector(100.0)
    assert detector.update(1.00, 1.01, 50.0, 150.0, 0.0) is None
    assert detector.update(1.01, 1.02, 150.0, LANDING_FORCE - 1.0, 0.0) is None
    assert detector.update(1.02, 1.03, LANDING_FORCE - 1.0, LANDING_FORCE, 0.0) == (
        pytest.approx(1.005)
    )
