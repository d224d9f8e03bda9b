"""Gait identification settings: every bad field reported at once, before any work."""

from pathlib import Path

import pytest

from colloc.identify.gait.settings import DEFAULT_TRACK, GaitIdentifySettings


def test_defaults_are_valid_and_plain(tmp_path):
    settings = GaitIdentifySettings(trial=tmp_path)
    assert settings.problems() == []
    plain = settings.to_dict()
    assert plain["trial"] == str(tmp_path) and plain["track"] == list(DEFAULT_TRACK)


def test_every_bad_field_is_named(tmp_path):
    settings = GaitIdentifySettings(
        trial=tmp_path / "missing",
        fit_fraction=1.5,
        points=1,
        feedback="elbows",
        structure="diagonal",
        scheme="rk4",
        phase="moon",
        guess="lucky",
        track=("angles", "angles"),
        start=-1.0,
        duration=0.0,
        segment_nodes=1,
        max_iter=-1,
        smoothing_window=0.0,
        seed=-3,
        process_noise=(1.0, 0.0),
    )
    found = settings.problems()
    for name in (
        "trial", "fit_fraction", "points", "feedback", "structure", "scheme", "phase",
        "guess", "track", "start", "duration", "segment_nodes", "max_iter",
        "smoothing_window", "seed", "process_noise",
    ):  # fmt: skip
        assert any(line.startswith(f"{name}:") for line in found), name
    with pytest.raises(ValueError, match="fit_fraction"):
        settings.validate()


@pytest.mark.parametrize(
    ("value", "method", "expected"),
    [
        (1, "smoother", "whole strides >= 2"),
        (2.5, "smoother", "whole strides >= 2"),
        (True, "smoother", "whole strides >= 2"),
        (4, "closed-loop", "an option of method 'smoother'"),
    ],
)
def test_window_strides_is_checked(tmp_path, value, method, expected):
    settings = GaitIdentifySettings(trial=tmp_path, window_strides=value, method=method)
    found = [p for p in settings.problems() if p.startswith("window_strides:")]
    assert len(found) == 1 and expected in found[0]
    assert GaitIdentifySettings(trial=tmp_path, window_strides=2).problems() == []


def test_track_needs_a_kinematic_signal(tmp_path):
    found = GaitIdentifySettings(trial=Path(tmp_path), track=("torques",)).problems()
    assert found and "angles" in found[0]


def test_process_noise_is_recorded_as_a_list_and_checked(tmp_path):
    assert "process_noise" in GaitIdentifySettings(trial=tmp_path).to_dict()
    plain = GaitIdentifySettings(trial=tmp_path, process_noise=(2.0, 5.0)).to_dict()
    assert plain["process_noise"] == [2.0, 5.0]
    for bad in ((1.0,), [1.0, 2.0], (1.0, float("nan")), (True, 1.0)):
        found = GaitIdentifySettings(trial=tmp_path, process_noise=bad).problems()  # type: ignore[arg-type]
        assert found and found[0].startswith("process_noise:"), bad
