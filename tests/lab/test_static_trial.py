"""The subject in the model from the standing trial: segment lengths between its landmarks,
and each tracked marker's position in its segment.

Reference: the positions the synthetic lab placed the markers at, read back through gait2d's
own segment frames (:func:`colloc.models.gait2d_markers.local_positions` on the simulated
walk's exact states and the markers without noise), and the model's segment lengths.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from colloc.data.columns import JOINT_ANGLE_COLUMNS, TRUNK_COLUMNS
from colloc.gait.orbit import GaitDynamics
from colloc.identify.gait.markers import marker_smoother
from colloc.lab import LabFileError, LabSettings, trial_from_lab
from colloc.lab.formats import read_lab_file
from colloc.lab.skin_markers import skin_marker_positions
from colloc.lab.static_trial import static_calibration
from colloc.lab.synthetic_skin import skin_lab_from_record
from colloc.lab.writers import write_skin_lab
from colloc.models.gait2d_markers import local_positions
from colloc.models.gait2d_params import load_parameters
from colloc.models.gait2d_points import StickFigureGeometry

SUBJECT = (75.0, 1.8)  # the session walk's (tests/lab/conftest.py)


@pytest.fixture(scope="module")
def skin_files(walk, tmp_path_factory) -> dict[str, Path]:
    lab = skin_lab_from_record(walk, load_parameters(*SUBJECT), seed=8)
    return write_skin_lab(lab, tmp_path_factory.mktemp("static"))


@pytest.fixture(scope="module")
def trial(skin_files):
    """The skin export's trial with the markers placed from the standing trial."""
    settings = LabSettings(*SUBJECT, belt_speed=1.2)
    return trial_from_lab(
        skin_files["trc"],
        settings,
        skin_files["mot"],
        static=skin_files["static_trc"],
        static_positions=True,
    ).trial


@pytest.fixture(scope="module")
def truth(walk, walk_parts, trial):
    """Each tracked marker's true position in its segment, through the model's frames."""
    dynamics = walk_parts[1][3]
    gait = dynamics.gait
    p = np.array([dynamics.constants[c] for c in gait.constants])
    geometry = StickFigureGeometry.from_parameters(load_parameters(*SUBJECT))
    exact = skin_marker_positions(walk.states[:, :9], geometry)
    segments = trial.metadata["markers"]["segments"]
    markers = {name: exact[name][:, :2] for name in segments}
    return local_positions(gait, p, walk.states[:, :9], markers, segments)


def test_the_static_trial_places_every_marker_in_its_segment(trial, truth):
    placed = trial.metadata["markers"]["in_segment_m"]
    assert set(placed) == set(truth)
    errors = {name: np.abs(np.array(placed[name]) - truth[name]).max() for name in truth}
    # 1 mm of noise over 200 standing frames; measured at most 0.3 mm
    assert max(errors.values()) < 0.5e-3, errors
    assert "static trial" in trial.metadata["markers"]["in_segment_from"]


def test_the_static_trial_gives_the_models_segment_lengths(trial):
    lengths = trial.metadata["lab"]["segment_lengths_m"]
    params = load_parameters(*SUBJECT)
    for side in ("right", "left"):
        assert lengths[f"{side}_thigh"]["static"] == pytest.approx(params.thigh.length, abs=5e-4)
        assert lengths[f"{side}_shank"]["static"] == pytest.approx(params.shank.length, abs=5e-4)
        # the walk's own estimate is kept beside it
        assert "measured" in lengths[f"{side}_thigh"]
    assert any(n.startswith("static trial ") for n in trial.metadata["lab"]["notes"])


def test_the_walks_own_fit_places_them_as_well_without_soft_tissue(walk_parts, trial, truth):
    """The fallback without a static trial: least squares over the walk's 6 Hz inverse
    kinematics. On a synthetic walk, whose markers are fixed to their bones, it lands as
    close as the static trial (measured 0.24 against 0.21 mm at worst): what the static
    trial adds is a reference that does not depend on the walk's own pose estimate."""
    dynamics = walk_parts[1][3]
    gait = dynamics.gait
    p = np.array([dynamics.constants[c] for c in gait.constants])
    table = trial.tables["markers"]
    segments = trial.metadata["markers"]["segments"]
    markers = {n: table[[f"{n}_x", f"{n}_y"]].to_numpy() for n in segments}
    pose = trial.signals[list(TRUNK_COLUMNS + JOINT_ANGLE_COLUMNS)].to_numpy()
    walked = local_positions(gait, p, pose, markers, segments)
    assert max(np.abs(walked[n] - truth[n]).max() for n in truth) < 0.5e-3


