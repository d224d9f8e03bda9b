"""RunStore: round trips, atomic writes, id lookup and error paths."""

from __future__ import annotations

import os
import sqlite3
from datetime import UTC, datetime, timedelta, timezone

import numpy as np
import pandas as pd
import pytest
from sqlalchemy import create_engine, false, text
from sqlalchemy import inspect as sqlalchemy_inspect

import colloc.store.queries as queries_module
import colloc.store.runs as runs_module
from colloc.store import (
    DuplicateRunError,
    ParameterRow,
    RecordError,
    RunNotFoundError,
    RunRecord,
    RunStore,
    StoreURLError,
    StoreWriteError,
)
from colloc.store.errors import ForeignDatabaseError, StoreDamagedError


def make_record(run_id: str = "run-a", seed: int = 0, **changes) -> RunRecord:
    rng = np.random.default_rng(seed)
    fields = {
        "run_id": run_id,
        "kind": "pendulum",
        "settings": {"num_links": 1, "scheme": "midpoint", "grid": {"h": 0.01, "N": 6000}},
        "versions": {"python": "3.11.7", "numpy": "2.4.6"},
        "statistics": {"iterations": 4, "success": True, "objective": 3.49e-3},
        "ipopt_log": "EXIT: Optimal Solution Found.\n",
        "parameters": [
            ParameterRow("k_00", -4.71764346, -4.70001, 0.0123),
            ParameterRow("k_01", 19.67083668, 19.9, None),
            ParameterRow("m_0", None, 1.5, 0.2),
        ],
        "arrays": {
            "times": np.linspace(0.0, 1.0, 11),
            "measured": rng.normal(size=(11, 2)),
            "force": np.asfortranarray(rng.normal(size=(11, 3))).astype(np.float32),
            "counts": np.arange(7, dtype=np.int16),
            "mask": rng.normal(size=4) > 0,
            "scalar": np.array(2.5),
            "big_endian": np.arange(5, dtype=">f8") / 3,
        },
        "created": datetime(2014, 8, 15, 9, 44, 0, 123456, tzinfo=timezone(timedelta(hours=-7))),
    }
    fields.update(changes)
    return RunRecord(**fields)


def assert_same_record(actual: RunRecord, expected: RunRecord) -> None:
    assert actual.run_id == expected.run_id
    assert actual.kind == expected.kind
    assert actual.settings == expected.settings
    assert actual.versions == expected.versions
    assert actual.statistics == expected.statistics
    assert actual.ipopt_log == expected.ipopt_log
    assert actual.parameters == expected.parameters
    assert list(actual.arrays) == list(expected.arrays)
    for name, array in expected.arrays.items():
        assert actual.arrays[name].dtype == array.dtype, name
        assert actual.arrays[name].shape == array.shape, name
        assert np.array_equal(actual.arrays[name], array), name
    assert actual.created == expected.created


@pytest.fixture
def db_path(tmp_path):
    return tmp_path / "runs.db"


@pytest.fixture(params=["sqlite", "postgresql"])
def store(request, db_path):
    """The same tests against an SQLite file and a real PostgreSQL server."""
    url = (
        f"sqlite:///{db_path}"
        if request.param == "sqlite"
        else request.getfixturevalue("postgres_url")
    )
    with RunStore(url) as opened:
        yield opened


def row_counts(store, run_id: str) -> tuple[int, int, int]:
    """Rows of a run in each table, counted by a separate connection."""
    engine = create_engine(store.url)
    try:
        with engine.connect() as connection:
            return tuple(
                connection.execute(
                    text(f"SELECT COUNT(*) FROM {table} WHERE run_id = :r"), {"r": run_id}
                ).scalar_one()
                for table in ("colloc_runs", "colloc_parameters", "colloc_arrays")
            )
    finally:
        engine.dispose()


