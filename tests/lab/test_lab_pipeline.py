"""The lab pipeline end to end: a simulated walk's markers and plates back to its states,
torques and heel strikes, from the library and from ``colloc gait trial-from-lab``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from colloc.cli import main
from colloc.data.columns import JOINT_ANGLE_COLUMNS, JOINT_RATE_COLUMNS, TORQUE_COLUMNS
from colloc.data.trial import read_trial
from colloc.lab import (
    LabFileError,
    LabNoise,
    LabSettings,
    lab_export_from_record,
    process_lab,
    write_lab_export,
)
from colloc.models.gait2d_params import load_parameters

TESTS = Path(__file__).resolve().parents[1]
CLIP = TESTS / "data" / "records" / "gatk-leg2d-sagittal-gait-3s" / "rawdata.txt"
SUBJECT = (75.0, 1.8)  # the session walk's subject (tests/lab/conftest.py)


def _contact_events(record) -> np.ndarray:
    """Where a foot's vertical force crosses 20 N either way (impacts, grazes, toe-offs)."""
    forces = record.contact_forces[:, 1::2]
    events = []
    for foot in (forces[:, 0] + forces[:, 1], forces[:, 2] + forces[:, 3]):
        events += list(record.times[np.flatnonzero(np.diff((foot > 20.0).astype(int)))])
    return np.asarray(events)


def _rms(x: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean(x**2, axis=0))


def test_a_simulated_walk_comes_back_from_its_markers_and_plates(walk):
    params = load_parameters(*SUBJECT)
    export = lab_export_from_record(walk, params, seed=3)  # 1 mm, 2 N, 1 N m noise
    result = process_lab(export, LabSettings(*SUBJECT, belt_speed="RightBeltSpeed"))
    trial = result.trial
    # the filter's ends are cut, and said: 9 samples (half a period of 6 Hz) at each end
    assert result.notes == [
        "the first and last 9 samples (0.09 s) are cut: there the 6 Hz filter runs off the "
        "record's ends, and the torques from its second derivatives are not to be trusted"
    ]
    kept = slice(9, -9)
    np.testing.assert_allclose(trial.time, walk.times[kept])
    truth, true_torques = walk.states[kept], walk.torques[kept]
    angles = trial.signals[list(JOINT_ANGLE_COLUMNS)].to_numpy()
    rates = trial.signals[list(JOINT_RATE_COLUMNS)].to_numpy()
    torques = trial.signals[list(TORQUE_COLUMNS)].to_numpy()
    inner = slice(1, -1)  # every sample kept, the ends' included (but the extreme two)
    near = np.zeros(trial.time.size, bool)
    for event in _contact_events(walk):
        near |= np.abs(trial.time - event) < 0.06
    away = ~near
    # away from contact events (37 % of the samples) the angles are within the 0.25 deg a
    # lab's processed angles are credited with (colloc.gait.trials.DEFAULT_NOISE_STD);
    # measured 0.12-0.25 deg, rates 0.09-0.26 rad/s, torques 1.8-2.2 N m
    assert np.degrees(_rms((angles - truth[:, 3:9])[away])).max() < 0.3
    assert _rms((rates - truth[:, 12:18])[away]).max() < 0.3
    assert _rms((torques - true_torques)[away]).max() < 2.5
    # over the whole record the ankles lose what the model's stiff contact puts above the
    # 6 Hz cut-off at each impact (measured 0.69-0.73 deg, 5.7 N m; the same without noise)
    assert np.degrees(_rms((angles - truth[:, 3:9])[inner])).max() < 0.8
    assert _rms((torques - true_torques)[inner]).max() < 6.5
    # no sample's torque is far off, the record's ends included (590 N m at t = 0 on a walk
    # starting with a friction transient before the ends were cut)
    assert np.abs(torques - true_torques).max() < 40.0
    # trunk pose from the mean hip and shoulder markers
    trunk = trial.signals[["trunk_x", "trunk_y", "trunk_angle"]].to_numpy()
    assert _rms((trunk - truth[:, :3])[inner]).max() < 2e-3  # m and rad
    # every heel strike, within 15 ms (the filtered force rises earlier: measured 6-13 ms)
    for side in ("right", "left"):
        found, true = getattr(trial, f"{side}_heel_strikes"), getattr(walk, f"{side}_heel_strikes")
        true = true[(true >= trial.time[0]) & (true <= trial.time[-1])]
        assert found.size == true.size
        assert np.abs(found - true).max() < 0.015
    # the noise levels declared for the identification are the record's own: the marker
    # spread (1 mm drawn) and the plates' (2 N drawn), robust to the impacts
    noise = trial.metadata["noise"]
    assert noise["marker_std"] == pytest.approx(1e-3, rel=0.1)
    assert noise["std"]["ground_reaction_force"] == pytest.approx(2.0, rel=0.35)


