"""The whole design's information (states unknown) against generalised least squares on
exact states: when the tracked positions are nearly exact, the closed loop's Schur complement
must reduce to the schedule's regression with the motor noise as its only error."""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest

from colloc.control.gain_scheduled import GainScheduled
from colloc.control.output_feedback import schedule_weights
from colloc.data.columns import JOINT_ANGLE_COLUMNS, TORQUE_COLUMNS, TRUNK_COLUMNS
from colloc.data.trial import read_trial
from colloc.identify.gait.design_bound import (
    BoundJob,
    ClosedLoopInformation,
    LabSignals,
    WindowDesign,
    design_bound,
    full_design_bound,
    job_information,
    pieces,
)
from colloc.identify.gait.phase_law import phase_law
from colloc.identify.gait.read import state_names
from colloc.identify.gait.windows import gait_dynamics
from colloc.models.gait2d_markers import SEGMENTS

FIXTURE = Path(__file__).parent / "data" / "gait_trial_p20"  # noise-free: the true states
MOTOR = 3.0  # N m per sample


@pytest.fixture(scope="module")
def setting():
    trial = read_trial(FIXTURE)
    meta = trial.metadata
    dyn = gait_dynamics(float(meta.get("body_mass", 75.0)), float(meta.get("height", 1.8)))
    controller = meta["controller"]
    Tstar = np.asarray(controller["Tstar"], float)
    K = np.asarray(controller["K"], float)
    names = list(state_names())
    feedback = [names.index(n) for n in controller["feedback"]]
    gs = GainScheduled(Tstar.shape[0], [dyn.model.states[i] for i in feedback], dyn.gait.torques)
    rows = slice(300, 340)
    signals = trial.signals.iloc[rows]
    t = trial.time[rows]
    window = WindowDesign(
        t,
        signals[names].to_numpy(float),
        signals[list(TORQUE_COLUMNS)].to_numpy(float),
        signals["belt_speed"].to_numpy(float),
        phase_law("causal", trial).at(t, signals),
    )
    return dyn, gs, window, Tstar, K, feedback


def test_a_windows_job_travels_and_sums_its_pieces(setting):
    dyn, gs, window, Tstar, K, feedback = setting
    noise = (
        dict.fromkeys(JOINT_ANGLE_COLUMNS, 0.004)
        | dict.fromkeys(TRUNK_COLUMNS, 0.001)
        | dict.fromkeys(TORQUE_COLUMNS, 1.0)
    )
    job = BoundJob((75.0, 1.8), gs.num_points, tuple(feedback), gs.mask,
                   tuple(noise.items()), MOTOR, window, Tstar, K, nodes=20)  # fmt: skip
    travelled = pickle.loads(pickle.dumps(job))  # what a Dask worker receives
    information = ClosedLoopInformation(dyn, gs, noise, MOTOR)
    direct = sum(information(piece, Tstar, K) for piece in pieces(window, 20))
    np.testing.assert_allclose(job_information(travelled), direct, rtol=1e-9, atol=1e-9)
    calls = []

    def elsewhere(function, items):
        calls.append(len(items))
        return [function(pickle.loads(pickle.dumps(item))) for item in items]

    with pytest.raises(ValueError, match="singular"):  # 0.4 s cannot reach every point
        full_design_bound(gs, [job], elsewhere)
    assert calls == [1]


def regression_information(gs, window, feedback, motor):
    """``J^T Sigma^-1 J`` of the torques at the interval midpoints, each the law plus the
    mean of its two nodes' motor noise (so neighbouring intervals share noise)."""
    mid = lambda a: 0.5 * (a[1:] + a[:-1])  # noqa: E731
    phase, s = mid(window.phase), mid(window.states[:, feedback])
    n = phase.size
    w = schedule_weights(phase, gs.num_points)
    index = {str(p): i for i, p in enumerate(gs.parameters)}
    A = np.zeros((n, n + 1))
    A[np.arange(n), np.arange(n)] = A[np.arange(n), np.arange(n) + 1] = 0.5
    sigma_inv = np.linalg.inv(A @ A.T * motor**2)
    info = np.zeros((len(index), len(index)))
    for j in range(len(gs.inputs)):
        J = np.zeros((n, len(index)))
        for p in range(gs.num_points):
            J[:, index[f"T_{p}_{j}"]] = w[:, p]
            for i in range(len(feedback)):
                J[:, index[f"K_{p}_{j}_{i}"]] = -w[:, p] * s[:, i]
        info += J.T @ sigma_inv @ J
    return info


