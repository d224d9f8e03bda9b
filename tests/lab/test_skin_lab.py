"""The synthetic lab with skin markers: clusters off the bones, pelvis markers, a static
trial and plates at 1000 Hz, in every format, through the whole lab path.

References: Harrington's regression (an independent formula, :mod:`colloc.lab.hip_centre`)
for the pelvis markers; the simulation's own states for the angles; the landmark markers'
export of the same walk for the path; the same walk simulated without plate substeps for
the 1000 Hz plates.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from colloc.data.columns import JOINT_ANGLE_COLUMNS, TORQUE_COLUMNS
from colloc.gait.closed_loop import simulate_walking
from colloc.lab import LabSettings, lab_export_from_record, trial_from_lab
from colloc.lab.formats import read_lab_file
from colloc.lab.hip_centre import hip_joint_centres
from colloc.lab.record import LabRecord
from colloc.lab.skin_markers import SKIN_MARKERS, skin_marker_positions, standing_pose
from colloc.lab.synthetic import LabNoise
from colloc.lab.synthetic_skin import skin_lab_from_record
from colloc.lab.writers import write_lab_files, write_skin_lab
from colloc.models.gait2d_params import load_parameters
from colloc.models.gait2d_points import StickFigureGeometry, stick_figure_points

SUBJECT = (75.0, 1.8)
#: The session walk's plate samples per marker sample (tests/lab/conftest.py).
PLATE_SUBSTEPS = 10


@pytest.fixture(scope="module")
def geometry() -> StickFigureGeometry:
    return StickFigureGeometry.from_parameters(load_parameters(*SUBJECT))


@pytest.fixture(scope="module")
def skin_files(walk, tmp_path_factory) -> dict[str, Path]:
    lab = skin_lab_from_record(walk, load_parameters(*SUBJECT), seed=6)
    return write_skin_lab(lab, tmp_path_factory.mktemp("skin"))


def _rms(x: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean(x**2, axis=0))


def test_harringtons_regression_on_the_pelvis_markers_gives_the_models_hip(geometry):
    rng = np.random.default_rng(1)
    q = standing_pose(geometry) + rng.uniform(-0.6, 0.6, (50, 9))
    markers = skin_marker_positions(q, geometry)
    right, left = hip_joint_centres(
        markers["R.ASIS"], markers["L.ASIS"], markers["V.Sacral"], np.array([0.0, 1.0, 0.0])
    )
    hip = stick_figure_points(q, geometry)["hip"]
    for centre, sign in ((right, 1.0), (left, -1.0)):
        np.testing.assert_allclose(centre[:, :2], hip, atol=1e-12)
        # Harrington's lateral offset for a 240 mm pelvis: 0.33 * 240 + 7.3 mm
        np.testing.assert_allclose(centre[:, 2], sign * 0.0865, atol=1e-12)


def test_skin_markers_ride_their_segments_off_the_joints(walk, geometry):
    markers = skin_marker_positions(walk.states[:, :9], geometry)
    points = stick_figure_points(walk.states[:, :9], geometry)
    # no marker on a knee or an ankle during the walk: those are the static trial's
    assert not any("Knee" in name or "Ankle" in name for name in markers)
    for side, prefix in (("right", "R."), ("left", "L.")):
        for segment, joints in (
            ("Thigh", ("hip", f"{side}_knee")),
            ("Shank", (f"{side}_knee", f"{side}_ankle")),
        ):
            cluster = [
                markers[f"{prefix}{segment}.{part}"][:, :2] for part in ("Upper", "Front", "Rear")
            ]
            # rigid: the distances within the cluster and to its segment's joints never change
            for a, b in (
                (cluster[0], cluster[1]),
                (cluster[1], cluster[2]),
                (cluster[0], points[joints[0]]),
            ):
                distance = np.linalg.norm(a - b, axis=1)
                assert np.ptp(distance) < 1e-12
            # not in a line (a pose needs three points that span the plane)
            u, v = cluster[1] - cluster[0], cluster[2] - cluster[0]
            assert np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]).min() > 1e-3
            # and off the bone: no cluster marker within 2 cm of the joint-to-joint line
            start, end = points[joints[0]], points[joints[1]]
            axis = (end - start) / np.linalg.norm(end - start, axis=1, keepdims=True)
            for xy in cluster:
                off = (xy - start)[:, 0] * axis[:, 1] - (xy - start)[:, 1] * axis[:, 0]
                assert np.abs(off).min() > 0.02
    standing = skin_marker_positions(standing_pose(geometry)[None, :], geometry, standing=True)
    assert len(standing) == sum(1 if m.midline else 2 for m in SKIN_MARKERS)
    soles = [standing[f"{p}{m}"][0, 1] for p in ("R.", "L.") for m in ("Heel", "Toe.Lat")]
    np.testing.assert_allclose(soles, 0.0, atol=1e-12)  # standing on the floor


def test_the_plates_run_at_1000_hz_from_the_walk_itself(walk, walk_parts, skin_files):
    # the fine record is the same integration read more often: the walk at the samples is
    # the one simulated without substeps, to the integrator's tolerance
    _, (cycle, Tstar, K, dynamics, feedback) = walk_parts
    plain = simulate_walking(
        cycle, Tstar, K, 4.0, None, dynamics=dynamics, feedback=feedback, sample_rate=100.0
    )
    assert walk.fine_states is not None and walk.fine_contact_forces is not None
    np.testing.assert_array_equal(walk.fine_states[::PLATE_SUBSTEPS], walk.states)
    assert np.abs(plain.states - walk.states).max() < 1e-3  # measured 1.3e-4 with 3 N m
    assert np.abs(plain.contact_forces - walk.contact_forces).max() < 1.0  # N
    # the plates in the MOT and the C3D: 1000 Hz, and without noise their vertical force is
    # the contact model's heel plus toe at the fine times
    quiet = skin_lab_from_record(walk, load_parameters(*SUBJECT), seed=0, noise=LabNoise(0, 0, 0))
    right = quiet.walk.plates["FP2"]
    assert right.sample_rate == pytest.approx(1000.0)
    np.testing.assert_allclose(
        right.force[:, 1], walk.fine_contact_forces[:, 1] + walk.fine_contact_forces[:, 3]
    )
    for role in ("mot", "c3d"):
        record = read_lab_file(skin_files[role])
        assert isinstance(record, LabRecord)
        assert {round(p.sample_rate) for p in record.plates.values()} == {1000}


@pytest.mark.parametrize("kind", ["tsv", "trc", "c3d"])
def test_each_format_of_the_skin_export_gives_the_walk_through_the_static_trial(
    kind, walk, skin_files
):
    settings = LabSettings(*SUBJECT, belt_speed=1.2)
    forces = skin_files["mot"] if kind == "trc" else None
    result = trial_from_lab(skin_files[kind], settings, forces, static=skin_files[f"static_{kind}"])
    landmarks = result.trial.metadata["lab"]["landmarks"]
    assert landmarks["marker_set"].startswith("OpenSim gait2354")
    assert landmarks["landmarks"]["RLEK"]["carried_by"] == [
        "R.Thigh.Upper",
        "R.Thigh.Front",
        "R.Thigh.Rear",
    ]
    assert "Harrington" in landmarks["landmarks"]["RGTRO"]
    # the same walk's landmark export, through the same path, is the reference: clusters and
    # a regressed hip add little to the 6 Hz path's own error (measured: angles within
    # 0.05 deg RMS of it on an 8 s walk)
    direct = trial_from_lab_export(walk)
    angles = result.trial.signals[list(JOINT_ANGLE_COLUMNS)].to_numpy()
    reference = direct.signals[list(JOINT_ANGLE_COLUMNS)].to_numpy()
    inner = slice(1, -1)  # the lab path cut the filter's ends
    kept = np.isin(np.round(walk.times, 6), np.round(result.trial.time, 6))
    truth = walk.states[kept, 3:9]
    skin_error = np.degrees(_rms((angles - truth)[inner]))
    landmark_error = np.degrees(_rms((reference - truth)[inner]))
    assert skin_error.max() < 1.0
    assert np.all(skin_error < landmark_error + 0.15)
    torques = result.trial.signals[list(TORQUE_COLUMNS)].to_numpy()
    assert _rms((torques - walk.torques[kept])[inner]).max() < 8.0  # N m; the 6 Hz path's 5-7


def test_the_three_formats_of_the_skin_export_agree(skin_files):
    settings = LabSettings(*SUBJECT, belt_speed=1.2)
    trials = {
        kind: trial_from_lab(
            skin_files[kind],
            settings,
            skin_files["mot"] if kind == "trc" else None,
            static=skin_files[f"static_{kind}"],
        ).trial.signals
        for kind in ("tsv", "trc", "c3d")
    }
    inner = slice(1, -1)
    for kind in ("trc", "c3d"):
        difference = (trials[kind] - trials["tsv"]).abs().iloc[inner].max()
        assert difference.filter(regex="_angle$").max() < 1e-4  # the TSV's 1e-6 m
    # the MOT and the C3D hold the same 1000 Hz plates (32-bit floats in the C3D); the
    # C3D's last frame holds its last plate sample for 9 more, which the 6 Hz filter
    # carries some way back from the end
    difference = (trials["trc"] - trials["c3d"]).abs().iloc[1:-41].max()
    assert difference.filter(like="grf_").max() < 1e-2
    assert difference.filter(like="_torque").max() < 1e-2


def test_a_planar_static_trial_is_refused_by_name(walk, skin_files, tmp_path):
    from colloc.lab import LabFileError

    export = lab_export_from_record(walk, load_parameters(*SUBJECT), seed=1)
    planar = write_lab_files(export, tmp_path, formats=("tsv",))["tsv"]
    with pytest.raises(LabFileError, match="a static trial must be 3-D .*PosZ"):
        trial_from_lab(skin_files["tsv"], LabSettings(*SUBJECT, belt_speed=1.2), static=planar)


def trial_from_lab_export(walk):
    """The walk's landmark-marker export through the lab path (the reference)."""
    export = lab_export_from_record(walk, load_parameters(*SUBJECT), seed=6)
    from colloc.lab import process_lab

    return process_lab(export, LabSettings(*SUBJECT, belt_speed=1.2)).trial


