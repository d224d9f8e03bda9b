"""Trial files: reading a gait-lab style TSV, round trips, atomic writes, every error path."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

import colloc.data.trial as trial_module
from colloc.data.checks import TrialError
from colloc.data.columns import (
    COLUMN_UNITS,
    GRF_COLUMNS,
    JOINTS,
    SIDES,
    SIGNAL_COLUMNS,
    TORQUE_COLUMNS,
    TRUNK_RATE_COLUMNS,
    normalize_unit,
)
from colloc.data.text_tables import detect_delimiter
from colloc.data.trial import Trial, read_trial

FIXTURE = Path(__file__).resolve().parent / "fixtures" / "gait_trial_tsv"


def expected_signal(name: str, time: np.ndarray) -> np.ndarray:
    """Closed form used by fixtures/make_gait_trial_tsv.py (before rounding)."""
    joints = [f"{side}_{joint}" for side in SIDES for joint in JOINTS]
    for j, joint in enumerate(joints):
        phase = 2 * np.pi * time + 0.3 * j
        closed_forms = {
            f"{joint}_angle": 0.5 * np.sin(phase),
            f"{joint}_rate": np.pi * np.cos(phase),
            f"{joint}_torque": 10.0 * np.sin(phase),
        }
        if name in closed_forms:
            return closed_forms[name]
    return {
        "trunk_x": 0.05 * np.sin(2 * np.pi * time),
        "trunk_y": np.ones_like(time),
        "trunk_angle": 0.02 * np.cos(2 * np.pi * time),
        "belt_speed": np.full_like(time, 1.2),
        "belt_position": 1.2 * time,
    }[name]


@pytest.fixture
def trial() -> Trial:
    return read_trial(FIXTURE)


@pytest.fixture
def trial_dir(tmp_path: Path, trial: Trial) -> Path:
    return trial.write(tmp_path / "trial")


def test_read_gait_lab_tsv_matches_closed_form(trial: Trial) -> None:
    np.testing.assert_allclose(trial.time, np.arange(201) * 0.05, atol=1e-12)
    for name in SIGNAL_COLUMNS:
        if name in TRUNK_RATE_COLUMNS + GRF_COLUMNS:  # the fixture, like much lab output, has none
            assert name not in trial.signals.columns
            continue
        np.testing.assert_allclose(
            trial.signals[name], expected_signal(name, trial.time), atol=5.1e-7, err_msg=name
        )
    assert "marker_gaps" in trial.signals.columns  # extra columns are kept
    np.testing.assert_allclose(trial.right_heel_strikes, 0.27 + np.arange(10))
    np.testing.assert_allclose(trial.left_heel_strikes, 0.77 + np.arange(10))
    assert trial.metadata["body_mass"] == 70.5
    assert trial.metadata["controller"]["gains"][1] == [[5.0, 6.0], [7.0, 8.0]]


def test_read_time_series_file_path_uses_sibling_files(trial: Trial) -> None:
    by_file = read_trial(FIXTURE / "trial.tsv")
    np.testing.assert_array_equal(by_file.time, trial.time)
    np.testing.assert_array_equal(by_file.left_heel_strikes, trial.left_heel_strikes)


def test_round_trip_is_exact_and_adds_units(tmp_path: Path, trial: Trial) -> None:
    trial.metadata["controller"]["offsets"] = np.array([0.5, np.float64(1.25)])
    trial.metadata["seed"] = np.int64(7)
    trial.metadata.pop("units")
    again = read_trial(trial.write(tmp_path / "out"))
    np.testing.assert_array_equal(again.time, trial.time)
    pd.testing.assert_frame_equal(again.signals, trial.signals, check_dtype=False)
    np.testing.assert_array_equal(again.right_heel_strikes, trial.right_heel_strikes)
    np.testing.assert_array_equal(again.left_heel_strikes, trial.left_heel_strikes)
    assert again.metadata["controller"]["offsets"] == [0.5, 1.25]
    assert again.metadata["seed"] == 7
    assert again.metadata["units"]["left_ankle_torque"] == "N·m"
    assert again.metadata["units"]["time"] == "s"
    assert "marker_gaps" not in again.metadata["units"]


def test_write_refuses_existing_directory(trial_dir: Path, trial: Trial) -> None:
    with pytest.raises(FileExistsError, match="already exists; pass overwrite=True"):
        trial.write(trial_dir)


def test_overwrite_replaces_trial_and_leaves_no_temporaries(trial_dir: Path, trial: Trial) -> None:
    trial.signals["belt_speed"] = 1.5
    trial.write(trial_dir, overwrite=True)
    assert np.all(read_trial(trial_dir).signals["belt_speed"] == 1.5)
    assert [p.name for p in trial_dir.parent.iterdir()] == ["trial"]


@pytest.mark.parametrize(
    "foreign",
    ["notes.txt", "export.tsv", ".hidden", "sub/"],
)
def test_overwrite_never_replaces_a_folder_holding_anything_but_a_trial(
    tmp_path: Path, trial: Trial, foreign: str
) -> None:
    folder = tmp_path / "mine"
    folder.mkdir()
    if foreign.endswith("/"):
        (folder / foreign).mkdir()
        (folder / foreign / "data.bin").write_bytes(b"keep")
    else:
        (folder / foreign).write_text("keep")
    before = sorted(p.relative_to(folder) for p in folder.rglob("*"))
    with pytest.raises(FileExistsError, match=f"holds '{foreign.rstrip('/')}', which is not"):
        trial.write(folder, overwrite=True)
    assert sorted(p.relative_to(folder) for p in folder.rglob("*")) == before
    assert [p.name for p in tmp_path.iterdir()] == ["mine"]


def test_overwrite_refuses_a_file_and_a_link_and_keeps_them(tmp_path: Path, trial: Trial) -> None:
    file = tmp_path / "a-file"
    file.write_text("keep")
    with pytest.raises(FileExistsError, match="is a file, not a trial folder"):
        trial.write(file, overwrite=True)
    assert file.read_text() == "keep"
    real = tmp_path / "real"
    trial.write(real)
    link = tmp_path / "link"
    link.symlink_to(real, target_is_directory=True)
    with pytest.raises(FileExistsError, match="is a link, not a trial folder"):
        trial.write(link, overwrite=True)
    assert link.is_symlink() and read_trial(real).time.size == trial.time.size


def test_overwrite_replaces_an_empty_folder(tmp_path: Path, trial: Trial) -> None:
    (tmp_path / "empty").mkdir()
    assert read_trial(trial.write(tmp_path / "empty", overwrite=True)).time.size == trial.time.size


def test_failed_write_keeps_the_good_trial(
    trial_dir: Path, trial: Trial, monkeypatch: pytest.MonkeyPatch
) -> None:
    before = (trial_dir / "trial.csv").read_bytes()

    def broken_dump(*args: object, **kwargs: object) -> None:
        raise OSError("disk full")

    monkeypatch.setattr(trial_module.yaml, "safe_dump", broken_dump)
    trial.signals["belt_speed"] = 1.5
    with pytest.raises(OSError, match="disk full"):
        trial.write(trial_dir, overwrite=True)
    with pytest.raises(OSError, match="disk full"):
        trial.write(trial_dir.parent / "fresh")
    assert (trial_dir / "trial.csv").read_bytes() == before
    assert [p.name for p in trial_dir.parent.iterdir()] == ["trial"]


def test_invalid_trial_is_not_written(tmp_path: Path, trial: Trial) -> None:
    trial.signals.loc[3, "trunk_y"] = np.nan
    with pytest.raises(TrialError, match="column 'trunk_y' has 1 NaN"):
        trial.write(tmp_path / "bad")
    assert not (tmp_path / "bad").exists()


def test_construction_checks_types_and_shapes(trial: Trial) -> None:
    with pytest.raises(TypeError, match="signals must be a pandas.DataFrame, found dict"):
        Trial(trial.time, {}, trial.right_heel_strikes, trial.left_heel_strikes)
    with pytest.raises(TrialError, match=r"one row per time sample \(200\), found 201 rows"):
        Trial(trial.time[:-1], trial.signals, trial.right_heel_strikes, trial.left_heel_strikes)
    with pytest.raises(TrialError, match=r"left_heel_strikes must be 1-D, found shape \(1, 2\)"):
        Trial(trial.time, trial.signals, [1.0], [[1.0, 2.0]])


def test_detect_delimiter(tmp_path: Path) -> None:
    assert detect_delimiter(FIXTURE / "trial.tsv") == "\t"
    assert detect_delimiter(FIXTURE / "events.csv") == ","
    (tmp_path / "one.tsv").write_text("time\n0\n")
    (tmp_path / "one.csv").write_text("time\n0\n")
    (tmp_path / "semi.csv").write_text("time;x\n0;1\n")
    assert detect_delimiter(tmp_path / "one.tsv") == "\t"
    assert detect_delimiter(tmp_path / "one.csv") == ","
    assert detect_delimiter(tmp_path / "semi.csv") == ";"


def test_unit_spellings_compare_equal() -> None:
    assert normalize_unit("N m") == normalize_unit("N·m") == normalize_unit("n*M")
    assert normalize_unit("rad/s") != normalize_unit("rad")
    assert {COLUMN_UNITS[name] for name in TORQUE_COLUMNS} == {"N·m"}


# --- error paths of read_trial ------------------------------------------------------------


def _edit_series(directory: Path, edit) -> None:
    frame = edit(pd.read_csv(directory / "trial.csv"))
    frame.to_csv(directory / "trial.csv", index=False)


def _edit_metadata(directory: Path, edit) -> None:
    metadata = yaml.safe_load((directory / "metadata.yaml").read_text(encoding="utf-8"))
    edit(metadata)
    (directory / "metadata.yaml").write_text(yaml.safe_dump(metadata), encoding="utf-8")


def test_missing_columns_are_listed(trial_dir: Path) -> None:
    _edit_series(trial_dir, lambda f: f.drop(columns=["trunk_y", "right_knee_angle"]))
    with pytest.raises(TrialError, match=r"missing columns \['right_knee_angle', 'trunk_y'\]"):
        read_trial(trial_dir)


def test_incomplete_torques_are_listed(trial_dir: Path) -> None:
    _edit_series(trial_dir, lambda f: f.drop(columns=["left_hip_torque"]))
    with pytest.raises(TrialError, match=r"missing columns \['left_hip_torque'\].*all 6 or none"):
        read_trial(trial_dir)


def test_trial_without_torques_is_valid(trial_dir: Path) -> None:
    _edit_series(trial_dir, lambda f: f.drop(columns=list(TORQUE_COLUMNS)))
    assert not set(TORQUE_COLUMNS) & set(read_trial(trial_dir).signals.columns)


def test_misspelled_column_is_hinted(trial_dir: Path) -> None:
    _edit_series(trial_dir, lambda f: f.rename(columns={"trunk_y": "trunkY"}))
    with pytest.raises(TrialError, match=r"not recognised: \['marker_gaps', 'trunkY'\]"):
        read_trial(trial_dir)


def test_missing_time_column(trial_dir: Path) -> None:
    _edit_series(trial_dir, lambda f: f.rename(columns={"time": "Time"}))
    with pytest.raises(TrialError, match="missing time column 'time'"):
        read_trial(trial_dir)


def test_non_monotonic_time_names_first_sample(trial_dir: Path) -> None:
    def swap(frame: pd.DataFrame) -> pd.DataFrame:
        frame.loc[[4, 5], "time"] = frame.loc[[5, 4], "time"].to_numpy()
        return frame

    _edit_series(trial_dir, swap)
    with pytest.raises(TrialError, match=r"sample 5 \(time 0.2 s\) is not after sample 4"):
        read_trial(trial_dir)


def test_nans_are_counted_per_column(trial_dir: Path) -> None:
    def spoil(frame: pd.DataFrame) -> pd.DataFrame:
        frame.loc[[10, 11, 40], "left_hip_rate"] = np.nan
        frame["belt_speed"] = frame["belt_speed"].astype(object)
        frame.loc[7, "belt_speed"] = "n/a"
        return frame

    _edit_series(trial_dir, spoil)
    with pytest.raises(TrialError) as info:
        read_trial(trial_dir)
    message = str(info.value)
    assert "column 'left_hip_rate' has 3 NaN/infinite/non-numeric values" in message
    assert "(first at sample 10, time 0.5 s)" in message
    assert "column 'belt_speed' has 1 NaN" in message


def test_non_uniform_sampling(trial_dir: Path) -> None:
    _edit_series(trial_dir, lambda f: f.assign(time=f["time"].where(f.index != 50, 2.52)))
    with pytest.raises(TrialError, match=r"not uniformly sampled: 2 steps .* first between "):
        read_trial(trial_dir)
    assert read_trial(trial_dir, sampling_tolerance=0.5).time[50] == 2.52


def test_sample_rate_must_agree_with_time(trial_dir: Path) -> None:
    _edit_metadata(trial_dir, lambda m: m.__setitem__("sample_rate", 100))
    with pytest.raises(TrialError, match="'sample_rate' is 100 Hz but .* sampled at 20 Hz"):
        read_trial(trial_dir)


def test_heel_strikes_out_of_order_and_range(trial_dir: Path) -> None:
    events = pd.read_csv(trial_dir / "events.csv")
    events.loc[events.side == "right", "time"] = [0.27, 2.27, 1.27, 3.27, 4, 5, 6, 7, 8, 12.5]
    events.to_csv(trial_dir / "events.csv", index=False)
    with pytest.raises(TrialError) as info:
        read_trial(trial_dir)
    message = str(info.value)
    assert "right_heel_strikes are not strictly increasing: strike 2 (1.27 s)" in message
    assert (
        "right_heel_strikes has 1 strikes outside the time range [0, 10] s, first 12.5" in message
    )


def test_wrong_units_and_bad_constants(trial_dir: Path) -> None:
    def spoil(metadata: dict) -> None:
        metadata["units"]["right_hip_angle"] = "deg"
        metadata["units"]["belt_position"] = "mm"
        metadata["body_mass"] = -70

    _edit_metadata(trial_dir, spoil)
    with pytest.raises(TrialError) as info:
        read_trial(trial_dir)
    message = str(info.value)
    assert "'right_hip_angle': expected 'rad', found 'deg'" in message
    assert "'belt_position': expected 'm', found 'mm'" in message
    assert "metadata 'body_mass' must be a positive number, found -70" in message
    assert len(info.value.problems) == 2


def test_units_must_be_a_mapping(trial_dir: Path) -> None:
    _edit_metadata(trial_dir, lambda m: m.__setitem__("units", "SI"))
    with pytest.raises(TrialError, match="'units' must map column names to units, found str"):
        read_trial(trial_dir)


def test_metadata_file_problems(trial_dir: Path) -> None:
    (trial_dir / "metadata.yaml").write_text("- just\n- a list\n")
    with pytest.raises(TrialError, match="metadata.yaml must hold a mapping, found list"):
        read_trial(trial_dir)
    (trial_dir / "metadata.yaml").write_text("a: [unclosed\n")
    with pytest.raises(TrialError, match="cannot parse metadata.yaml"):
        read_trial(trial_dir)
    (trial_dir / "metadata.yaml").unlink()
    assert read_trial(trial_dir).metadata == {}


def test_a_key_given_twice_in_the_metadata_is_refused(trial_dir: Path) -> None:
    path = trial_dir / "metadata.yaml"
    path.write_text(path.read_text() + "sample_rate: 50.0\n")  # the file has one already
    with pytest.raises(
        TrialError, match=r"cannot parse metadata.yaml: found the key 'sample_rate' twice"
    ):
        read_trial(trial_dir)


def test_events_file_problems(trial_dir: Path) -> None:
    events = pd.read_csv(trial_dir / "events.csv")
    events.loc[0, "side"] = "middle"
    events.to_csv(trial_dir / "events.csv", index=False)
    with pytest.raises(TrialError, match=r"'side' must be one of \['right', 'left'\].*'middle'"):
        read_trial(trial_dir)
    events.loc[0, "side"] = "right"
    events["time"] = events["time"].astype(object)
    events.loc[1, "time"] = "abc"
    events.to_csv(trial_dir / "events.csv", index=False)
    with pytest.raises(
        TrialError,
        match=r"column 'time': expected numbers in seconds, found 1 that are not \(row 3: 'abc'\)",
    ):
        read_trial(trial_dir)
    events.rename(columns={"time": "t"}).to_csv(trial_dir / "events.csv", index=False)
    with pytest.raises(TrialError, match=r"events.csv is missing columns \['time'\]"):
        read_trial(trial_dir)
    (trial_dir / "events.csv").unlink()
    with pytest.raises(TrialError, match=r"heel-strike file events.csv not found"):
        read_trial(trial_dir)


def test_all_problems_reported_at_once(trial_dir: Path) -> None:
    _edit_series(trial_dir, lambda f: f.drop(columns=["trunk_x"]))
    _edit_metadata(trial_dir, lambda m: m["units"].__setitem__("time", "ms"))
    (trial_dir / "events.csv").write_text("side,time\nright,-1\n")
    with pytest.raises(TrialError, match="4 problems found") as info:
        read_trial(trial_dir)
    assert [p.split(" ")[0] for p in info.value.problems] == [
        "missing",
        "right_heel_strikes",
        "metadata",
        "heel",  # on one side only
    ]


def test_missing_paths(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="does not exist"):
        read_trial(tmp_path / "nowhere")
    with pytest.raises(TrialError, match=r"no time-series file found; expected one of"):
        read_trial(tmp_path)
    (tmp_path / "trial.csv").write_text("")
    shutil.copy(FIXTURE / "events.csv", tmp_path / "events.csv")
    with pytest.raises(TrialError, match="cannot parse trial.csv"):
        read_trial(tmp_path)


def test_content_problems_of_a_trial_in_memory(trial: Trial) -> None:
    short = Trial(trial.time[:1], trial.signals.iloc[:1], [], [], {"height": "tall"})
    found = short.problems()
    assert found == [
        "column 'time' needs at least 2 samples, found 1",
        "metadata 'height' must be a positive number, found 'tall'",
        "no heel strikes: the events file lists none",
    ]
    time = trial.time.copy()
    time[3] = np.nan
    odd = Trial(time, trial.signals, [np.nan, 1.0], trial.left_heel_strikes, ["not", "a", "map"])
    with pytest.raises(TrialError, match="3 problems found") as info:
        odd.validate()
    assert info.value.problems == [
        "column 'time' has 1 NaN/infinite values (first at sample 3)",
        "right_heel_strikes has 1 NaN/infinite times",
        "metadata must be a mapping, found list",
    ]


def test_trunk_rate_columns_are_all_or_none(trial_dir: Path) -> None:
    series = trial_module._find_series_file(trial_dir)
    frame = pd.read_csv(series, sep=detect_delimiter(series))
    frame["trunk_x_rate"] = 0.0
    frame.to_csv(series, sep=detect_delimiter(series), index=False)
    with pytest.raises(
        TrialError,
        match=r"missing columns \['trunk_y_rate', 'trunk_angle_rate'\] \(trunk rate columns "
        r"are optional, but all 3 or none\)",
    ):
        read_trial(trial_dir)
    frame["trunk_y_rate"] = 0.0
    frame["trunk_angle_rate"] = 0.5
    frame.to_csv(series, sep=detect_delimiter(series), index=False)
    np.testing.assert_array_equal(read_trial(trial_dir).signals["trunk_angle_rate"], 0.5)


def test_latin1_metadata_is_named_not_a_raw_decode_error(trial_dir: Path) -> None:
    path = trial_dir / "metadata.yaml"
    path.write_bytes(path.read_bytes() + "subject: J\xfcrgen\n".encode("latin-1"))
    with pytest.raises(TrialError, match=r"metadata.yaml is not UTF-8 text \(byte 0xfc"):
        read_trial(trial_dir)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda f: f.assign(right_hip_angle=np.degrees(f["right_hip_angle"])), "in radians but"),
        (lambda f: f.assign(right_knee_angle=1e300), r"reaches 1e\+300: not a physical signal"),
        (
            lambda f: f.assign(time=f["time"] * 1000),
            r"steps by \d+ \(a rate of .* Hz\): not seconds\?",
        ),
        (lambda f: f.assign(belt_speed=f["belt_speed"] > 0), "holds true/false values"),
    ],
    ids=["degrees", "1e300", "milliseconds", "true-false"],
)
def test_implausible_data_are_named(trial_dir: Path, edit, message) -> None:
    if "not seconds" in message:
        _edit_metadata(trial_dir, lambda m: m.pop("sample_rate", None))
    _edit_series(trial_dir, edit)
    with pytest.raises(TrialError, match=message):
        read_trial(trial_dir)


def test_strikes_on_one_side_duplicate_columns_and_two_series_files_are_named(
    trial_dir: Path,
) -> None:
    events = pd.read_csv(trial_dir / "events.csv")
    events.assign(side="right").to_csv(trial_dir / "events.csv", index=False)
    with pytest.raises(TrialError, match=r"heel strikes on one side only \(\d+ right, 0 left\)"):
        read_trial(trial_dir)
    events.iloc[:0].to_csv(trial_dir / "events.csv", index=False)
    with pytest.raises(TrialError, match="no heel strikes"):
        read_trial(trial_dir)
    events.to_csv(trial_dir / "events.csv", index=False)
    series = next(p for p in trial_dir.iterdir() if p.name.startswith("trial."))
    lines = series.read_text().splitlines()
    sep = detect_delimiter(series)
    header = lines[0].split(sep)
    lines = [sep.join([*row.split(sep), row.split(sep)[header.index("time")]]) for row in lines]
    series.write_text("\n".join(lines) + "\n")
    with pytest.raises(TrialError, match="column 'time' appears more than once"):
        read_trial(trial_dir)
    other = "trial.tsv" if series.name == "trial.csv" else "trial.csv"
    (trial_dir / other).write_text("time\n0\n")
    with pytest.raises(TrialError, match="several time-series files"):
        read_trial(trial_dir)