def test_the_trial_keeps_the_raw_markers_and_plates_with_their_gaps(walk, tmp_path):
    params = load_parameters(*SUBJECT)
    export = lab_export_from_record(walk, params, seed=3)
    export.markers["RLEK"][50:53] = np.nan  # a gap of three samples: filled in the signals
    trial = process_lab(export, LabSettings(*SUBJECT, belt_speed="RightBeltSpeed")).trial
    markers, plates = trial.tables["markers"], trial.tables["plates"]
    # exactly what the export holds over the trial's time (its ends cut with the signals'):
    # not filtered, the gap left as a gap
    kept = (export.time >= trial.time[0] - 1e-9) & (export.time <= trial.time[-1] + 1e-9)
    assert kept.sum() == export.time.size - 18
    for name, xy in export.markers.items():
        if f"{name}_x" in markers:
            np.testing.assert_array_equal(markers[[f"{name}_x", f"{name}_y"]].to_numpy(), xy[kept])
    assert markers["RLEK_x"].isna().sum() == 3
    np.testing.assert_array_equal(plates["time"], export.time[kept])
    np.testing.assert_array_equal(
        plates[["right_force_x", "right_force_y", "right_moment"]], export.plates["FP2"][kept]
    )
    meta = trial.metadata
    assert meta["markers"]["segments"]["RLEK"] == "right_thigh"
    assert meta["markers"]["segments"]["LSHO"] == "trunk"
    assert meta["markers"]["noise_std_m"] == pytest.approx(1e-3, rel=0.1)
    assert meta["plates"]["force_noise_std_n"] == pytest.approx(2.0, rel=0.35)
    assert meta["plates"]["moment_noise_std_nm"] == pytest.approx(1.0, rel=0.35)
    back = read_trial(trial.write(tmp_path / "t"))
    assert sorted(back.tables) == ["markers", "plates"]


def test_trial_from_lab_writes_a_trial_that_reads_back_with_what_was_done(walk, tmp_path, capsys):
    params = load_parameters(*SUBJECT)
    export = lab_export_from_record(walk, params, seed=4, noise=LabNoise(0.001, 2.0, 1.0))
    # an occluded knee marker for 0.1 s, written as exact zeros as some systems do
    export.markers["RLEK"][150:160] = 0.0
    path = write_lab_export(export, tmp_path / "export.tsv")
    out = tmp_path / "trial"
    args = ["gait", "trial-from-lab", str(path), "--mass", "75", "--height", "1.8"]
    args += ["--belt-speed", "RightBeltSpeed", "--out", str(out)]
    assert main(args) == 0
    trial = read_trial(out)
    lab = trial.metadata["lab"]
    assert lab["gaps"]["list"] == [
        {"marker": "RLEK", "start": 1.5, "stop": 1.59, "samples": 10, "filled": True}
    ]
    assert lab["filter"]["cutoff_hz"] == 6.0 and len(lab["sources"]["markers"]["sha256"]) == 64
    # the walk's first right heel strike (0.026 s) lies in the 0.09 s cut at the start
    assert trial.metadata["body_mass"] == 75.0 and trial.right_heel_strikes.size == 3
    assert trial.signals["belt_speed"].to_numpy() == pytest.approx(1.2)
    # the filled knee is still the knee: through the gap, the knee angle is within 0.5 deg
    # of the same pipeline's on the unbroken record
    unbroken = (
        process_lab(
            lab_export_from_record(walk, params, seed=4), LabSettings(*SUBJECT, belt_speed=1.2)
        )
        .trial.signals["right_knee_angle"]
        .to_numpy()[141:151]
    )
    knee = trial.signals["right_knee_angle"].to_numpy()[141:151]  # the export's 150-159
    assert np.degrees(np.abs(knee - unbroken)).max() < 0.5
    # a second run refuses to replace the trial unless told to
    assert main(args) == 2
    assert main([*args, "--overwrite"]) == 0
    # a heel marker hidden for 0.6 s is not guessed at, and the trial written before stays
    export.markers["LHEE"][100:160] = np.nan
    write_lab_export(export, path)
    assert main([*args, "--overwrite"]) == 2
    assert "marker LHEE: missing from 1 to 1.59 s (60 samples" in capsys.readouterr().err
    assert read_trial(out).metadata["lab"]["gaps"]["list"][0]["marker"] == "RLEK"


def test_every_problem_of_a_one_legged_record_is_named_before_anything_is_written(tmp_path, capsys):
    out = tmp_path / "trial"
    code = main(
        ["gait", "trial-from-lab", str(CLIP), "--mass", "67.2", "--height", "1.7"]
        + ["--belt-speed", "1.1", "--out", str(out)]
    )
    assert code == 2 and not out.exists()
    err = capsys.readouterr().err
    # the left leg's six markers and its plate, in one report
    assert "LSHO, LGTRO, LLEK, LLM, LHEE, LMT5 not in" in err
    assert "plates: FP1 not in" in err
    with pytest.raises(LabFileError) as info:
        process_lab(lab_export_from_record_stub(), LabSettings(-1.0, 1.8, belt_speed="none"))
    assert any(p.startswith("body_mass") for p in info.value.problems)
    assert any("belt_speed: no column 'none'" in p for p in info.value.problems)