def test_round_trip_is_exact(store):
    record = make_record()
    store.add(record)
    loaded = store.get("run-a")
    assert_same_record(loaded, record)
    # The same instant, expressed in UTC: 09:44 at UTC-7 is 16:44 UTC.
    assert loaded.created.tzinfo is UTC
    assert loaded.created.hour == 16


def test_round_trip_survives_reopening_the_file(db_path):
    record = make_record()
    with RunStore(f"sqlite:///{db_path}") as first:
        first.add(record)
    with RunStore(f"sqlite:///{db_path}") as second:
        assert_same_record(second.get("run-a"), record)


def test_missing_created_is_set_to_now(store):
    before = datetime.now(UTC)
    store.add(make_record(created=None))
    after = datetime.now(UTC)
    assert before <= store.get("run-a").created <= after


def test_nan_parameter_values_read_back_as_missing(store):
    store.add(make_record(parameters=[ParameterRow("k", float("nan"), 1.0, np.nan)]))
    assert store.get("run-a").parameters == [ParameterRow("k", None, 1.0, None)]
    frame = store.get("run-a").parameters_frame()
    assert np.isnan(frame.loc[0, "known"]) and frame.loc[0, "identified"] == 1.0


def test_failure_while_writing_arrays_leaves_no_trace(store, monkeypatch):
    earlier = make_record("run-a", seed=1)
    store.add(earlier)
    calls = []
    original = queries_module.encode_array

    def failing_encode(array):
        calls.append(array)
        if len(calls) == 3:
            raise RuntimeError("disk on fire")
        return original(array)

    monkeypatch.setattr(queries_module, "encode_array", failing_encode)
    with pytest.raises(RuntimeError, match="disk on fire"):
        store.add(make_record("run-b", seed=2))
    assert len(calls) == 3  # the failure really happened part-way through the arrays
    assert row_counts(store, "run-b") == (0, 0, 0)
    assert row_counts(store, "run-a") == (1, 3, 7)
    assert list(store.list()["run_id"]) == ["run-a"]
    assert_same_record(store.get("run-a"), earlier)


def test_failed_replace_keeps_the_old_run(store, monkeypatch):
    old = make_record("run-a", seed=1)
    store.add(old)
    new = make_record("run-a", seed=2, kind="gait")

    def failing_encode(array):
        raise RuntimeError("no space left")

    with monkeypatch.context() as patch:
        patch.setattr(queries_module, "encode_array", failing_encode)
        with pytest.raises(RuntimeError, match="no space left"):
            store.add(new, replace=True)
    assert_same_record(store.get("run-a"), old)
    store.add(new, replace=True)
    assert_same_record(store.get("run-a"), new)
    assert row_counts(store, "run-a") == (1, 3, 7)


def test_duplicate_id_is_refused(store):
    store.add(make_record())
    with pytest.raises(DuplicateRunError, match="'run-a' is already stored; pass replace=True"):
        store.add(make_record(seed=5))
    assert_same_record(store.get("run-a"), make_record())


def test_prefix_lookup(store):
    for run_id in ("abc1", "abc2", "abd", "a_x", "xyz", "xyzw"):
        store.add(make_record(run_id))
    assert store.get("abd").run_id == "abd"
    assert store.get("abc1").run_id == "abc1"
    assert store.resolve("ab" + "d") == "abd"
    # "_" and "%" are SQL wildcards; a prefix must match them literally.
    assert store.get("a_").run_id == "a_x"
    # An exact id wins over being a prefix of a longer id.
    assert store.get("xyz").run_id == "xyz"
    with pytest.raises(RunNotFoundError, match="prefix 'ab' is ambiguous, it matches abc1, abc2"):
        store.get("ab")
    with pytest.raises(RunNotFoundError, match="no stored run has an id starting with 'q'"):
        store.get("q")
    with pytest.raises(RunNotFoundError, match="expected a non-empty id or id prefix"):
        store.get("")


