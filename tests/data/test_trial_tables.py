"""A trial's raw markers and plates at their own rates: round trip, slicing, every error."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from colloc.data.checks import TrialError
from colloc.data.split import take_rows
from colloc.data.tables import PLATE_COLUMNS
from colloc.data.trial import read_trial, replace_refusal

FIXTURE = Path(__file__).resolve().parent / "fixtures" / "gait_trial_tsv"


def tables(trial):
    """Markers on the trial's times with a gap; plates ten times faster."""
    t = trial.time
    markers = pd.DataFrame({"time": t, "RLEK_x": np.sin(t), "RLEK_y": 0.5 + 0 * t})
    markers.loc[3:5, ["RLEK_x", "RLEK_y"]] = np.nan
    h = float(np.median(np.diff(t)))
    tp = np.arange(t[0] + h / 20, t[-1], h / 10)  # none on a node's half-step boundary
    plates = pd.DataFrame({"time": tp, **{c: np.cos(tp + k) for k, c in enumerate(PLATE_COLUMNS)}})
    return {"markers": markers, "plates": plates}


def test_tables_round_trip_with_their_gaps_and_rates(tmp_path):
    trial = read_trial(FIXTURE)
    trial.tables = tables(trial)
    back = read_trial(trial.write(tmp_path / "t"))
    for name, table in trial.tables.items():
        pd.testing.assert_frame_equal(back.tables[name], table, check_dtype=False, atol=1e-12)
    assert back.tables["markers"]["RLEK_x"].isna().sum() == 3
    # a trial's own files may be replaced: the tables are among them
    assert replace_refusal(tmp_path / "t") is None


def test_take_rows_keeps_the_tables_rows_of_its_span():
    trial = read_trial(FIXTURE)
    trial.tables = tables(trial)
    part = take_rows(trial, np.arange(10, 20))
    h = float(np.median(np.diff(trial.time)))
    for table in part.tables.values():
        assert table["time"].min() >= trial.time[10] - 0.5 * h - 1e-12
        assert table["time"].max() <= trial.time[19] + 0.5 * h + 1e-12
    np.testing.assert_array_equal(part.tables["markers"]["time"], trial.time[10:20])
    assert len(part.tables["plates"]) == 10 * 10  # ten nodes' cells of ten samples each


@pytest.mark.parametrize(
    ("name", "change", "message"),
    [
        ("markers", lambda m: m.drop(columns="RLEK_y"), "in pairs"),
        ("markers", lambda m: m.assign(RLEK_x=np.inf), "infinite values"),
        ("markers", lambda m: m.assign(time=m["time"][::-1].to_numpy()), "increasing time"),
        ("markers", lambda m: m.drop(columns="time"), "expected a 'time' column"),
        ("plates", lambda p: p.assign(right_moment=np.nan), "expected every plate sample"),
        ("plates", lambda p: p.drop(columns="left_moment"), "expected columns"),
        ("forces", lambda p: p, "expected names among"),
    ],
)
def test_a_bad_table_is_named_and_not_written(tmp_path, name, change, message):
    trial = read_trial(FIXTURE)
    good = tables(trial)
    source = good["plates" if name == "forces" else name]
    trial.tables = {**good, name: change(source.copy())}
    with pytest.raises(TrialError, match=message):
        trial.write(tmp_path / "t")
    assert not (tmp_path / "t").exists()


def test_a_damaged_table_on_disk_is_named(tmp_path):
    trial = read_trial(FIXTURE)
    trial.tables = tables(trial)
    folder = trial.write(tmp_path / "t")
    text = (folder / "markers.csv").read_text().replace("0.5", "half", 1)
    (folder / "markers.csv").write_text(text)
    with pytest.raises(TrialError, match="markers.csv: column 'RLEK_y' holds values that are not"):
        read_trial(folder)