def lab_export_from_record_stub():
    from colloc.lab import read_lab_export

    return read_lab_export(CLIP)


def test_bad_flags_are_named_before_reading(tmp_path, capsys):
    code = main(
        ["gait", "trial-from-lab", str(tmp_path / "none.tsv"), "--mass", "75", "--height", "9"]
        + ["--belt-speed", "1.1", "--out", str(tmp_path / "t"), "--cutoff", "0"]
        + ["--marker-names", "elbow=ELB"]
    )
    assert code == 2
    err = capsys.readouterr().err
    for expected in (
        "--height",
        "--cutoff",
        "--marker-names: unknown landmarks ['elbow']",
        "no such file",
    ):
        assert expected in err


def test_plates_in_their_own_file_at_their_own_rate_give_the_same_trial(walk, tmp_path):
    """Forces exported apart at 200 Hz (here: the 100 Hz plates interpolated, their noise
    with them): filtered at their rate and read at the marker times, the torques agree with
    those from one 100 Hz file to well within their error against the truth (2-6 N m)."""
    from colloc.lab import LabExport, trial_from_lab

    params = load_parameters(*SUBJECT)
    export = lab_export_from_record(walk, params, seed=5)
    markers = LabExport(export.time, export.markers, {}, export.columns, "markers")
    fine = np.arange(0.0, export.time[-1] + 1e-9, 0.005)
    plates = {
        name: np.column_stack([np.interp(fine, export.time, c[:, k]) for k in range(3)])
        for name, c in export.plates.items()
    }
    forces = LabExport(fine, {}, plates, {}, "forces")
    write_lab_export(markers, tmp_path / "markers.tsv")
    write_lab_export(forces, tmp_path / "forces.tsv")
    write_lab_export(export, tmp_path / "both.tsv")
    settings = LabSettings(*SUBJECT, belt_speed="LeftBeltSpeed")
    apart = trial_from_lab(tmp_path / "markers.tsv", settings, tmp_path / "forces.tsv").trial
    together = trial_from_lab(tmp_path / "both.tsv", settings).trial
    difference = (apart.signals - together.signals)[list(TORQUE_COLUMNS)].to_numpy()[10:-10]
    assert np.sqrt(np.mean(difference**2)) < 0.5  # N m; measured 0.07
    assert apart.right_heel_strikes == pytest.approx(together.right_heel_strikes, abs=0.005)
    assert set(apart.metadata["lab"]["sources"]) == {"markers", "forces"}


def test_the_help_states_the_settings_defaults(capsys):
    """The parser imports nothing heavy, so its help writes the defaults out: they must be
    LabSettings' own."""
    with pytest.raises(SystemExit):
        main(["gait", "trial-from-lab", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    defaults = LabSettings(75.0, 1.8, belt_speed=0.0)
    assert f"(default {defaults.cutoff_hz:g} Hz)" in text
    assert f"(default {defaults.max_gap:g} s)" in text
    assert f"(default {defaults.strike_threshold:g} N," in text
    ms = defaults.marker_set
    names = ", ".join(getattr(ms, k) for k in ("shoulder", "hip", "knee", "ankle", "heel", "toe"))
    assert f"(default {names})" in text
    assert "(default right=FP2,left=FP1)" in text and "(default right=R,left=L)" in text


def test_overwrite_never_deletes_the_inputs_or_a_users_files(tmp_path, capsys):
    """`--out DIR --overwrite` replaces a trial colloc wrote and nothing else: pointed at the
    folder holding the export, or at one holding someone's file, it is refused before any
    work and every file stays."""
    folder = tmp_path / "lab"
    folder.mkdir()
    export = folder / "rawdata.txt"
    export.write_bytes(CLIP.read_bytes())
    base = ["gait", "trial-from-lab", str(export), "--mass", "67.2", "--height", "1.7"]
    base += ["--belt-speed", "1.1", "--overwrite", "--out"]
    assert main([*base, str(folder)]) == 2
    assert "holds the markers file" in capsys.readouterr().err
    assert export.read_bytes() == CLIP.read_bytes()
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "thesis.tex").write_text("years of work")
    assert main([*base, str(mine)]) == 2
    err = capsys.readouterr().err
    assert "holds 'thesis.tex', which is not part of a trial" in err
    assert (mine / "thesis.tex").read_text() == "years of work"
    # an output under a file is named before the work, not found after it
    assert main([*base, str(export / "trial")]) == 2
    assert "is a file, not a folder" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.rglob("*")) == [
        "lab",
        "mine",
        "rawdata.txt",
        "thesis.tex",
    ]