def test_delete(store):
    store.add(make_record("abc"))
    store.add(make_record("xyz"))
    assert store.delete("ab") == "abc"
    assert row_counts(store, "abc") == (0, 0, 0)
    assert list(store.list()["run_id"]) == ["xyz"]
    assert len(store) == 1
    with pytest.raises(RunNotFoundError, match="no stored run"):
        store.delete("abc")


def test_list_summarises_settings_and_metrics(store):
    first = make_record("one", created=datetime(2020, 1, 1, tzinfo=UTC))
    second = make_record(
        "two",
        created=datetime(2021, 1, 1, tzinfo=UTC),
        settings={"num_links": 4, "grid": {"h": 0.005}},
        statistics={"iterations": 197},
        parameters=[ParameterRow("k", 2.0, 2.5), ParameterRow("j", -4.0, -3.0)],
    )
    store.add(second)
    store.add(first)
    table = store.list(settings=("num_links", "scheme", "grid.h"), statistics=("iterations",))
    assert list(table.columns) == [
        "run_id",
        "created",
        "kind",
        "num_links",
        "scheme",
        "grid.h",
        "iterations",
        "num_parameters",
        "max_rel_error",
    ]
    assert list(table["run_id"]) == ["one", "two"]  # oldest first
    assert list(table["num_links"]) == [1, 4]
    assert table.loc[0, "scheme"] == "midpoint" and pd.isna(table.loc[1, "scheme"])
    assert list(table["grid.h"]) == [0.01, 0.005]
    assert list(table["num_parameters"]) == [3, 2]
    # By hand: run one, |-4.70001 + 4.71764346| / 4.71764346 and |19.9 - 19.67...| / 19.67...
    expected_one = max(
        abs(-4.70001 + 4.71764346) / 4.71764346, abs(19.9 - 19.67083668) / 19.67083668
    )
    assert table.loc[0, "max_rel_error"] == pytest.approx(expected_one, rel=1e-12)
    assert table.loc[1, "max_rel_error"] == pytest.approx(0.25, rel=1e-12)
    assert list(store.list(kind="gait")["run_id"]) == []


def test_invalid_record_lists_every_problem(store):
    record = make_record(
        run_id="",
        settings={"bad": object(), 3: "int key"},
        parameters=[ParameterRow("k"), ParameterRow("k")],
        arrays={"metadata": np.zeros(2), "../escape": np.zeros(1), "obj": np.array([None])},
    )
    with pytest.raises(RecordError, match="7 problem") as caught:
        store.add(record)
    message = str(caught.value)
    for fragment in (
        "run_id: expected a non-empty str",
        "settings['bad']: expected JSON data",
        "settings: keys must be strings, found 3",
        "parameters[1].name: 'k' appears more than once",
        "'metadata' is reserved",
        "name '../escape' must match",
        "arrays['obj']: dtype object holds Python objects",
    ):
        assert fragment in message
    assert len(store) == 0


def test_add_refuses_a_non_record(store):
    with pytest.raises(TypeError, match="record: expected a RunRecord, found dict"):
        store.add({"run_id": "x"})


@pytest.mark.parametrize(
    ("url", "message"),
    [
        ("not a url", "url: expected a SQLAlchemy database URL .* found 'not a url'"),
        ("nosuchdb://host/x", "url: expected a SQLAlchemy database URL .* found 'nosuchdb"),
        ("sqlite:////no/such/directory/runs.db", "url: could not open or create the database"),
    ],
)
def test_bad_url(url, message):
    with pytest.raises(StoreURLError, match=message):
        RunStore(url)


def test_bad_url_type():
    with pytest.raises(StoreURLError, match="url: expected a str, found int"):
        RunStore(5)


def test_newer_schema_is_refused(db_path):
    RunStore(f"sqlite:///{db_path}").close()
    with sqlite3.connect(db_path) as connection:
        connection.execute("UPDATE colloc_schema SET version = 99")
    with pytest.raises(StoreURLError, match=r"schema version \[99\], this colloc reads version 1"):
        RunStore(f"sqlite:///{db_path}")


