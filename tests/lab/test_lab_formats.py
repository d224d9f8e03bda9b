"""The lab's own files: TRC, MOT/STO (with OpenSim's _grf.xml), C3D through ezc3d, and the
reader that picks among them, each against what was written, and the whole lab path from
each kind of file against the same walk's tab export."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from colloc.cli import main
from colloc.data.trial import read_trial
from colloc.lab import (
    LabFileError,
    LabSettings,
    lab_export_from_record,
    read_lab_file,
    trial_from_lab,
    write_lab_files,
)
from colloc.lab.exports import LabExport
from colloc.lab.formats import lab_file_format
from colloc.lab.formats.c3d import read_c3d, write_c3d
from colloc.lab.formats.mot import read_mot, write_grf_mapping, write_mot
from colloc.lab.formats.trc import read_trc, write_trc
from colloc.lab.markers import DEFAULT_MARKER_SET
from colloc.lab.record import LabRecord, PlateSeries, regular_time
from colloc.lab.sagittal import find_plane, sagittal_exports
from colloc.lab.synthetic import write_lab_export
from colloc.models.gait2d_params import load_parameters

TESTS = Path(__file__).resolve().parents[1]
SUBJECT = (75.0, 1.8)


@pytest.fixture(scope="module")
def export(walk) -> LabExport:
    """The session's walk as a lab would have recorded it (seeded noise)."""
    return lab_export_from_record(walk, load_parameters(*SUBJECT), seed=4)


@pytest.fixture(scope="module")
def files(export, tmp_path_factory) -> dict[str, Path]:
    return write_lab_files(export, tmp_path_factory.mktemp("lab-files"))


def _random_plates(rng, time, lateral):
    n = time.size
    force = np.column_stack(
        [rng.normal(size=n) * 50, rng.normal(size=n) * 20, 700 + rng.normal(size=n) * 100]
    )
    point = np.column_stack([rng.uniform(-0.5, 0.5, n), np.full(n, lateral), np.zeros(n)])
    torque = np.column_stack([np.zeros(n), np.zeros(n), rng.normal(size=n) * 3])
    return PlateSeries(time, force, point, torque)


def test_trc_reads_back_what_was_written_in_metres_with_gaps(tmp_path):
    rng = np.random.default_rng(1)
    time = np.arange(30) / 60.0
    markers = {"A": rng.normal(size=(30, 3)), "B.Toe": rng.normal(size=(30, 3))}
    markers["A"][7] = np.nan
    path = write_trc(tmp_path / "walk.trc", time, markers, units="mm")
    record = read_trc(path)
    for name, xyz in markers.items():
        np.testing.assert_allclose(record.markers[name], xyz, atol=1e-9)
    assert np.isnan(record.markers["A"][7]).all() and record.up == 1
    assert record.notes[0] == "walk.trc: markers in mm, converted to m"
    np.testing.assert_allclose(record.time, time, atol=1e-12)


def test_a_fixed_rate_written_to_a_millisecond_is_taken_as_that_rate_with_a_note():
    rounded = np.round(np.arange(151) / 60.0, 3)  # OpenSim's walk: 0.016, 0.033, 0.05, ...
    time, notes = regular_time(rounded, 60.0, "walk.trc")
    np.testing.assert_allclose(time, np.arange(151) / 60.0, atol=1e-12)
    assert notes == [
        "walk.trc: time stamps written to 0.001 s of a fixed 60 Hz (up to 0.33 ms off): taken "
        "as exactly 60 Hz"
    ]
    # stamps off by more than a millisecond are not a rounding: kept for the sampling check
    jittered = np.arange(100) / 100.0 + np.r_[0.0, 0.004, np.zeros(98)]
    kept, none = regular_time(jittered, None, "x")
    assert none == [] and np.array_equal(kept, jittered)


