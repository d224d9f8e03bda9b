"""The periodic walking cycle against physics it must obey but was never told.

A coarse grid with a soft contact keeps the CI solve at a few seconds; the default
settings (homotopy to the real contact) run under ``-m slow``.
"""

from __future__ import annotations

import numpy as np
import pytest

from colloc.data.records import read_winter_gait_cycle
from colloc.gait import WalkingCycle, find_walking_cycle
from colloc.gait.cycle import _plant, default_winter_path, reference_angles, stride_duration
from colloc.models.gait2d_params import load_parameters

SOFT = {"stiffness": 5e6, "friction_velocity": 0.1, "smoothing": 1e-3}
SPEED = 1.2


@pytest.fixture(scope="module")
def params():
    return load_parameters()


@pytest.fixture(scope="module")
def coarse():
    return find_walking_cycle(SPEED, 30, contact_overrides=SOFT, soft_stages=())


def body_weight(params):
    return params.total_mass * params.gravity


def backward_euler_residuals(cycle, params, overrides):
    """Kinematic and dynamic residuals of every interval, evaluated with NumPy."""
    gait, _ = _plant()
    symbols = gait.contact_symbols
    p = gait.constant_array(params, {getattr(symbols, k): v for k, v in overrides.items()})
    mass_forcing = gait.dynamics_function()
    h = np.diff(cycle.times)
    q, u = cycle.states[:, :9], cycle.states[:, 9:]
    kinematic = (q[1:] - q[:-1]) / h[:, None] - u[1:]
    dynamic = []
    for k in range(1, cycle.times.size):
        M, f = mass_forcing(q[k], u[k], cycle.torques[k], cycle.belt_speed, p)
        dynamic.append(M @ (u[k] - u[k - 1]) / h[k - 1] - f)
    return kinematic, np.array(dynamic)


def test_cycle_is_periodic_in_states_and_torques(coarse):
    assert np.max(np.abs(coarse.states[-1] - coarse.states[0])) < 1e-8
    assert np.max(np.abs(coarse.torques[-1] - coarse.torques[0])) < 1e-8
    assert coarse.states[0, 0] == pytest.approx(0.0, abs=1e-10)  # hip x pinned on the belt


def test_backward_euler_dynamics_hold_at_the_solution(coarse, params):
    kinematic, dynamic = backward_euler_residuals(coarse, params, SOFT)
    assert np.max(np.abs(kinematic)) < 1e-9
    assert np.max(np.abs(dynamic)) < 1e-6 * body_weight(params)
    # and a perturbed torque breaks them, so the check can fail
    bad = WalkingCycle(**{**coarse.__dict__, "torques": coarse.torques + 5.0})
    assert np.max(np.abs(backward_euler_residuals(bad, params, SOFT)[1])) > 1.0


def test_mean_vertical_floor_force_is_body_weight(coarse, params):
    # periodic motion: the momentum change over a stride is zero, so mean sum(Fy) = m g
    fy = coarse.contact_forces[1:, 1::2].sum(axis=1)  # backward Euler: forces act at k >= 1
    assert fy.mean() == pytest.approx(body_weight(params), rel=0.02)


def test_mean_horizontal_floor_force_vanishes(coarse, params):
    fx = coarse.contact_forces[1:, 0::2].sum(axis=1)
    assert abs(fx.mean()) < 0.01 * body_weight(params)


def test_feet_alternate_stance_like_winter(coarse, params):
    loaded = coarse.vertical_grf[:-1] > 0.05 * body_weight(params)
    for side in (0, 1):
        assert 0.5 < loaded[:, side].mean() < 0.75  # Winter: stance is ~60 % of the stride
    assert not np.any(~loaded[:, 0] & ~loaded[:, 1])  # walking has no flight phase
    assert np.any(loaded[:, 0] & ~loaded[:, 1]) and np.any(~loaded[:, 0] & loaded[:, 1])
    # right heel strike at phase 0: the right foot is loaded then, and swings at 80 %
    mid_swing = round(0.8 * (coarse.times.size - 1))
    assert loaded[0, 0] and not loaded[mid_swing, 0] and loaded[mid_swing, 1]


def test_joint_angles_follow_winter(coarse):
    reference = read_winter_gait_cycle(default_winter_path())
    winter = reference_angles(reference, coarse.times / coarse.duration)
    rms = np.sqrt(np.mean(np.rad2deg(coarse.states[:, 3:9] - winter) ** 2))
    assert rms < 4.0
    assert coarse.stats["rms_angle_error_deg"] == pytest.approx(rms, rel=0.05)


