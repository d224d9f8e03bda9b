"""Batches on a local Dask cluster: stored runs, a failed entry, re-runs, a killed worker."""

from __future__ import annotations

import contextlib
import os
import re
import signal
import sqlite3
import textwrap
import time
from pathlib import Path

import pytest

from colloc.batch import Task, run_batch, task_key
from colloc.cli import main
from colloc.identify.pendulum.settings import PendulumSettings
from colloc.store import RunStore

FIXTURE = Path(__file__).resolve().parents[1] / "data" / "fixtures" / "gait_trial_tsv"


def write_spec(tmp_path: Path, db: str, bad_trial: Path) -> Path:
    spec = tmp_path / "batch.yaml"
    spec.write_text(
        textwrap.dedent(
            f"""\
            db: {db}
            workers: 2
            runs:
              - kind: pendulum
                numlinks: 1
                duration: 10
                sensornoise: true
                initialconditions: close
                seed: {{range: [0, 3]}}
              - kind: gait-identify
                trial: {bad_trial}
                no-plots: true
            """
        )
    )
    return spec


def unreadable_trial(tmp_path: Path) -> Path:
    folder = tmp_path / "broken-trial"
    folder.mkdir()
    for name in ("events.csv", "metadata.yaml"):
        (folder / name).write_bytes((FIXTURE / name).read_bytes())
    (folder / "trial.tsv").write_text("time\tnonsense\n0\tx\n")
    return folder


def test_a_batch_stores_its_runs_reports_the_bad_one_and_skips_them_when_run_again(
    tmp_path, capsys
):
    db = f"sqlite:///{tmp_path / 'runs.db'}"
    spec = write_spec(tmp_path, db, unreadable_trial(tmp_path))
    assert main(["batch", str(spec)]) == 1  # finished, with one failure
    out = capsys.readouterr().out
    assert "3 done, 1 failed, 0 skipped" in out
    assert "failed: entry 3 (gait-identify): TrialError" in out and "broken-trial" in out
    with RunStore(db) as store:
        (batch,) = store.batches.list().itertuples()
        assert (batch.done, batch.failed, batch.status) == (3, 1, "finished")
        entries = store.batches.get(batch.batch_id)["entries"]
        first_ids = list(entries["run_id"][:3])
        assert sorted(first_ids) == sorted(store.list()["run_id"])  # all three stored
        seeds = [store.get(r).settings["seed"] for r in first_ids]
        assert seeds == [0, 1, 2]

    assert main(["batch", "run", str(spec)]) == 1  # the bad one fails again, nothing else runs
    out = capsys.readouterr().out
    assert "3 entries already done (runs stored): skipped" in out
    assert "0 done, 1 failed, 3 skipped" in out
    with RunStore(db) as store:
        again = store.batches.get(batch.batch_id)["entries"]
        assert list(again["run_id"][:3]) == first_ids and len(store) == 3

    assert main(["runs", "list", "--db", db, "--batch", batch.batch_id[:8]]) == 0
    listed = capsys.readouterr().out
    assert all(run_id in listed for run_id in first_ids)
    report = tmp_path / "report"
    assert main(["batch", "report", batch.batch_id[:8], "--db", db, "--out", str(report)]) == 0
    names = sorted(p.name for p in report.iterdir())
    assert names == [
        "entries.csv",
        "entries.md",
        "pendulum-gains.csv",
        "pendulum-gains.md",
        "pendulum-spread-vs-se.png",
        "pendulum-spread-vs-se.svg",
    ]
    gains = (report / "pendulum-gains.md").read_text()
    assert gains.count("| 0 | k_0_") == 4 and "spread_over_se" in gains