def test_concurrent_insert_of_the_same_id_is_a_duplicate(store, monkeypatch):
    """Another process stores the id between the existence check and the insert."""
    store.add(make_record())
    real_select = runs_module.select

    def select_missing_everything(*columns):
        return real_select(*columns).where(false())

    monkeypatch.setattr(runs_module, "select", select_missing_everything)
    with pytest.raises(DuplicateRunError, match="'run-a' is already stored"):
        store.add(make_record(seed=9))
    monkeypatch.undo()
    assert_same_record(store.get("run-a"), make_record())


def test_summary_describes_the_run(store):
    store.add(make_record())
    text = store.get("run-a").summary()
    assert text.splitlines()[0] == "run run-a"
    assert "created:    2014-08-15T16:44:00.123456+00:00" in text
    assert '"scheme": "midpoint"' in text
    rows = {line.split()[0]: line.split()[1:] for line in text.splitlines() if "k_0" in line}
    assert [float(v) for v in rows["k_00"]] == pytest.approx([-4.71764346, -4.70001, 0.0123], 1e-6)
    assert rows["k_01"][2] == "NaN"
    assert "  measured: shape (11, 2), dtype float64" in text
    assert text.endswith("ipopt log:  1 lines")


def _hold_write_lock(path, mode: str = "IMMEDIATE") -> sqlite3.Connection:
    """Another process's writer: an open write transaction on the file (IMMEDIATE lets
    readers in, EXCLUSIVE does not)."""
    holder = sqlite3.connect(path, isolation_level=None)
    holder.execute(f"BEGIN {mode}")
    return holder


def test_a_real_lock_fails_the_check_and_the_write_after_the_busy_timeout_storing_nothing(
    tmp_path,
):
    path = tmp_path / "runs.db"
    url = f"sqlite:///{path}"
    RunStore(url).close()
    holder = _hold_write_lock(path)
    try:
        store = RunStore(url, busy_timeout=0.2)
        with pytest.raises(StoreURLError, match="cannot be written.*locked"):
            store.check_writable()
        with pytest.raises(StoreWriteError, match=r"refused run run-a.*locked.*nothing of it"):
            store.add(make_record())
    finally:
        holder.rollback()
        holder.close()
    assert store.list().empty  # the refused write left no part of the run
    store.add(make_record())  # and once the lock is gone the same run goes in whole
    assert store.get("run-a").arrays.keys() == make_record().arrays.keys()
    store.close()


def test_a_database_locked_even_for_reading_cannot_be_opened_and_says_so(tmp_path):
    path = tmp_path / "runs.db"
    RunStore(f"sqlite:///{path}").close()
    holder = _hold_write_lock(path, "EXCLUSIVE")
    try:
        with pytest.raises(StoreURLError, match="could not open.*locked"):
            RunStore(f"sqlite:///{path}", busy_timeout=0.2)
    finally:
        holder.rollback()
        holder.close()


@pytest.mark.parametrize("timeout", [-1.0, float("nan"), float("inf"), "5", True])
def test_a_bad_busy_timeout_is_refused(timeout):
    with pytest.raises(StoreURLError, match="busy_timeout: expected a finite number"):
        RunStore("sqlite://", busy_timeout=timeout)


def _write_runs(url: str, writer: int, count: int) -> None:
    with RunStore(url) as opened:
        for i in range(count):
            opened.add(make_record(f"w{writer}-{i:03d}", seed=writer * 1000 + i))