def test_trc_problems_are_named(tmp_path):
    path = tmp_path / "bad.trc"
    path.write_text(
        "PathFileType\t4\t(X/Y/Z)\tbad.trc\nDataRate\tUnits\n60\tinches\nFrame#\tTime\tA\t\t\n"
        "\t\tX1\tY1\tZ1\n1\t0\t1\t2\t3\n"
    )
    with pytest.raises(LabFileError, match="Units: expected one of .*found 'inches'"):
        read_trc(path)


def test_mot_reads_back_with_the_sides_its_xml_names(tmp_path):
    rng = np.random.default_rng(2)
    time = np.arange(600) / 600.0
    plates = {"ground": _random_plates(rng, time, 0.1), "1_ground": _random_plates(rng, time, -0.1)}
    mot = write_mot(tmp_path / "walk_grf.mot", plates)
    xml = write_grf_mapping(
        tmp_path / "walk_grf.xml", {"ground": "right", "1_ground": "left"}, mot.name
    )
    record = read_mot(mot, xml)
    assert record.plate_sides == {"ground": "right", "1_ground": "left"}
    for name, plate in plates.items():
        np.testing.assert_allclose(record.plates[name].force, plate.force, rtol=1e-8)
        np.testing.assert_allclose(record.plates[name].point, plate.point, rtol=1e-8, atol=1e-12)
        np.testing.assert_allclose(record.plates[name].free_torque, plate.free_torque, rtol=1e-8)
    assert read_mot(mot).plate_sides == {}


def test_mot_problems_are_named(tmp_path):
    path = tmp_path / "grf.mot"
    path.write_text(
        "grf.mot\nendheader\ntime\tground_force_vx\tground_force_vy\n0\t1\t2\n1\t1\t2\n"
    )
    with pytest.raises(
        LabFileError, match="plate ground: no column ground_force_vz, ground_force_px"
    ):
        read_mot(path)
    xml = tmp_path / "grf.xml"
    xml.write_text("<OpenSimDocument><ExternalLoads/></OpenSimDocument>")
    good = write_mot(
        tmp_path / "ok.mot",
        {"ground": _random_plates(np.random.default_rng(0), np.arange(5) / 10.0, 0.1)},
    )
    with pytest.raises(LabFileError, match="expected one plate for each foot"):
        read_mot(good, xml)


def test_c3d_type2_platforms_give_back_the_written_reaction_through_ezc3d(tmp_path):
    """The writer's channels (plate axes z down, moments about the sensor origin 40 mm below
    the surface, N mm) against ezc3d's own platform filter: force, centre of pressure and
    free torque as written. C3D stores 32-bit floats: about 1e-7 of each value."""
    rng = np.random.default_rng(3)
    time = np.arange(50) / 100.0
    analog_time = np.arange(500) / 1000.0
    markers = {"RHEE": rng.normal(size=(50, 3)), "LHEE": rng.normal(size=(50, 3))}
    markers["RHEE"][5] = np.nan
    plates = {
        "FP1": _random_plates(rng, analog_time, 0.25),
        "FP2": _random_plates(rng, analog_time, -0.25),
    }
    events = [
        {"label": "Foot Strike", "context": "Right", "time": 0.125},
        {"label": "Foot Off", "context": "Left", "time": 0.05},
    ]
    record = read_c3d(write_c3d(tmp_path / "walk.c3d", time, markers, plates, 1000.0, events))
    assert record.up == 2 and list(record.plates) == ["FP1", "FP2"]
    assert [(e["label"], e["context"]) for e in record.events] == [
        ("Foot Off", "Left"),
        ("Foot Strike", "Right"),
    ]
    np.testing.assert_allclose([e["time"] for e in record.events], [0.05, 0.125], atol=1e-6)
    np.testing.assert_allclose(record.markers["LHEE"], markers["LHEE"], atol=1e-6)
    assert np.isnan(record.markers["RHEE"][5]).all()
    for name, plate in plates.items():
        read = record.plates[name]
        np.testing.assert_allclose(read.force, plate.force, atol=2e-4)
        np.testing.assert_allclose(read.point, plate.point, atol=1e-6)
        np.testing.assert_allclose(read.free_torque, plate.free_torque, atol=1e-5)
    assert set(record.analogs) == {
        f"{c}{k}" for k in (1, 2) for c in ("Fx", "Fy", "Fz", "Mx", "My", "Mz")
    }