def test_duration_follows_the_cadence_rule():
    reference = read_winter_gait_cycle(default_winter_path())
    assert stride_duration(reference.walking_speed, reference) == pytest.approx(1.1396)
    # stride length = speed x duration grows as sqrt(speed): four times faster, twice as long
    ratio = (4.0 * stride_duration(4.0, reference)) / (1.0 * stride_duration(1.0, reference))
    assert ratio == pytest.approx(2.0)


def test_state_at_interpolates_nodes_and_wraps(coarse):
    phase = coarse.times[:-1] / coarse.duration
    np.testing.assert_allclose(coarse.state_at(phase), coarse.states[:-1], atol=1e-9)
    np.testing.assert_allclose(coarse.state_at(1.25), coarse.state_at(0.25), atol=1e-12)
    np.testing.assert_allclose(coarse.state_at(-1e-9), coarse.states[0], atol=1e-5)


def test_npz_round_trip(coarse, tmp_path):
    path = tmp_path / "cycle.npz"
    coarse.to_npz(path)
    back = WalkingCycle.from_npz(path)
    for name in ("times", "states", "torques", "contact_forces"):
        np.testing.assert_array_equal(getattr(back, name), getattr(coarse, name))
    assert back.belt_speed == SPEED and back.duration == coarse.duration
    assert back.stats["iterations"] == coarse.stats["iterations"]
    assert back.stats["stages"][0]["contact"] == SOFT
    assert [p.name for p in tmp_path.iterdir()] == ["cycle.npz"]  # no temp file left


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"speed": 0.0}, r"speed: expected a positive belt speed in m/s, found 0\.0"),
        ({"speed": -1.0}, r"speed: .*found -1\.0"),
        ({"speed": float("nan")}, r"speed: .*found nan"),
        ({"num_nodes": 5}, r"num_nodes: expected at least 20 nodes per stride, found 5"),
        ({"num_nodes": 40.0}, r"num_nodes: expected an integer, found 40\.0"),
        ({"duration": -1.0}, r"duration: expected a positive stride duration"),
        ({"params": {"mass": 75}}, r"params: expected Gait2DParameters"),
        (
            {"contact_overrides": {"stifness": 1e6}},
            r"contact_overrides: expected keys .*'stifness'",
        ),
        ({"contact_overrides": {"stiffness": -1.0}}, r"contact_overrides\['stiffness'\]: .*-1\.0"),
        ({"soft_stages": ({"mu": 1.0},)}, r"soft_stages\[0\]: expected keys .*'mu'"),
    ],
)
def test_bad_arguments_are_named(kwargs, match):
    with pytest.raises(ValueError, match=match):
        find_walking_cycle(**kwargs)


def test_missing_reference_file_names_the_remedy(tmp_path, monkeypatch):
    monkeypatch.setenv("COLLOC_WINTER_GAIT_CYCLE", str(tmp_path / "absent.csv"))
    with pytest.raises(FileNotFoundError, match=r"reference: .*absent\.csv.*COLLOC_WINTER_GAIT"):
        find_walking_cycle()
    with pytest.raises(FileNotFoundError, match=r"found no file at .*other\.csv"):
        find_walking_cycle(reference=tmp_path / "other.csv")


def test_all_bad_arguments_are_reported_at_once():
    with pytest.raises(ValueError, match=r"speed: .*; num_nodes: .*; duration: "):
        find_walking_cycle(speed=-1.0, num_nodes=3, duration=0.0)


def test_solver_failure_is_an_error_with_the_stage_and_progress_is_reported():
    calls = []
    with pytest.raises(RuntimeError, match=r"Maximum_Iterations_Exceeded .*contact \{'stiff"):
        find_walking_cycle(
            SPEED, 20, contact_overrides=SOFT, soft_stages=(), max_iter=3, progress=calls.append
        )
    assert [c["iteration"] for c in calls] == [0, 1, 2, 3]


@pytest.mark.slow
def test_default_cycle_is_physically_sensible(params):
    cycle = find_walking_cycle()  # homotopy to the real contact, 60 nodes
    weight = body_weight(params)
    assert np.max(np.abs(cycle.states[-1] - cycle.states[0])) < 1e-8
    kinematic, dynamic = backward_euler_residuals(cycle, params, {})
    assert np.max(np.abs(kinematic)) < 1e-9 and np.max(np.abs(dynamic)) < 1e-6 * weight
    assert cycle.contact_forces[1:, 1::2].sum(axis=1).mean() == pytest.approx(weight, rel=0.02)
    assert 1.0 < cycle.vertical_grf.max() / weight < 1.5
    assert 0.85 < cycle.states[:, 1].min() and cycle.states[:, 1].max() < 1.0  # hip height [m]
    assert 20.0 < np.abs(cycle.torques).max() < 200.0
    assert cycle.stats["rms_angle_error_deg"] < 3.0
    assert [s["status"] for s in cycle.stats["stages"]] == ["Solve_Succeeded"] * 3