def test_concurrent_writers_in_several_processes_lose_and_corrupt_nothing(store):
    """Four processes store 15 runs each into one database at the same time."""
    import multiprocessing

    context = multiprocessing.get_context("spawn")
    writers = [context.Process(target=_write_runs, args=(store.url, w, 15)) for w in range(4)]
    for process in writers:
        process.start()
    for process in writers:
        process.join(timeout=120)
        assert process.exitcode == 0
    stored = sorted(store.list()["run_id"])
    assert stored == sorted(f"w{w}-{i:03d}" for w in range(4) for i in range(15))
    for run_id in stored[::7]:  # each read back whole and exact
        writer, i = run_id[1:].split("-")
        assert_same_record(store.get(run_id), make_record(run_id, seed=int(writer) * 1000 + int(i)))
        assert row_counts(store, run_id) == (1, 3, 7)


def test_the_batch_log_records_entries_and_finds_done_work(store):
    entries = [
        {"kind": "pendulum", "entry_key": f"key-{i}", "settings": {"seed": i}} for i in range(3)
    ]
    store.add(make_record("run-0"))
    log = store.batches
    log.start("batch-1", {"file": "b.yaml"}, entries)
    log.record("batch-1", 0, "done", run_id="run-0", seconds=1.5)
    log.record("batch-1", 1, "failed", error="TrialError: no heel strikes")
    assert log.done(["key-0", "key-1", "key-2"]) == {"key-0": {"run_id": "run-0", "output": None}}
    log.finish("batch-1")
    got = log.get("batch-")
    assert got["status"] == "finished" and got["spec"] == {"file": "b.yaml"}
    assert list(got["entries"]["status"]) == ["done", "failed", "cancelled"]
    assert got["entries"]["settings"][2] == {"seed": 2}
    assert list(store.list(batch="batch-1")["run_id"]) == ["run-0"]
    listed = log.list()
    assert (listed.loc[0, "done"], listed.loc[0, "failed"], listed.loc[0, "cancelled"]) == (1, 1, 1)
    store.delete("run-0")  # a deleted run is no longer done work
    assert log.done(["key-0"]) == {}
    log.start("batch-1", {"file": "b.yaml"}, entries)  # taken up again: unfinished -> pending
    assert list(log.get("batch-1")["entries"]["status"]) == ["done", "pending", "pending"]
    with pytest.raises(RecordError, match="recorded with other entries"):
        log.start("batch-1", {}, entries[:2])
    with pytest.raises(RunNotFoundError, match="no stored batch has an id starting with 'x'"):
        log.get("x")


def test_a_run_read_without_its_arrays_has_the_rest_exactly(store):
    record = make_record()
    store.add(record)
    light = store.get("run-a", arrays=False)
    assert light.arrays == {}
    assert light.parameters == record.parameters and light.settings == record.settings
    assert store.get("run-a").arrays.keys() == record.arrays.keys()  # still there


@pytest.mark.parametrize("backend", ["sqlite", "postgresql"])
def test_a_database_of_other_tables_is_refused_unchanged_unless_allowed(request, db_path, backend):
    url = f"sqlite:///{db_path}" if backend == "sqlite" else request.getfixturevalue("postgres_url")
    engine = create_engine(url)
    with engine.begin() as connection:
        connection.execute(text("CREATE TABLE patients (id INTEGER, name TEXT)"))

    def tables():
        engine.dispose()
        with engine.connect() as connection:
            names = sqlalchemy_inspect(connection).get_table_names()
        return sorted(names)

    with pytest.raises(ForeignDatabaseError, match=r"holds other tables \(patients\)"):
        RunStore(url)
    assert tables() == ["patients"]  # nothing was added
    with RunStore(url, allow_other_tables=True) as allowed:
        allowed.add(make_record())
    assert "colloc_runs" in tables() and "patients" in tables()
    with RunStore(url) as reopened:  # colloc's runs are there now: no need to say it again
        assert reopened.get("run-a").run_id == "run-a"
    engine.dispose()


def _damage(path, page: int, size: int = 4096) -> None:
    with open(path, "r+b") as fh:
        fh.seek(page * size)
        fh.write(b"\xab" * size)