def test_the_skin_trial_keeps_the_clusters_and_pelvis_markers_for_the_smoother(
    walk, geometry, skin_files
):
    settings = LabSettings(*SUBJECT, belt_speed=1.2)
    trial = trial_from_lab(
        skin_files["trc"], settings, skin_files["mot"], static=skin_files["static_trc"]
    ).trial
    segments = trial.metadata["markers"]["segments"]
    # the markers the landmarks were made from, each with the segment it rides; none of the
    # landmarks made of them (a carried knee or a regressed hip is not a measurement)
    assert segments["R.Thigh.Front"] == "right_thigh"
    assert segments["L.Shank.Rear"] == "left_shank"
    assert segments["R.Heel"] == "right_foot" and segments["L.Toe.Lat"] == "left_foot"
    assert {segments[n] for n in ("R.ASIS", "L.ASIS", "V.Sacral", "R.Acromium")} == {"trunk"}
    assert not {"RLEK", "RGTRO", "RLM"} & set(segments)
    # unfiltered: the recorded positions are the simulated markers' plus the 1 mm drawn
    kept = np.isin(np.round(walk.times, 6), np.round(trial.time, 6))
    truth = skin_marker_positions(walk.states[kept, :9], geometry)
    table = trial.tables["markers"]
    errors = np.concatenate(
        [table[[f"{n}_x", f"{n}_y"]].to_numpy() - truth[n][:, :2] for n in segments]
    )
    assert np.sqrt(np.mean(errors**2)) == pytest.approx(1e-3, rel=0.15)
    assert trial.metadata["markers"]["noise_std_m"] == pytest.approx(1e-3, rel=0.3)
    # the MOT's moment is its centre of pressure times the force, exactly zero off the plate:
    # its noise is read where it is recorded (1 N m drawn; off the plate it read 0.43)
    assert trial.metadata["plates"]["moment_noise_std_nm"] == pytest.approx(1.0, rel=0.15)
    assert trial.metadata["plates"]["force_noise_std_n"] == pytest.approx(2.0, rel=0.15)
    # the ankle's height from the carried malleoli on the loaded feet: the model's 0.0703 m
    assert trial.metadata["markers"]["ankle_height_m"] == pytest.approx(0.0703, abs=2e-3)