def test_the_marker_smoother_takes_the_static_trials_positions_and_lengths(trial):
    dynamics = GaitDynamics.build(load_parameters(*SUBJECT))
    _, facts = marker_smoother(dynamics, trial, np.arange(40))
    placed = trial.metadata["markers"]["in_segment_m"]
    for name, fact in facts["markers"].items():
        assert fact["in_segment_m"] == pytest.approx(placed[name], abs=1e-12)
        assert "static trial" in fact["from"]
    lengths = trial.metadata["lab"]["segment_lengths_m"]
    thigh = np.mean([lengths[f"{side}_thigh"]["static"] for side in ("right", "left")])
    assert facts["segment_lengths_m"]["thigh"] == pytest.approx(thigh, abs=1e-12)


def test_by_default_the_static_trial_is_recorded_and_the_walk_places_the_markers(
    skin_files, trial, tmp_path
):
    settings = LabSettings(*SUBJECT, belt_speed=1.2)
    default = trial_from_lab(
        skin_files["trc"], settings, skin_files["mot"], static=skin_files["static_trc"]
    ).trial
    recorded = default.metadata["lab"]["static_trial"]
    assert recorded["used"] is False and recorded["frames"] == 200
    assert recorded["in_segment_m"] == trial.metadata["markers"]["in_segment_m"]
    assert "in_segment_m" not in default.metadata["markers"]
    assert all("static" not in v for v in default.metadata["lab"]["segment_lengths_m"].values())
    dynamics = GaitDynamics.build(load_parameters(*SUBJECT))
    _, facts = marker_smoother(dynamics, default, np.arange(40))
    assert all("walk's inverse kinematics" in f["from"] for f in facts["markers"].values())
    # asked for without a static trial: refused by name, on the command line too
    with pytest.raises(
        LabFileError,
        match=r"static_positions \(--static-positions\): asked for, but no static trial",
    ):
        trial_from_lab(skin_files["trc"], settings, skin_files["mot"], static_positions=True)
    from colloc.cli import main

    argv = ["gait", "trial-from-lab", str(skin_files["trc"]), "--forces", str(skin_files["mot"])]
    argv += ["--mass", "75", "--height", "1.8", "--belt-speed", "1.2", "--static-positions"]
    assert main([*argv, "--out", str(tmp_path / "t")]) == 2
    assert not (tmp_path / "t").exists()


def test_a_static_trial_without_the_heels_is_a_note_unless_its_positions_are_asked_for(
    skin_files, tmp_path
):
    """The walk marks its heels; a standing trial without them still carries the knees and
    ankles the walk needs, so the trial is made, and says why the subject standing was not
    measured. Asked to place the markers from it, the same files are refused."""
    import pandas as pd

    standing = pd.read_csv(skin_files["static_tsv"], sep="\t")
    heels = [c for c in standing.columns if c.startswith(("R.Heel.", "L.Heel."))]
    static = tmp_path / "static.tsv"
    standing.drop(columns=heels).to_csv(static, sep="\t", index=False)
    settings = LabSettings(*SUBJECT, belt_speed=1.2)
    made = trial_from_lab(skin_files["trc"], settings, skin_files["mot"], static=static).trial
    assert "static_trial" not in made.metadata["lab"]
    assert any(
        "the subject standing was not measured" in n and "Heel" in n
        for n in made.metadata["lab"]["notes"]
    )
    with pytest.raises(LabFileError, match="Heel"):
        trial_from_lab(
            skin_files["trc"], settings, skin_files["mot"], static=static, static_positions=True
        )


def test_a_static_trial_without_a_landmark_is_named(skin_files, tmp_path):
    standing = read_lab_file(skin_files["static_trc"])
    del standing.markers["R.Knee.Med"], standing.markers["R.Knee.Lat"]
    with pytest.raises(LabFileError, match="Knee"):
        static_calibration(standing, {"R.Thigh.Front": "right_thigh"}, [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="forward: expected a horizontal direction"):
        static_calibration(read_lab_file(skin_files["static_trc"]), {}, [0.0, 1.0, 0.0])