@pytest.mark.parametrize("page", [0, 1, 2])
def test_a_damaged_file_is_named_with_what_to_do(db_path, page):
    with RunStore(f"sqlite:///{db_path}") as store:
        for i in range(3):
            store.add(make_record(f"run-{i}", seed=i))
    before = db_path.read_bytes()
    _damage(db_path, page)
    damaged = db_path.read_bytes()
    assert damaged != before
    with pytest.raises(
        StoreDamagedError, match=rf"database file '{db_path}' is damaged.*\.recover"
    ):
        with RunStore(f"sqlite:///{db_path}", create=False) as store:
            store.list()
            for i in range(3):
                store.get(f"run-{i}")
    assert db_path.read_bytes() == damaged  # nothing was written


def _owned_by(store, batch_id, owner):
    """Record ``owner`` as the process running ``batch_id`` (as another colloc would)."""
    from colloc.store import schema

    engine = create_engine(store.url)
    with engine.begin() as connection:
        connection.execute(
            schema.batch_owners.update()
            .where(schema.batch_owners.c.batch_id == batch_id)
            .values(pid=owner.pid, process_start=owner.process_start, host=owner.host)
        )
    engine.dispose()


def test_a_stored_run_marks_its_entry_in_the_same_transaction(store, monkeypatch):
    entries = [{"kind": "pendulum", "entry_key": "k", "settings": {}}]
    store.batches.start("b", {}, entries)
    store.add(make_record("run-0"), batch_entry=("b", 0, "done"))
    assert list(store.batches.get("b")["entries"]["status"]) == ["done"]
    store.batches.finish("b", "cancelled")  # a Ctrl-C after the run was stored
    assert list(store.batches.get("b")["entries"]["status"]) == ["done"]
    assert store.batches.done(["k"]) == {"k": {"run_id": "run-0", "output": None}}

    store.batches.start("c", {}, [{"kind": "pendulum", "entry_key": "k2", "settings": {}}])
    monkeypatch.setattr(
        runs_module, "set_entry", lambda *a, **k: (_ for _ in ()).throw(OSError("disk"))
    )
    with pytest.raises(OSError, match="disk"):
        store.add(make_record("run-1", seed=1), batch_entry=("c", 0, "done"))
    assert "run-1" not in set(store.list()["run_id"])  # neither the run nor the mark
    assert list(store.batches.get("c")["entries"]["status"]) == ["pending"]


def test_a_batch_whose_process_is_gone_is_marked_dead_and_a_live_one_is_not_run_twice(store):
    import subprocess

    from colloc.store.owner import ProcessOwner

    entries = [{"kind": "pendulum", "entry_key": f"k{i}", "settings": {}} for i in range(2)]
    gone = subprocess.Popen(["true"])
    gone.wait()
    store.batches.start("dead-one", {}, entries)
    store.batches.record("dead-one", 0, "done")
    me = ProcessOwner.this_process()
    _owned_by(store, "dead-one", ProcessOwner(me.host, gone.pid, None))
    store.batches.start("other", {}, [])  # any batch started marks the dead
    got = store.batches.get("dead-one")
    assert got["status"] == "dead"
    assert list(got["entries"]["status"]) == ["done", "cancelled"]

    with subprocess.Popen(["sleep", "30"]) as live:
        try:
            store.batches.start("live-one", {}, entries)
            _owned_by(store, "live-one", ProcessOwner(me.host, live.pid, None))
            assert store.batches.mark_dead() == []
            with pytest.raises(RecordError, match=rf"running now in process {live.pid}"):
                store.batches.start("live-one", {}, entries)
            _owned_by(store, "live-one", ProcessOwner("elsewhere.example", live.pid, None))
            assert store.batches.mark_dead() == []  # another host: nothing here can tell
        finally:
            live.kill()
    reused = ProcessOwner(me.host, os.getpid(), "1")  # this pid, but another start time
    assert reused.alive() is False and ProcessOwner.this_process().alive() is True