def test_the_reader_goes_by_content_and_says_when_the_suffix_disagrees(files, tmp_path):
    assert [lab_file_format(files[k]) for k in ("tsv", "trc", "mot", "c3d")] == [
        "export", "TRC", "MOT", "C3D"
    ]  # fmt: skip
    renamed = tmp_path / "markers.c3d"
    renamed.write_bytes(files["trc"].read_bytes())
    record = read_lab_file(renamed)
    assert isinstance(record, LabRecord)
    assert record.notes[-1] == "markers.c3d: read as TRC (its content), not C3D"
    pretend = tmp_path / "export.trc"
    pretend.write_bytes(files["tsv"].read_bytes())
    with pytest.raises(LabFileError, match="not a TRC file"):
        read_lab_file(pretend)


def test_the_walking_direction_and_the_sides_are_found_from_the_markers(files, export):
    record = read_trc(files["trc"])
    plane = find_plane(record)
    np.testing.assert_allclose(plane.forward, [1.0, 0.0, 0.0], atol=1e-3)
    # walking the other way along x: forward is -x, and the planar markers are the same
    mirrored = LabRecord(
        record.time,
        {n: xyz * np.array([-1.0, 1.0, -1.0]) for n, xyz in record.markers.items()},
        {},
        up=1,
    )
    assert find_plane(mirrored).forward @ np.array([-1.0, 0.0, 0.0]) > 0.999
    planar, _, _, _, _ = sagittal_exports(mirrored, None, DEFAULT_MARKER_SET)
    np.testing.assert_allclose(planar.markers["RHEE"], export.markers["RHEE"], atol=2e-6)
    # left and right markers swapped: their positions say so
    swapped = LabRecord(
        record.time,
        {n: xyz * np.array([1.0, 1.0, -1.0]) for n, xyz in record.markers.items()},
        {},
        up=1,
    )
    with pytest.raises(LabFileError, match="markers lie .* to the LEFT of the L\\* markers"):
        sagittal_exports(swapped, None, DEFAULT_MARKER_SET, forward="+x")
    with pytest.raises(LabFileError, match="'\\+y' is the vertical axis"):
        find_plane(record, "+y")


def test_each_kind_of_file_gives_the_same_trial_as_the_tab_export(files, export):
    settings = LabSettings(*SUBJECT, belt_speed=1.2)
    tsv = trial_from_lab(files["tsv"], settings).trial
    from_trc = trial_from_lab(files["trc"], settings, files["mot"], mapping=files["grf_xml"])
    from_c3d = trial_from_lab(files["c3d"], settings)
    assert any("plate sides from lab-export_grf.xml" in note for note in from_trc.notes)
    # the tab export holds 1e-6 m and N, the MOT 12 digits: markers and forces agree to
    # 1e-6 (measured 5.0e-7); a C3D stores 32-bit floats, 6e-5 N at 700 N (measured 3.1e-5)
    force_tolerance = {"trc": 1e-6, "c3d": 1e-4}
    for kind, result in (("trc", from_trc), ("c3d", from_c3d)):
        trial = result.trial
        np.testing.assert_array_equal(
            trial.right_heel_strikes.round(6), tsv.right_heel_strikes.round(6)
        )
        np.testing.assert_array_equal(
            trial.left_heel_strikes.round(6), tsv.left_heel_strikes.round(6)
        )
        markers = (trial.tables["markers"] - tsv.tables["markers"]).abs().max()
        assert markers.max() < 1e-6
        plates = (trial.tables["plates"] - tsv.tables["plates"]).abs().max()
        assert plates.filter(like="_force_").max() < force_tolerance[kind]
        difference = (trial.signals - tsv.signals).abs().max()
        assert difference.filter(regex="_angle$").max() < 1e-5
        assert difference.filter(like="grf_").max() < force_tolerance[kind]
        assert difference.filter(like="cop_").max() < 1e-4
        assert difference.filter(like="_torque").max() < 5e-3
    # without the XML the plates are put under the feet from the markers, the same way
    inferred = trial_from_lab(files["trc"], settings, files["mot"])
    assert any("plates under the feet" in note for note in inferred.notes)
    np.testing.assert_allclose(
        inferred.trial.signals["right_grf_y"], from_trc.trial.signals["right_grf_y"]
    )