def test_nearly_exact_positions_leave_the_motor_noise_regression(setting):
    dyn, gs, window, Tstar, K, feedback = setting
    # positions to a micrometre, no torques tracked: the dynamics give the torques exactly
    noise = dict.fromkeys(JOINT_ANGLE_COLUMNS, 1e-6) | dict.fromkeys(TRUNK_COLUMNS, 1e-6)
    info = ClosedLoopInformation(dyn, gs, noise, MOTOR)(window, Tstar, K)
    reference = regression_information(gs, window, feedback, MOTOR)
    seen = np.flatnonzero(np.diag(reference) > 0)
    assert 0 < seen.size < len(gs.parameters)  # 0.4 s reach some schedule points, not all
    np.testing.assert_allclose(np.delete(np.delete(info, seen, 0), seen, 1), 0.0, atol=1e-9)
    block, ref = info[np.ix_(seen, seen)], reference[np.ix_(seen, seen)]
    # measured 1.7 % apart (trace 0.991): the midpoint rule pins the node speeds' odd-even
    # mode, and with it the accelerations, only through the motor noise's prior
    assert np.linalg.norm(block - ref) < 0.03 * np.linalg.norm(ref)
    assert 0.97 < np.trace(block) / np.trace(ref) <= 1.0 + 1e-9
    # and the check can fail: the same regression with the noise 10 % smaller
    assert np.linalg.norm(block - ref / 0.81) > 0.1 * np.linalg.norm(ref)


def test_noisier_positions_carry_less_information(setting):
    dyn, gs, window, Tstar, K, _ = setting
    exact = dict.fromkeys(JOINT_ANGLE_COLUMNS, 1e-6) | dict.fromkeys(TRUNK_COLUMNS, 1e-6)
    lab = dict.fromkeys(JOINT_ANGLE_COLUMNS, np.deg2rad(0.25)) | dict.fromkeys(TRUNK_COLUMNS, 1e-3)
    more = ClosedLoopInformation(dyn, gs, exact, MOTOR)(window, Tstar, K)
    less = ClosedLoopInformation(dyn, gs, lab, MOTOR)(window, Tstar, K)
    # Loewner order: more - less is positive semi-definite
    gap = np.linalg.eigvalsh(more - less)
    assert gap.min() > -1e-6 * gap.max() and gap.max() > 0


def test_bad_noise_is_named(setting):
    dyn, gs, *_ = setting
    with pytest.raises(ValueError, match="motor_noise: expected a standard deviation > 0"):
        ClosedLoopInformation(dyn, gs, {"right_hip_angle": 0.01}, 0.0)
    with pytest.raises(ValueError, match="noise: no tracked signal is named right_elbow_angle"):
        ClosedLoopInformation(dyn, gs, {"right_elbow_angle": 0.01}, 3.0)
    with pytest.raises(ValueError, match="expected standard deviations > 0"):
        ClosedLoopInformation(dyn, gs, {"right_hip_angle": -1.0}, 3.0)
    with pytest.raises(ValueError, match="singular"):
        design_bound([np.zeros((3, 3))])


def lab_design(marker_std, plate_std=None):
    """Two markers on every segment, off its axis (so each segment's pose is fixed by them)."""
    segments = tuple((f"{seg}_{k}", seg) for seg in SEGMENTS for k in (0, 1))
    local = tuple(
        (name, (0.05 + 0.1 * k, -0.2 + 0.25 * k if "foot" not in name else 0.02 * k))
        for (name, _), k in zip(segments, [0, 1] * len(SEGMENTS), strict=True)
    )
    return LabSignals(segments, local, (("l_thigh", 0.44),), marker_std, plate_std)


