"""Markers' places in their segments estimated with the motion (``gait smooth --fit-places``).

Reference: where the synthetic lab put each marker, from the walk's true coordinates and its
noise-free markers (:func:`colloc.models.gait2d_markers.local_positions` on exact data is
the place itself). The smoother starts from places moved several millimetres off.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import sympy as sm
import yaml

from colloc.cli import main
from colloc.identify.gait.settings import GaitIdentifySettings
from colloc.lab import LabNoise, LabSettings, lab_export_from_record, process_lab
from colloc.models.gait2d_markers import local_positions
from colloc.models.gait2d_params import load_parameters

SUBJECT = (75.0, 1.8)  # the session walk's (tests/lab/conftest.py)
#: Standard deviation [m] of the moves off the true places the smoother starts from.
START_OFFSET = 0.005


@pytest.fixture(scope="module")
def lab_trial(walk):
    export = lab_export_from_record(walk, load_parameters(*SUBJECT), seed=5)  # 1 mm, 2 N
    return process_lab(export, LabSettings(*SUBJECT, belt_speed="RightBeltSpeed")).trial


@pytest.fixture(scope="module")
def true_places(walk, walk_parts, lab_trial):
    params = load_parameters(*SUBJECT)
    exact = lab_export_from_record(walk, params, seed=0, noise=LabNoise(0.0, 0.0, 0.0))
    gait = walk_parts[1][3].gait  # the walk's own model
    constants = gait.constant_array(params)
    segments = lab_trial.metadata["markers"]["segments"]
    return local_positions(gait, constants, walk.states[:, :9], exact.markers, segments)


@pytest.fixture(scope="module")
def fitted(lab_trial, true_places, tmp_path_factory):
    """``gait smooth --fit-places`` on 1.5 s, started off the true places; its JSON."""
    folder = lab_trial.write(tmp_path_factory.mktemp("places") / "lab")
    meta_file = folder / "metadata.yaml"
    meta = yaml.safe_load(meta_file.read_text())
    rng = np.random.default_rng(11)
    start = {
        name: (np.asarray(xy) + START_OFFSET * rng.standard_normal(2)).tolist()
        for name, xy in true_places.items()
    }
    meta["markers"]["in_segment_m"] = start
    meta["markers"]["in_segment_from"] = "the true places moved off by the test"
    meta_file.write_text(yaml.safe_dump(meta))
    out = folder.parent / "smoothed"
    window = ["--start", "1.1", "--duration", "1.5", "--no-plots"]
    assert main(["gait", "smooth", str(folder), "--out", str(out), "--fit-places", *window]) == 0
    summary = json.loads((out / "smooth.json").read_text())
    return summary, start


def test_the_places_return_to_where_the_markers_sit(fitted, true_places):
    summary, start = fitted
    assert "markers' places in their segments: estimated with the motion" in summary["notes"]
    (window,) = summary["windows"]
    markers = window["tracking"]["markers"]
    assert set(markers) == set(true_places)
    for name, entry in markers.items():
        truth = np.asarray(true_places[name])
        np.testing.assert_allclose(entry["start_m"], start[name], atol=1e-12)
        before = np.abs(np.asarray(start[name]) - truth).max()
        after = np.abs(np.asarray(entry["in_segment_m"]) - truth).max()
        # measured: 3-12 mm off at the start, within 0.9 mm after (the ankle's height read
        # from the loaded feet, 0.7 mm off the walk's, moves them all a little)
        assert after < 1.5e-3, (name, after)
        assert after < before or before < 1.5e-3, (name, before, after)
        assert entry["from"].startswith("estimated with the motion, started from")


def test_the_record_determines_the_places_it_ties_to_a_joint(fitted):
    summary, _ = fitted
    markers = summary["windows"][0]["tracking"]["markers"]
    for name, entry in markers.items():
        sd = np.asarray(entry["place_sd_m"])
        share = np.asarray(entry["record_share"])
        assert np.all(sd > 0) and np.all((share >= 0) & (share <= 1))
        if entry["segment"].endswith(("thigh", "shank")):
            # a joint below the segment ties its markers to the record: a fraction of a
            # millimetre, the prior's 10 mm playing no part
            assert sd.max() < 1e-3 and share.min() > 0.99, (name, sd, share)


def test_fit_places_needs_a_smoother_that_tracks_markers(lab_trial, tmp_path, capsys):
    folder = lab_trial.write(tmp_path / "lab")
    code = main(
        ["gait", "smooth", str(folder), "--out", str(tmp_path / "o"), "--fit-places"]
        + ["--smooth-from", "angles", "--no-plots", "--start", "1.1", "--duration", "1.5"]
    )
    assert code == 2
    assert "fit_places: the markers' places are estimated by a smoother that tracks them" in (
        capsys.readouterr().err
    )


def test_identify_settings_refuse_fit_places_without_the_marker_smoother(tmp_path):
    settings = GaitIdentifySettings(trial=tmp_path, fit_places=True, smooth_from="angles")
    assert any("fit_places" in p for p in settings.problems(require_trial=False))
    wrong = GaitIdentifySettings(trial=tmp_path, fit_places="yes")  # type: ignore[arg-type]
    assert any("expected True or False" in p for p in wrong.problems(require_trial=False))


def test_output_parameters_need_their_update_and_a_positive_prior(walk_parts):
    from colloc.identify.gait.smoother import GaitSmoother

    dynamics = walk_parts[1][3]
    N = 5
    a = sm.Symbol("place_test_a")
    with pytest.raises(ValueError) as caught:
        GaitSmoother(
            dynamics,
            np.arange(N) * 0.01,
            np.zeros((N, 9)),
            np.ones(N),
            np.ones(9),
            output_parameters={a: (0.0, -1.0)},
        )
    message = str(caught.value)
    assert "expected a parameter_update" in message
    assert "place_test_a: expected (start, prior_std)" in message