def test_swapped_plates_in_a_tab_export_are_refused_by_name(export, tmp_path):
    swapped = LabExport(
        export.time,
        export.markers,
        {"FP1": export.plates["FP2"], "FP2": export.plates["FP1"]},
        export.columns,
    )
    path = write_lab_export(swapped, tmp_path / "swapped.tsv")
    with pytest.raises(
        LabFileError,
        match="FP2 is named for the right foot but its centre of pressure lies under the left",
    ):
        trial_from_lab(path, LabSettings(*SUBJECT, belt_speed=1.2))


def test_a_free_torque_written_as_the_moment_is_caught(export, tmp_path):
    """A natural misreading of a MOT: its free torque taken for the plate's moment puts the
    centre of pressure near the origin, under neither foot."""
    plates = {
        name: np.column_stack([ch[:, :2], np.full(len(ch), 3.0)])
        for name, ch in export.plates.items()
    }
    moved = {n: xy + np.array([1.5, 0.0]) for n, xy in export.markers.items()}
    path = write_lab_export(
        LabExport(export.time, moved, plates, export.columns), tmp_path / "x.tsv"
    )
    with pytest.raises(LabFileError, match="centre of pressure lies under neither foot"):
        trial_from_lab(path, LabSettings(*SUBJECT, belt_speed=1.2))


def test_markers_in_millimetres_are_named_and_converted(export, tmp_path):
    in_mm = LabExport(
        export.time, {n: xy * 1000.0 for n, xy in export.markers.items()}, export.plates,
        export.columns,
    )  # fmt: skip
    plates_mm = {n: ch * np.array([1.0, 1.0, 1.0]) for n, ch in export.plates.items()}
    path = write_lab_export(
        LabExport(in_mm.time, in_mm.markers, plates_mm, in_mm.columns), tmp_path / "mm.tsv"
    )
    result = trial_from_lab(path, LabSettings(*SUBJECT, belt_speed=1.2))
    assert result.notes[0].startswith("markers in mm: the thighs' markers lie")
    reference = trial_from_lab(
        write_lab_export(export, tmp_path / "m.tsv"), LabSettings(*SUBJECT, belt_speed=1.2)
    )
    difference = (result.trial.signals - reference.trial.signals).abs().max()
    assert difference.filter(like="_angle").max() < 1e-4


def test_the_command_reads_a_trc_and_a_mot_and_names_its_flags(files, tmp_path, capsys):
    out = tmp_path / "trial"
    argv = ["gait", "trial-from-lab", str(files["trc"]), "--forces", str(files["mot"])]
    argv += ["--mass", "75", "--height", "1.8", "--belt-speed", "1.2", "--out", str(out)]
    assert main(argv) == 0
    said = capsys.readouterr().out
    assert "note: lab-export.trc: markers in mm, converted to m" in said
    assert read_trial(out).metadata["lab"]["sources"]["forces"]["path"].endswith("_grf.mot")
    assert main([*argv[:-2], "--out", str(tmp_path / "t2"), "--forward", "up"]) == 2
    assert "--forward: expected an axis such as +x" in capsys.readouterr().err