def test_markers_to_track_must_be_in_the_export_with_a_known_segment(walk):
    from colloc.lab import LabFileError, process_lab

    export = lab_export_from_record(walk, load_parameters(*SUBJECT), seed=1)
    settings = LabSettings(*SUBJECT, belt_speed=1.2)
    with pytest.raises(
        LabFileError, match=r"(?s)tracked: RXYZ not in .*segments expected among.*right_femur"
    ):
        process_lab(export, settings, tracked={"RXYZ": "right_thigh", "RLEK": "right_femur"})


@pytest.fixture(scope="module")
def perturbed_belt_files(walk, tmp_path_factory) -> tuple[dict[str, Path], np.ndarray]:
    """The skin lab of the session walk with its belt speed perturbed (a 0.3 m/s sine at
    0.7 Hz, as the files would carry a perturbed treadmill's)."""
    from dataclasses import replace

    lab = skin_lab_from_record(walk, load_parameters(*SUBJECT), seed=6)
    belt = 1.2 + 0.3 * np.sin(2 * np.pi * 0.7 * lab.walk.time)
    columns = dict.fromkeys(lab.walk.columns, belt)
    lab = replace(lab, walk=replace(lab.walk, columns=columns))
    return write_skin_lab(lab, tmp_path_factory.mktemp("belt")), belt


