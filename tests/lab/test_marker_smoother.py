"""The smoother that tracks a lab's raw markers and plates, against the simulated walk they
were recorded from (its true angles and torques)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from colloc.cli import main
from colloc.data.columns import JOINT_ANGLE_COLUMNS, TORQUE_COLUMNS
from colloc.gait.orbit import GaitDynamics
from colloc.identify.gait.markers import marker_smoother, tracking_fit
from colloc.lab import LabSettings, lab_export_from_record, process_lab
from colloc.models.gait2d_params import load_parameters

SUBJECT = (75.0, 1.8)  # the session walk's (tests/lab/conftest.py)


@pytest.fixture(scope="module")
def lab_trial(walk):
    export = lab_export_from_record(walk, load_parameters(*SUBJECT), seed=3)  # 1 mm, 2 N, 1 N m
    return process_lab(export, LabSettings(*SUBJECT, belt_speed="RightBeltSpeed")).trial


@pytest.fixture(scope="module")
def smoothed(lab_trial):
    smoother, facts = marker_smoother(
        GaitDynamics.build(load_parameters(*SUBJECT)), lab_trial, np.arange(lab_trial.time.size)
    )
    result = smoother.run()
    return result, facts, tracking_fit(result.problem, result.z)


def _rms(x):
    return np.sqrt(np.mean(x**2, axis=0))


def _kept(walk, trial):
    """The walk's samples the lab trial kept."""
    return np.isin(np.round(walk.times, 6), np.round(trial.time, 6))


def test_the_marker_smoother_comes_closer_to_the_walk_than_inverse_kinematics(
    walk, lab_trial, smoothed
):
    result, facts, fit = smoothed
    assert result.stages[-1].success and result.stages[-1].friction_velocity == 0.01
    # the plates at a hundredth of their weight until the contact is the model's, then whole
    assert [s.name for s in result.stages][-2:] == ["continuation", "full weights"]
    kept = _kept(walk, lab_trial)  # the lab path cuts the filter's ends
    truth = walk.states[kept, 3:9]
    ik = lab_trial.signals[list(JOINT_ANGLE_COLUMNS)].to_numpy()
    ours = np.degrees(_rms(result.states[:, 3:9] - truth))
    theirs = np.degrees(_rms(ik - truth))
    # measured: 0.09-0.21 deg against the 6 Hz inverse kinematics' 0.18-0.74 deg
    assert np.all(ours < theirs) and ours.max() < 0.3
    # torques within a few N m of the truth (the walk's own reach 100); the node torques
    # alternate node to node (measured 5.1-8.2 N m RMS), their node means, which a lab reads
    # (gait smooth's table), do not (2.0-5.1 N m)
    assert result.inputs_in_pairs
    assert _rms(result.torques - walk.torques[kept]).max() < 10.0
    torques, _ = result.node_mean_inputs()
    assert _rms(torques - walk.torques[kept]).max() < 6.0
    # the markers are followed to their noise (1 mm drawn), the plates to theirs (2 N, 1 N m)
    assert fit["marker_rms_mm"] == pytest.approx(1.0, rel=0.3)
    assert fit["plate_force_rms_n"] < 3.0 and fit["plate_moment_rms_nm"] < 2.0
    assert facts["tracked"] == "markers and plates"
    assert facts["noise"]["marker_m"] == pytest.approx(1e-3, rel=0.1)
    # the landmarks sit on their joints: the knee marker at the thigh's measured length
    knee = facts["markers"]["RLEK"]
    assert knee["segment"] == "right_thigh"
    assert knee["in_segment_m"][0] == pytest.approx(0.0, abs=2e-3)
    assert knee["in_segment_m"][1] == pytest.approx(-facts["segment_lengths_m"]["thigh"], abs=2e-3)
    # the ankle's height above the sole from the loaded feet: the walk's model had 0.0703 m
    assert facts["segment_lengths_m"]["ankle_height"] == pytest.approx(0.0703, abs=2e-3)


def test_gait_smooth_tracks_a_lab_trials_markers_by_default(lab_trial, tmp_path, capsys):
    folder = lab_trial.write(tmp_path / "lab")
    out = tmp_path / "smoothed"
    code = main(
        ["gait", "smooth", str(folder), "--out", str(out), "--start", "1.1", "--duration", "1.5"]
        + ["--no-plots"]
        + ["--noise-levels", "marker=0.002"]
    )
    assert code == 0
    summary = json.loads((out / "smooth.json").read_text())
    assert "tracked: the lab's raw markers and plates" in summary["notes"]
    tracking = summary["windows"][0]["tracking"]
    assert tracking["tracked"] == "markers and plates"
    assert tracking["noise"]["marker_m"] == 0.002  # given, not the record's 1 mm
    assert "marker given" in tracking["noise"]["source"]
    assert "force estimated from the record" in tracking["noise"]["source"]
    assert set(tracking["fit"]) == {
        "marker_rms_mm", "plate_force_rms_n", "plate_moment_rms_nm", "torque_from_prior_rms_nm",
    }  # fmt: skip