def test_nearly_exact_markers_leave_the_motor_noise_regression(setting):
    """A marker to a micrometre on every segment fixes every coordinate as the angles to a
    micrometre do: the lab design's information must come to the same regression."""
    dyn, gs, window, Tstar, K, feedback = setting
    lab = lab_design(1e-6)
    information = ClosedLoopInformation(dyn, gs, {}, MOTOR, lab=lab)
    assert len(information.tracked) == 4 * len(SEGMENTS)
    # the subject's constant replaces gait2d's own
    assert information.constants[dyn.gait.segment_symbols.l_thigh] == 0.44
    reference = regression_information(gs, window, feedback, MOTOR)
    seen = np.flatnonzero(np.diag(reference) > 0)
    info = information(window, Tstar, K)
    block, ref = info[np.ix_(seen, seen)], reference[np.ix_(seen, seen)]
    assert np.linalg.norm(block - ref) < 0.03 * np.linalg.norm(ref)
    assert 0.97 < np.trace(block) / np.trace(ref) <= 1.0 + 1e-9


def test_plates_and_seen_markers_add_information_hidden_ones_none(setting):
    dyn, gs, window, Tstar, K, _ = setting
    N = window.times.size
    markers = ClosedLoopInformation(dyn, gs, {}, MOTOR, lab=lab_design(1e-3))
    plates = ClosedLoopInformation(dyn, gs, {}, MOTOR, lab=lab_design(1e-3, (2.0, 1.0)))
    assert len(plates.tracked) == len(markers.tracked) + 6
    alone = markers(window, Tstar, K)
    both = plates(window, Tstar, K)
    gap = np.linalg.eigvalsh(both - alone)  # Loewner order: the plates add, never take
    assert gap.min() > -1e-6 * gap.max() and gap.max() > 0.05 * np.linalg.eigvalsh(alone).max()
    # every sample marked seen is the window without a mask
    everywhere = np.ones((N, 4 * len(SEGMENTS)), bool)
    seen = WindowDesign(window.times, window.states, window.torques, window.belt_speed,
                        window.phase, everywhere)  # fmt: skip
    np.testing.assert_allclose(markers(seen, Tstar, K), alone, rtol=1e-8, atol=1e-8)
    # the trunk's markers hidden for the first half: less information, and the built problem
    # is reused with the new mask
    hidden = seen.observed.copy()
    hidden[: N // 2, :4] = False
    part = WindowDesign(seen.times, seen.states, seen.torques, seen.belt_speed, seen.phase, hidden)
    less = markers(part, Tstar, K)
    assert len(markers._built) == 1
    gap = np.linalg.eigvalsh(alone - less)
    assert gap.min() > -1e-6 * gap.max() and gap.max() > 0
    with pytest.raises(ValueError, match="window.observed: expected shape"):
        markers(WindowDesign(seen.times, seen.states, seen.torques, seen.belt_speed,
                             seen.phase, hidden[:, :3]), Tstar, K)  # fmt: skip


def test_a_lab_design_travels_to_a_worker(setting):
    from colloc.transcription import Trapezoidal

    dyn, gs, window, Tstar, K, feedback = setting
    lab = lab_design(1e-3, (2.0, 1.0))
    job = BoundJob((75.0, 1.8), gs.num_points, tuple(feedback), gs.mask, (), MOTOR, window,
                   Tstar, K, nodes=20, lab=lab, scheme=Trapezoidal)  # fmt: skip
    travelled = pickle.loads(pickle.dumps(job))
    information = ClosedLoopInformation(dyn, gs, {}, MOTOR, Trapezoidal(), lab)
    direct = sum(information(piece, Tstar, K) for piece in pieces(window, 20))
    np.testing.assert_allclose(job_information(travelled), direct, rtol=1e-9, atol=1e-9)


def test_a_bad_lab_design_is_named(setting):
    dyn, gs, *_ = setting
    with pytest.raises(ValueError, match="unknown constants \\['l_arm'\\]"):
        bad = LabSignals((("a", "trunk"),), (("a", (0.0, 0.1)),), (("l_arm", 0.3),), 1e-3, None)
        ClosedLoopInformation(dyn, gs, {}, MOTOR, lab=bad)
    with pytest.raises(ValueError, match="noise levels > 0"):
        ClosedLoopInformation(dyn, gs, {}, MOTOR, lab=lab_design(1e-3, (0.0, 1.0)))
    with pytest.raises(ValueError, match="at least one tracked signal"):
        ClosedLoopInformation(dyn, gs, {}, MOTOR)