def _refusal(export, tmp_path, **settings) -> str:
    path = write_lab_export(export, tmp_path / "export.tsv")
    with pytest.raises(LabFileError) as info:
        trial_from_lab(path, LabSettings(*SUBJECT, **{"belt_speed": 1.2, **settings}))
    return str(info.value)


def test_markers_upside_down_are_refused(export, tmp_path):
    flipped = {n: xy * np.array([1.0, -1.0]) for n, xy in export.markers.items()}
    message = _refusal(LabExport(export.time, flipped, export.plates, export.columns), tmp_path)
    assert "the vertical axis is not Y up" in message


def test_a_one_frame_marker_spike_is_taken_as_missing_and_said(export, tmp_path):
    spiked = {n: xy.copy() for n, xy in export.markers.items()}
    spiked["RLEK"][150] += [1.0, 0.0]  # 1 m for one frame
    path = write_lab_export(
        LabExport(export.time, spiked, export.plates, export.columns), tmp_path / "s.tsv"
    )
    clean = write_lab_export(export, tmp_path / "c.tsv")
    settings = LabSettings(*SUBJECT, belt_speed=1.2)
    result = trial_from_lab(path, settings)
    assert any(
        "marker RLEK: 1 sample(s) jump away and back faster than 25 m/s (first at t = 1.5 s)" in n
        for n in result.notes
    )
    reference = trial_from_lab(clean, settings).trial
    knee = np.degrees(
        np.abs(result.trial.signals["right_knee_angle"] - reference.signals["right_knee_angle"])
    )
    assert knee.max() < 1.0  # the spike cost 34 degrees before


def test_a_cutoff_at_the_nyquist_frequency_and_a_vanishing_one_are_refused(export, tmp_path):
    assert "at or near the Nyquist frequency of the markers (100 Hz sampled" in _refusal(
        export, tmp_path, cutoff_hz=50.0
    )
    assert (
        LabSettings(*SUBJECT, belt_speed=1.2, cutoff_hz=1e-9)
        .problems()[0]
        .startswith("cutoff_hz: expected a number of Hz in (1")
    )


def test_a_belt_speed_the_feet_contradict_is_refused(export, tmp_path):
    assert (
        LabSettings(*SUBJECT, belt_speed=-1.2)
        .problems()[0]
        .startswith("belt_speed: expected a speed >= 0")
    )
    message = _refusal(export, tmp_path, belt_speed=0.5)
    assert "belt_speed: 0.5 m/s given, but the heels move backward at 1.19 m/s" in message


def test_a_strike_threshold_no_step_reaches_is_refused(export, tmp_path):
    message = _refusal(export, tmp_path, strike_threshold=1e9)
    assert "strike_threshold: 1e+09 N, but the right foot's plate peaks at" in message


def test_left_and_right_markers_swapped_are_refused(export, tmp_path):
    """The plates say which foot stands where: a record whose R and L markers trade places
    puts each plate under the other side's markers."""
    swapped = {
        ("L" + n[1:] if n[0] == "R" else "R" + n[1:]): xy for n, xy in export.markers.items()
    }
    message = _refusal(LabExport(export.time, swapped, export.plates, export.columns), tmp_path)
    assert "the plates or the markers' sides are swapped" in message


def test_a_glitch_of_1e300_m_is_a_spike_not_an_overflow(export, tmp_path):
    spiked = {n: xy.copy() for n, xy in export.markers.items()}
    spiked["RLM"][200, 0] = 1e300
    path = write_lab_export(
        LabExport(export.time, spiked, export.plates, export.columns), tmp_path / "s.tsv"
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a RuntimeWarning of numpy's is not a message
        result = trial_from_lab(path, LabSettings(*SUBJECT, belt_speed=1.2))
    assert any("marker RLM: 1 sample(s) jump away and back faster" in n for n in result.notes)
    assert np.isfinite(result.trial.signals["right_ankle_angle"]).all()