def test_killing_a_worker_mid_batch_loses_no_finished_run_and_leaves_no_half_one(tmp_path):
    db = f"sqlite:///{tmp_path / 'runs.db'}"
    tasks = []
    for i in range(6):
        settings = PendulumSettings(num_links=1, duration=10.0, sensor_noise=True, seed=i)
        tasks.append(
            Task(i, "pendulum", settings, key=task_key("pendulum", settings.to_dict(), {}))
        )
    killed: list[int] = []

    def kill_one_worker(result):
        if not killed:  # the worker that ran the first run, busy with its next one by now
            assert result.pid is not None and result.pid != os.getpid()
            os.kill(result.pid, signal.SIGKILL)
            killed.append(result.pid)

    outcome = run_batch(tasks, db, workers=2, on_result=kill_one_worker)
    assert killed
    with RunStore(db) as store:
        entries = store.batches.get(outcome.batch_id)["entries"]
        done = entries[entries["status"] == "done"]
        assert len(done) >= 1
        for run_id in done["run_id"]:  # every finished run is whole
            record = store.get(run_id)
            assert record.arrays["times"].shape == (1001,) and len(record.parameters) == 4
        assert sorted(store.list()["run_id"]) == sorted(done["run_id"])  # nothing half-stored
    path = str(tmp_path / "runs.db")
    with sqlite3.connect(path) as connection:
        assert connection.execute("PRAGMA integrity_check").fetchone() == ("ok",)

    again = run_batch(tasks, db, workers=1)
    assert again.batch_id == outcome.batch_id
    assert again.count("skipped") == len(done)
    assert again.count("done") == 6 - len(done)
    with RunStore(db) as store:
        assert len(store) == 6
        entries = store.batches.get(outcome.batch_id)["entries"]
        assert set(entries["status"]) <= {"done", "skipped"}
        for _, row in done.iterrows():  # the same run ids as before the kill
            assert entries.loc[row["position"], "run_id"] == row["run_id"]


def test_the_repeat_flag_runs_seeds_as_a_batch_and_reports_spread_against_se(tmp_path, capsys):
    db = f"sqlite:///{tmp_path / 'runs.db'}"
    argv = ["pendulum", "-d", "10", "-r", "-i", "close", "--seed", "5", "--repeat", "3"]
    started = time.perf_counter()
    code = main([*argv, "--db", db, "--out", str(tmp_path / "out"), "--workers", "2"])
    assert code == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    assert "3 done, 0 failed, 0 skipped" in out and "spread_over_se" in out
    built = re.search(r"build cache: (\d) of 3 runs found their problem built", out)
    assert built and int(built.group(1)) >= 1  # at most one build per worker
    with RunStore(db) as store:
        assert sorted(store.get(r).settings["seed"] for r in store.list()["run_id"]) == [5, 6, 7]
    assert time.perf_counter() - started < 120


@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["-p"], "-p/--plot: not with --repeat"),
        (["--json", "s.json"], "--json: not with --repeat"),
        (["--no-store"], "--no-store: --repeat stores every run"),
    ],
)
def test_the_repeat_flag_refuses_what_a_batch_cannot_do(tmp_path, capsys, flags, message):
    code = main(["pendulum", "--repeat", "2", "--db", f"sqlite:///{tmp_path / 'r.db'}", *flags])
    assert code == 2 and message in capsys.readouterr().err


# two batches on two Dask clusters (27 s): run by benchmarks/slow_tests.py; in CI PostgreSQL
# is exercised by the store's tests (round trips, concurrent writers)
@pytest.mark.slow
def test_the_same_batch_on_sqlite_and_postgresql_gives_the_same_runs(tmp_path, postgres_url):
    tasks = []
    for i in range(2):
        settings = PendulumSettings(num_links=1, duration=10.0, sensor_noise=True, seed=i)
        tasks.append(
            Task(i, "pendulum", settings, key=task_key("pendulum", settings.to_dict(), {}))
        )
    sqlite_url = f"sqlite:///{tmp_path / 'runs.db'}"
    on_sqlite = run_batch(tasks, sqlite_url, workers=2)
    on_postgres = run_batch(tasks, postgres_url, workers=2)
    assert on_sqlite.batch_id == on_postgres.batch_id
    ids = {p: r.run_id for p, r in on_sqlite.results.items()}
    assert ids == {p: r.run_id for p, r in on_postgres.results.items()}
    with RunStore(sqlite_url) as a, RunStore(postgres_url) as b:
        for run_id in ids.values():
            ra, rb = a.get(run_id), b.get(run_id)
            assert ra.parameters == rb.parameters  # the same floats, to the bit
            assert ra.statistics["iterations"] == rb.statistics["iterations"]
            assert (
                all((ra.arrays[k] == rb.arrays[k]).all() for k in ra.arrays)
                and ra.arrays.keys() == rb.arrays.keys()
            )


