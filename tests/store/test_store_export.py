"""Exports: the files re-read equal to the stored run; failures leave nothing behind."""

from __future__ import annotations

import json
import sqlite3
import zipfile
from datetime import UTC, datetime

import numpy as np
import pandas as pd
import pytest

import colloc.store.export as export_module
from colloc.store import ExportError, ParameterRow, RunRecord, RunStore


@pytest.fixture
def record():
    rng = np.random.default_rng(3)
    return RunRecord(
        run_id="0123456789abcdef",
        kind="pendulum",
        settings={"num_links": 2, "grid": {"h": 0.01}},
        versions={"numpy": "2.4.6"},
        statistics={"iterations": 12},
        ipopt_log="line 1\nline 2\n",
        parameters=[ParameterRow("k_00", -4.5, -4.25, 0.125), ParameterRow("k_01", 1.0, None)],
        arrays={
            "times": np.arange(6) * 0.01,
            "states": rng.normal(size=(6, 4)),
            "force": rng.normal(size=6).astype(np.float32),
            "steps": np.arange(3, dtype=np.int64),
            "file": np.ones(2),  # a name that numpy.savez(**arrays) could not take
        },
        created=datetime(2014, 8, 15, 16, 44, tzinfo=UTC),
    )


@pytest.fixture
def store(record):
    with RunStore("sqlite://") as opened:
        opened.add(record)
        yield opened


def test_csv_export_reads_back_equal(store, record, tmp_path):
    files = store.export("0123", tmp_path / "out", format="csv")
    names = sorted(path.name for path in files)
    assert names == sorted(
        [
            "times.csv",
            "states.csv",
            "force.csv",
            "steps.csv",
            "file.csv",
            "parameters.csv",
            "metadata.json",
        ]
    )
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == names
    metadata = json.loads((tmp_path / "out" / "metadata.json").read_text())
    for name, array in record.arrays.items():
        table = pd.read_csv(tmp_path / "out" / f"{name}.csv")
        layout = metadata["arrays"][name]
        assert list(table.columns) == layout["columns"]
        values = table.to_numpy().astype(np.dtype(layout["dtype"])).reshape(layout["shape"])
        assert np.array_equal(values, array), name
    assert list(pd.read_csv(tmp_path / "out" / "states.csv").columns) == [
        "states_0",
        "states_1",
        "states_2",
        "states_3",
    ]
    parameters = pd.read_csv(tmp_path / "out" / "parameters.csv")
    assert list(parameters["name"]) == ["k_00", "k_01"]
    assert parameters.loc[0, ["known", "identified", "std_error"]].tolist() == [-4.5, -4.25, 0.125]
    assert (
        parameters.loc[1, "known"] == 1.0
        and parameters.loc[1, ["identified", "std_error"]].isna().all()
    )
    assert metadata["settings"] == record.settings
    assert metadata["statistics"] == record.statistics
    assert metadata["ipopt_log"] == record.ipopt_log
    assert metadata["created"] == "2014-08-15T16:44:00+00:00"
    assert metadata["run_id"] == record.run_id


def test_npz_export_reads_back_equal(store, record, tmp_path):
    files = store.export("0123456789abcdef", tmp_path, format="npz")
    assert [p.name for p in files] == ["0123456789abcdef.npz", "0123456789abcdef.json"]
    with np.load(files[0], allow_pickle=False) as archive:
        assert sorted(archive.files) == sorted(record.arrays)
        for name, array in record.arrays.items():
            assert archive[name].dtype == array.dtype
            assert np.array_equal(archive[name], array), name
    document = json.loads(files[1].read_text())
    assert document["parameters"] == [
        {"name": "k_00", "known": -4.5, "identified": -4.25, "std_error": 0.125},
        {"name": "k_01", "known": 1.0, "identified": None, "std_error": None},
    ]
    assert document["arrays"]["states"] == {"dtype": "<f8", "shape": [6, 4]}


