"""Landmarks from clusters, static trials and the pelvis (colloc.lab.landmarks, hip_centre),
against points known by construction."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from colloc.lab import LabFileError, LabNoise, LabSettings, lab_export_from_record, trial_from_lab
from colloc.lab.formats.mot import write_mot
from colloc.lab.formats.trc import write_trc
from colloc.lab.hip_centre import hip_joint_centres
from colloc.lab.landmarks import MARKER_SETS, detect_convention, landmark_record
from colloc.lab.record import LabRecord
from colloc.lab.writers import OPENSIM_PLATES, _plate
from colloc.models.gait2d_params import load_parameters

SUBJECT = (75.0, 1.8)


def test_the_hip_centre_follows_harringtons_regression_in_any_pose():
    """A pelvis 240 mm wide and 160 mm deep: the centres lie 0.24 * 160 + 9.9 = 48.3 mm
    behind, 0.30 * 240 + 10.9 = 82.9 mm below and 0.33 * 240 + 7.3 = 86.5 mm to each side of
    the ASIS midpoint, whatever the pelvis' place and turn."""
    rng = np.random.default_rng(0)
    local = {
        "rasis": np.array([0.0, 0.0, 0.12]),
        "lasis": np.array([0.0, 0.0, -0.12]),
        "sacrum": np.array([-0.16, 0.0, 0.0]),
    }
    expected_right = np.array([-0.0483, -0.0829, 0.0865])
    turns = Rotation.from_euler("xyz", rng.uniform(-0.3, 0.3, (5, 3)))
    places = rng.normal(size=(5, 3))
    at = {name: turns.apply(np.tile(p, (5, 1))) + places for name, p in local.items()}
    right, left = hip_joint_centres(at["rasis"], at["lasis"], at["sacrum"], np.array([0, 1.0, 0]))
    np.testing.assert_allclose(
        right, turns.apply(np.tile(expected_right, (5, 1))) + places, atol=1e-12
    )
    mirrored = expected_right * np.array([1, 1, -1])
    np.testing.assert_allclose(left, turns.apply(np.tile(mirrored, (5, 1))) + places, atol=1e-12)


def _clustered(markers: dict[str, np.ndarray], side: str) -> dict[str, np.ndarray]:
    """Three markers fixed on the thigh and on the shank, as rigid clusters (x forward, y up,
    z right, the plane at z = 0)."""
    p = "R." if side == "right" else "L."
    s = side[0].upper()
    out = {}
    for segment, top, bottom in (("Thigh", "GTRO", "LEK"), ("Shank", "LEK", "LM")):
        a, b = markers[f"{s}{top}"], markers[f"{s}{bottom}"]
        axis = (a - b) / np.linalg.norm(a - b, axis=1, keepdims=True)
        normal = np.column_stack([-axis[:, 1], axis[:, 0], np.zeros(len(axis))])
        lateral = np.array([0.0, 0.0, 0.08 if side == "right" else -0.08])
        for name, (along, across, out_of) in {
            "Upper": (0.25, 0.03, 1.0),
            "Front": (0.12, 0.06, 0.6),
            "Rear": (0.10, -0.05, 0.9),
        }.items():
            out[f"{p}{segment}.{name}"] = b + along * (a - b) + across * normal + out_of * lateral
        del axis
    return out