def test_without_the_plates_the_markers_alone_leave_the_torques_further_from_the_walk(
    walk, lab_trial, tmp_path
):
    folder = lab_trial.write(tmp_path / "lab")
    errors, summaries = {}, {}
    for source in ("markers", "markers-only"):
        out = tmp_path / source
        window = ["--start", "1.1", "--duration", "1.5", "--no-plots"]
        assert main(["gait", "smooth", str(folder), "--out", str(out), "--smooth-from", source]
                    + window) == 0  # fmt: skip
        summaries[source] = json.loads((out / "smooth.json").read_text())
        table = pd.read_csv(out / "smoothed.csv")
        rows = np.searchsorted(np.round(walk.times, 6), np.round(table["time"].to_numpy(), 6))
        assert np.allclose(walk.times[rows], table["time"])
        errors[source] = _rms(table[list(TORQUE_COLUMNS)].to_numpy() - walk.torques[rows])
    alone = summaries["markers-only"]
    assert "tracked: the lab's raw markers alone (its plates not tracked)" in alone["notes"]
    tracking = alone["windows"][0]["tracking"]
    assert tracking["tracked"] == "markers"
    assert set(tracking["fit"]) == {"marker_rms_mm", "torque_from_prior_rms_nm"}
    assert tracking["fit"]["marker_rms_mm"] == pytest.approx(1.0, rel=0.3)  # 1 mm drawn
    # the ankle's height the lab recorded stays the subject's without plates
    assert tracking["segment_lengths_m"]["ankle_height"] == pytest.approx(0.0703, abs=2e-3)
    # what the plates add: torques the markers alone leave further from the walk's
    assert errors["markers-only"].mean() > 1.5 * errors["markers"].mean()


def test_markers_asked_of_a_trial_without_them_is_refused(lab_trial, tmp_path, capsys):
    trial = lab_trial
    plain = type(trial)(
        trial.time, trial.signals, trial.right_heel_strikes, trial.left_heel_strikes,
        trial.metadata,
    )  # fmt: skip
    folder = plain.write(tmp_path / "plain")
    for source in ("markers", "markers-only"):
        code = main(
            ["gait", "smooth", str(folder), "--out", str(tmp_path / "o"), "--smooth-from", source]
        )
        assert code == 2
        err = capsys.readouterr().err
        assert f"{source!r} needs a lab trial with its raw markers" in err
        assert "this trial has none (--smooth-from angles)" in err
        assert not (tmp_path / "o" / "smooth.json").exists()


def test_the_torques_prior_needs_the_inverse_dynamics(lab_trial):
    trial = type(lab_trial)(
        lab_trial.time,
        lab_trial.signals.drop(columns=list(TORQUE_COLUMNS)),
        lab_trial.right_heel_strikes,
        lab_trial.left_heel_strikes,
        lab_trial.metadata,
        lab_trial.tables,
    )
    with pytest.raises(ValueError, match="found no right_hip_torque"):
        marker_smoother(GaitDynamics.build(), trial, np.arange(10))


def test_bad_noise_levels_are_named_before_any_work(tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(
            [
                "gait",
                "identify",
                str(tmp_path),
                "--noise-levels",
                "marker=-1,skin=2,force=1,force=2",
            ]
        )
    err = capsys.readouterr().err
    assert "marker: expected a standard deviation > 0, found '-1'" in err
    assert "unknown name 'skin'" in err and "force given twice" in err


def test_early_weights_must_be_factors_of_tracked_outputs(lab_trial):
    from sympy.physics.mechanics import dynamicsymbols

    from colloc.identify.gait.smoother import GaitSmoother

    smoother, _ = marker_smoother(GaitDynamics.build(), lab_trial, np.arange(20))
    y = dynamicsymbols("plate_right_force_x")
    tracked = {y: (smoother.model.outputs[y], smoother._measured[y], 2.0)}
    for bad in ({y: 0.0}, {y: 2.0}, {dynamicsymbols("other"): 0.5}):
        with pytest.raises(ValueError, match="early_weights: expected a factor in \\(0, 1\\]"):
            GaitSmoother(
                smoother.dynamics, smoother.times, smoother.positions, smoother.belt_speed,
                np.ones(9), tracked=tracked, track_positions=False, early_weights=bad,
            )  # fmt: skip