def test_failed_export_leaves_no_files_and_keeps_old_ones(store, tmp_path, monkeypatch):
    old = tmp_path / "0123456789abcdef.npz"
    old.write_bytes(b"previous export")

    def failing_write(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(export_module.np.lib.format, "write_array", failing_write)
    with pytest.raises(OSError, match="disk full"):
        store.export("0123", tmp_path, format="npz", overwrite=True)
    assert [p.name for p in tmp_path.iterdir()] == [old.name]
    assert old.read_bytes() == b"previous export"


def test_csv_refuses_arrays_it_cannot_hold_and_writes_nothing(tmp_path):
    with RunStore("sqlite://") as store:
        store.add(
            RunRecord(
                "r",
                "pendulum",
                {},
                {},
                arrays={"cube": np.zeros((2, 2, 2)), "waves": np.ones(3, dtype=complex)},
            )
        )
        with pytest.raises(ExportError, match="format: 'csv' cannot hold this run; use 'npz'") as e:
            store.export("r", tmp_path / "out")
        assert "arrays['waves']" in str(e.value) and "cube" not in str(e.value)
        assert not (tmp_path / "out").exists()
        with zipfile.ZipFile(store.export("r", tmp_path, format="npz")[0]) as archive:
            assert sorted(archive.namelist()) == ["cube.npy", "waves.npy"]


def test_csv_writes_an_array_of_three_dimensions_a_row_per_first_index(tmp_path):
    """A gait run's gains K (P x 6 x n_s) went unexported with the default format."""
    cube = np.arange(24.0).reshape(2, 3, 4)
    with RunStore("sqlite://") as store:
        store.add(RunRecord("g", "gait", {}, {}, arrays={"K": cube}))
        written = store.export("g", tmp_path)
    frame = pd.read_csv(tmp_path / "K.csv")
    assert list(frame.columns)[:5] == ["K_0_0", "K_0_1", "K_0_2", "K_0_3", "K_1_0"]
    np.testing.assert_array_equal(frame.to_numpy().reshape(2, 3, 4), cube)
    layout = json.loads((tmp_path / "metadata.json").read_text())["arrays"]["K"]
    assert layout["shape"] == [2, 3, 4] and tmp_path / "K.csv" in written


def test_unknown_format(store, tmp_path):
    with pytest.raises(ExportError, match=r"format: expected one of \['csv', 'npz'\], found 'xls'"):
        store.export("0123", tmp_path, format="xls")
    assert list(tmp_path.iterdir()) == []
    assert RunStore.export_formats() == ("csv", "npz")


def test_directory_that_is_a_file(store, tmp_path):
    target = tmp_path / "taken"
    target.write_text("x")
    with pytest.raises(ExportError, match="directory: expected a directory, found a file"):
        store.export("0123", target)


def test_export_refuses_to_replace_files_unless_asked(store, tmp_path):
    first = store.export("0123", tmp_path, format="npz")
    (tmp_path / first[0].name).write_bytes(b"mine")
    with pytest.raises(ExportError, match=r"already holds \[.*\.json.*\.npz"):
        store.export("0123", tmp_path, format="npz")
    assert first[0].read_bytes() == b"mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in first)
    assert store.export("0123", tmp_path, format="npz", overwrite=True) == first
    assert first[0].read_bytes() != b"mine"


def test_array_names_from_a_crafted_database_are_checked_on_export(tmp_path):
    db = tmp_path / "runs.db"
    with RunStore(f"sqlite:///{db}") as store:
        store.add(RunRecord("0123abcd", "pendulum", {}, {}, arrays={"times": np.arange(3.0)}))
    with sqlite3.connect(db) as connection:
        connection.execute("UPDATE colloc_arrays SET name = '../../escaped'")
    target = tmp_path / "deep" / "er"
    with RunStore(f"sqlite:///{db}") as store, pytest.raises(ExportError, match="escaped"):
        store.export("0123abcd", target)
    assert not (tmp_path / "escaped.csv").exists() and not target.exists()