@pytest.fixture(scope="module")
def opensim_style(walk, tmp_path_factory):
    """A noise-free simulated walk written as OpenSim's example set is: clusters on thigh and
    shank, epicondyles and malleoli only in a static trial, pelvis markers for the hip."""
    record = walk
    export = lab_export_from_record(
        record, load_parameters(*SUBJECT), seed=0, noise=LabNoise(0, 0, 0)
    )
    planar = export.markers
    three = {}
    for side, z in (("right", 0.09), ("left", -0.09)):
        s = side[0].upper()
        lift = lambda xy, zz=z: np.column_stack([xy, np.full(len(xy), zz)])  # noqa: E731
        three[f"{s}.Acromium"] = lift(planar[f"{s}SHO"])
        three[f"{s}.Heel"] = lift(planar[f"{s}HEE"])
        three[f"{s}.Toe.Lat"] = lift(planar[f"{s}MT5"])
        for landmark, name in (("LEK", "Knee"), ("LM", "Ankle")):
            three[f"{s}.{name}.Lat"] = lift(planar[f"{s}{landmark}"]) + [0, 0, 0.05 * np.sign(z)]
            three[f"{s}.{name}.Med"] = lift(planar[f"{s}{landmark}"]) - [0, 0, 0.05 * np.sign(z)]
        three |= _clustered({k: lift(v) for k, v in planar.items() if k.startswith(s)}, side)
    # a pelvis whose Harrington centres fall on the simulated hip: width 240 mm, depth 160 mm
    hip = np.column_stack([planar["RGTRO"], np.zeros(len(export.time))])
    middle = hip - np.array([-0.0483, -0.0829, 0.0])
    three["R.ASIS"] = middle + [0, 0, 0.12]
    three["L.ASIS"] = middle - [0, 0, 0.12]
    three["V.Sacral"] = middle - [0.16, 0, 0]
    folder = tmp_path_factory.mktemp("opensim-style")
    walk = {k: v for k, v in three.items() if ".Knee." not in k and ".Ankle." not in k}
    write_trc(folder / "walk.trc", export.time, walk)
    # standing still: one pose held for 0.3 s
    write_trc(
        folder / "static.trc",
        export.time[:30],
        {k: np.repeat(v[100:101], 30, axis=0) for k, v in three.items()},
    )
    plates = {
        OPENSIM_PLATES[side]: _plate(export, name, (0, 1), 2, 0.0)
        for side, name in (("right", "FP2"), ("left", "FP1"))
    }
    write_mot(folder / "walk_grf.mot", plates)
    return export, folder


def test_knees_and_ankles_marked_only_standing_are_carried_by_the_clusters(opensim_style):
    export, folder = opensim_style
    settings = LabSettings(*SUBJECT, belt_speed=1.2)
    result = trial_from_lab(
        folder / "walk.trc", settings, folder / "walk_grf.mot", static=folder / "static.trc"
    )
    reference = trial_from_lab(_tsv(export, folder), settings)
    made = result.trial.metadata["lab"]["landmarks"]
    assert made["marker_set"].startswith("OpenSim gait2354")
    assert made["landmarks"]["RLEK"]["carried_by"] == [
        "R.Thigh.Upper",
        "R.Thigh.Front",
        "R.Thigh.Rear",
    ]
    assert "Harrington" in made["landmarks"]["LGTRO"]
    difference = (result.trial.signals - reference.trial.signals).abs().max()
    # the TSV holds 1e-6 m; the carried knees and ankles and the regressed hips are exact
    assert difference.filter(regex="_angle$").max() < 1e-5
    assert difference.filter(like="_torque").max() < 5e-3


def test_a_frame_with_a_cluster_marker_unseen_leaves_a_gap_there_only(opensim_style):
    _, folder = opensim_style
    from colloc.lab.formats.trc import read_trc

    walk, static = read_trc(folder / "walk.trc"), read_trc(folder / "static.trc")
    full, _ = landmark_record(walk, static)
    walk.markers["R.Thigh.Front"][40] = np.nan
    walk.markers["R.Shank.Front"][50:52] = np.nan
    walk.markers["R.Shank.Rear"][51] = np.nan
    partial, _ = landmark_record(walk, static)
    # a three-marker cluster with one unseen has no pose: the landmark is a gap there (which
    # the pipeline fills like any marker's), and the frames around it are untouched
    assert np.isnan(partial.markers["RLEK"][40]).all()
    np.testing.assert_allclose(partial.markers["RLEK"][39], full.markers["RLEK"][39], atol=1e-12)
    assert np.isnan(partial.markers["RLM"][50:52]).all()
    np.testing.assert_allclose(partial.markers["RLM"][52], full.markers["RLM"][52], atol=1e-12)


def test_a_walk_without_its_knees_and_no_static_trial_is_refused_by_name(opensim_style):
    _, folder = opensim_style
    from colloc.lab.formats.trc import read_trc

    walk = read_trc(folder / "walk.trc")
    with pytest.raises(
        LabFileError, match="right knee: R.Knee.Lat/R.Knee.Med \\(in the walk, or in a static trial"
    ):
        detect_convention(walk)
    assert [c.name.split()[0] for c in MARKER_SETS] == ["colloc", "OpenSim", "Plug-in"]
    assert isinstance(walk, LabRecord)


def _tsv(export, folder):
    from colloc.lab.synthetic import write_lab_export

    return write_lab_export(export, folder / "reference.tsv")