@pytest.mark.parametrize("kind", ["trc", "c3d"])
def test_the_belt_speed_travels_in_the_mot_and_the_c3d(kind, walk, perturbed_belt_files):
    """A perturbed belt is part of the walk: the MOT carries it as a column, the C3D as an
    analog channel no platform reads, and either gives the tab export's belt."""
    files, belt = perturbed_belt_files
    record = read_lab_file(files["mot" if kind == "trc" else "c3d"])
    assert isinstance(record, LabRecord)
    times = record.time if kind == "c3d" else next(iter(record.plates.values())).time
    expected = np.interp(times, walk.times, belt)  # the MOT's linear between the frames
    np.testing.assert_allclose(record.columns["LeftBeltSpeed"], expected, atol=1e-6)
    settings = LabSettings(*SUBJECT, belt_speed="LeftBeltSpeed")
    forces = files["mot"] if kind == "trc" else None
    trial = trial_from_lab(files[kind], settings, forces, static=files[f"static_{kind}"]).trial
    reference = trial_from_lab(files["tsv"], settings, static=files["static_tsv"]).trial
    # the same 6 Hz filtered belt: the MOT's is filtered at its 1000 Hz (the C3D's and the
    # tab export's at the frames), which differs by a few 1e-4 m/s where the filter meets
    # the record's ends (measured: 4e-4 at most)
    got, want = (t.signals["belt_speed"].to_numpy() for t in (trial, reference))
    np.testing.assert_allclose(got, want, atol=1e-3 if kind == "trc" else 1e-5)
    assert np.ptp(got) > 0.5


def test_the_landmarks_can_be_kept_instead_of_the_markers_they_are_made_of(skin_files, tmp_path):
    from colloc.cli import main
    from colloc.data import read_trial

    code = main(
        ["gait", "trial-from-lab", str(skin_files["tsv"]), "--static",
         str(skin_files["static_tsv"]), "--mass", "75", "--height", "1.8", "--belt-speed",
         "LeftBeltSpeed", "--track", "landmarks", "--out", str(tmp_path / "t")]
    )  # fmt: skip
    assert code == 0
    segments = read_trial(tmp_path / "t").metadata["markers"]["segments"]
    assert segments["RLEK"] == "right_thigh" and segments["RGTRO"] == "trunk"
    assert "R.Thigh.Front" not in segments
    with pytest.raises(ValueError, match=r"track: expected one of \['markers', 'landmarks'\]"):
        trial_from_lab(
            skin_files["tsv"], LabSettings(*SUBJECT, belt_speed=1.2),
            static=skin_files["static_tsv"], track="clusters",
        )  # fmt: skip