def _batch_until(spec: Path, db_file: Path, count_sql: str, at_least: int):
    """``colloc batch SPEC`` in its own process group, returned once ``count_sql`` on its
    database counts ``at_least`` (or after two minutes)."""
    import subprocess
    import sys

    colloc = Path(sys.executable).with_name("colloc")
    process = subprocess.Popen(
        [str(colloc), "batch", str(spec)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=spec.parent,
        start_new_session=True,
        # a shell's background job starts with SIGINT ignored, and a child inherits that:
        # the batch gets Ctrl-C's default, as in a terminal, wherever the tests run
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    deadline = time.monotonic() + 120
    count = 0
    while time.monotonic() < deadline and count < at_least:
        time.sleep(0.5)
        if db_file.exists():
            with contextlib.suppress(sqlite3.Error), sqlite3.connect(db_file) as connection:
                count = connection.execute(count_sql).fetchone()[0]
    return process


def test_ctrl_c_cancels_the_batch_cleanly_and_keeps_the_finished_runs(tmp_path):

    db_file = tmp_path / "runs.db"
    spec = tmp_path / "batch.yaml"
    spec.write_text(
        f"db: sqlite:///{db_file}\nworkers: 1\nruns:\n  - kind: pendulum\n    duration: 10\n"
        "    sensornoise: true\n    seed: {range: [0, 40]}\n"
    )
    process = _batch_until(
        spec, db_file, "SELECT COUNT(*) FROM colloc_batch_entries WHERE status = 'done'", 2
    )
    assert process.poll() is None, "the batch ended before it could be interrupted"
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130 and "interrupted" in err
    with RunStore(f"sqlite:///{db_file}") as store:
        (batch,) = store.batches.list().itertuples()
        assert batch.status == "cancelled" and batch.pending == 0
        assert 2 <= batch.done < 40 and batch.cancelled == 40 - batch.done - batch.failed
        entries = store.batches.get(batch.batch_id)["entries"]
        done_ids = set(entries.loc[entries["status"] == "done", "run_id"])
        stored = set(store.list()["run_id"])
        assert done_ids <= stored  # every finished run is stored whole
        assert stored <= done_ids  # and every stored run is done: a re-run skips it
        assert len(store.batches.done(list(entries["entry_key"]))) == len(stored)
        for run_id in stored:
            assert store.get(run_id).arrays["times"].shape == (1001,)


@pytest.mark.parametrize("value", ["0", "-1"])
def test_a_cluster_of_no_workers_is_refused_before_any_work(value, capsys):
    """``--workers -1`` waited for ever at 0/1 (issue 32 item 11)."""
    from colloc.cli import main

    with pytest.raises(SystemExit) as stop:
        main(["pendulum", "-n", "1", "--repeat", "2", "--workers", value, "--no-store"])
    assert stop.value.code == 2
    assert f"argument --workers: expected an integer >= 1, found '{value}'" in (
        capsys.readouterr().err
    )


def test_a_batch_into_a_database_of_other_tables_is_refused_before_any_work(tmp_path, capsys):
    db_file = tmp_path / "clinic.db"
    with sqlite3.connect(db_file) as connection:
        connection.execute("CREATE TABLE patients (id INTEGER)")
    spec = tmp_path / "batch.yaml"
    spec.write_text(
        f"db: sqlite:///{db_file}\nworkers: 1\nruns:\n  - kind: pendulum\n    duration: 5\n"
    )
    assert main(["batch", str(spec)]) == 2
    err = capsys.readouterr().err
    assert "holds other tables (patients)" in err and "--db-allow-other-tables" in err
    with sqlite3.connect(db_file) as connection:
        names = [r[0] for r in connection.execute("SELECT name FROM sqlite_master")]
    assert names == ["patients"]
    assert main(["batch", str(spec), "--db-allow-other-tables"]) == 0, capsys.readouterr().err
    with RunStore(f"sqlite:///{db_file}") as store:
        assert len(store) == 1


def test_a_killed_batch_is_marked_dead_by_the_next_and_its_stored_runs_are_done(tmp_path):

    db_file = tmp_path / "runs.db"
    spec = tmp_path / "batch.yaml"
    spec.write_text(
        f"db: sqlite:///{db_file}\nworkers: 1\nruns:\n  - kind: pendulum\n    duration: 5\n"
        "    seed: {range: [0, 40]}\n"
    )
    process = _batch_until(spec, db_file, "SELECT COUNT(*) FROM colloc_runs", 1)
    os.killpg(process.pid, signal.SIGKILL)  # the batch and its Dask workers, as a kill -9 would
    process.wait(timeout=30)
    with RunStore(f"sqlite:///{db_file}") as store:
        (batch,) = store.batches.list().itertuples()
        assert batch.status == "running"  # nothing could record its end
        assert store.batches.mark_dead() == [batch.batch_id]
        (batch,) = store.batches.list().itertuples()
        assert batch.status == "dead" and batch.pending == 0
        entries = store.batches.get(batch.batch_id)["entries"]
        done_ids = set(entries.loc[entries["status"] == "done", "run_id"])
        assert set(store.list()["run_id"]) == done_ids and len(done_ids) >= 1
        assert store.batches.mark_dead() == []  # once
