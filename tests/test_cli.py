"""The ``colloc`` command, called in-process through ``colloc.cli.main``.

References: the seed's gains, the settings asked for on the command line (which fix the
node count, the sample times and the run id), the stored record, and the file formats
(PNG/SVG/GIF read back with Pillow and as XML).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import sqlite3
import time
import xml.etree.ElementTree as ET

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from colloc.cli import main
from colloc.identify import PendulumSettings, run_pendulum
from colloc.identify.pendulum.outputs import pendulum_run_id
from colloc.store import RunStore

SEED_GAINS = np.array([-4.71764346, 19.67083668, -3.69402157, 5.57114809])
GAIN_NAMES = ["k_0_0", "k_0_1", "k_0_2", "k_0_3"]
SMALL = ["pendulum", "-n", "1", "-d", "5", "-s", "20", "-r", "-i", "close"]


@pytest.fixture(autouse=True)
def private_build_cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("COLLOC_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "build-cache"))


@pytest.fixture(scope="module")
def stored(tmp_path_factory):
    """One small run with figures, animation, JSON summary and database."""
    root = tmp_path_factory.mktemp("cli")
    db = f"sqlite:///{root / 'runs.db'}"
    argv = [*SMALL, "-p", "-a", "--db", db, "--out", str(root / "out")]
    argv += ["--json", str(root / "summary.json")]
    out, err = io.StringIO(), io.StringIO()
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("COLLOC_CACHE_DIR", str(root / "build-cache"))
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(argv)
    summary = json.loads((root / "summary.json").read_text())
    return {
        "root": root,
        "db": db,
        "code": code,
        "stdout": out.getvalue(),
        "stderr": err.getvalue(),
        "summary": summary,
    }


def run_cli(argv, capsys):
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


# ----------------------------------------------------------------------------- bad flags


@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["-n", "0"], r"num_links \(-n\): expected an integer >= 1, found 0"),
        (["-d", "-1"], r"duration \(-d\): expected a positive number of seconds, found -1.0"),
        (["-d", "1", "-s", "0.01"], r"gives 1 node\(s\); expected at least 3"),
        (["-s", "0"], r"sample_rate \(-s\): expected a positive rate in Hz, found 0.0"),
        (["-i", "bogus"], r"initial_guess \(-i\): expected one of \[.*'close'.*found 'bogus'"),
        (["--scheme", "bogus"], r"scheme: expected one of \[.*'midpoint'.*found 'bogus'"),
        (["--hessian", "bogus"], r"hessian: expected 'exact' or 'limited-memory'"),
        (["-r", "--noise-std", "-1"], r"noise_std_deg: expected a finite number >= 0, found -1"),
        # iterated past 45 s before: a noise that buries the motion is refused
        (
            ["-r", "--noise-std", "1e6"],
            r"noise_std_deg \(--noise-std\): expected at most 90 degrees",
        ),
        # Found by these tests: inf gave an OverflowError traceback, and a negative seed
        # failed in numpy after the database was created, without naming the flag.
        (["-s", "inf"], r"sample_rate \(-s\): expected a positive"),
        (["-d", "inf"], r"duration \(-d\): expected a positive"),
        (["--seed", "-1"], r"seed: expected an integer >= 0, found -1"),
        (["--process-noise", "-1"], r"process_noise: expected a finite number >= 0, found -1.0"),
        (["--input-noise", "nan"], r"input_noise: expected a finite number >= 0, found nan"),
        (
            ["--uncertainty", "bogus"],
            r"uncertainty: expected one of \['sandwich', 'autoregressive', 'kkt'\]",
        ),
        # issue 13: refused only after simulating, about a window the user cannot set
        (["-d", "0.1"], r"duration \(-d\): 0.1 s at 100 Hz gives 11 samples, fewer than the 15 "),
        # issue 13: a NumPy MemoryError, or no end and no word
        (["-d", "1e9"], r"1e\+11 nodes and 4e\+11 unknowns need an estimated .* GiB, more than"),
        (["-n", "1000"], r"num_links \(-n\) 1000, .* GiB, more than the .* GiB available"),
        (["--amplitude", "1e300"], r"force_amplitude \(--amplitude\): expected at most 1e\+06"),
        # issue 13: silently ignored
        (["--noise-std", "0.5"], r"--noise-std 0.5: has no effect without -r"),
    ],
)
def test_bad_flags_exit_2_before_any_work(tmp_path, capsys, flags, message):
    db = tmp_path / "runs.db"
    argv = ["pendulum", *flags, "--db", f"sqlite:///{db}", "--out", str(tmp_path / "out")]
    argv += ["--json", str(tmp_path / "s.json"), "-p", "-a"]
    code, out, err = run_cli(argv, capsys)
    assert code == 2
    assert err.startswith("colloc pendulum: error: ")
    assert re.search(message, err), err
    assert out == ""  # not even the first progress line
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # no database, figures or JSON


def test_all_bad_flags_are_reported_together(tmp_path, capsys):
    argv = ["pendulum", "-n", "0", "-d", "-1", "-i", "bogus", "--db", f"sqlite:///{tmp_path}/r.db"]
    code, _, err = run_cli(argv, capsys)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 3
    assert all(line.startswith("colloc pendulum: error: ") for line in lines)
    assert not (tmp_path / "r.db").exists()


@pytest.mark.parametrize(
    ("flags", "message"),
    [(["-n", "two"], "expected an integer, found 'two'"), (["-d", "x"], "expected a number")],
)
def test_unparsable_flags_exit_2_with_usage(capsys, flags, message):
    with pytest.raises(SystemExit) as info:
        main(["pendulum", *flags])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "usage: colloc pendulum" in err and message in err


# ----------------------------------------------------------------------------- a real run


def test_small_run_succeeds_and_reports_progress(stored):
    assert stored["code"] == 0
    assert stored["stderr"] == ""
    out = stored["stdout"]
    for step in ("derive", "control design", "simulate", "build", "solve", "store"):
        assert f"] {step}" in out
    assert "N = 101" in out  # 5 s at 20 Hz
    assert "IPOPT: Solve_Succeeded" in out


def test_json_summary_has_the_documented_keys_and_sane_values(stored):
    s = stored["summary"]
    for key in ("run_id", "gains", "max_rel_gain_error", "ipopt", "objective", "times"):
        assert key in s
    assert set(s["ipopt"]) >= {"iterations", "status"}
    assert s["ipopt"]["status"] == "Solve_Succeeded" and s["ipopt"]["iterations"] >= 1
    assert set(s["times"]) >= {"derive", "build", "solve", "total"}
    assert all(v >= 0 for v in s["times"].values())
    assert s["times"]["total"] >= s["times"]["solve"]
    assert list(s["gains"]) == GAIN_NAMES
    known = np.array([s["gains"][k]["known"] for k in GAIN_NAMES])
    identified = np.array([s["gains"][k]["identified"] for k in GAIN_NAMES])
    se = np.array([s["gains"][k]["std_error"] for k in GAIN_NAMES])
    np.testing.assert_allclose(known, SEED_GAINS, rtol=1e-6)
    assert np.all(se > 0) and np.all(np.abs(identified - known) < 4 * se)
    assert s["max_rel_gain_error"] == pytest.approx(np.max(np.abs(identified / known - 1)))
    assert s["settings"]["num_links"] == 1 and s["settings"]["sensor_noise"] is True
    assert s["settings"]["duration"] == 5.0 and s["settings"]["sample_rate"] == 20.0


def test_run_id_is_the_hash_of_the_settings_and_data(stored):
    # The same settings run in-process (no CLI) give the same data and so the same id.
    settings = PendulumSettings(**stored["summary"]["settings"])
    assert pendulum_run_id(run_pendulum(settings, cache=False)) == stored["summary"]["run_id"]


def test_the_run_is_stored(stored):
    s = stored["summary"]
    record = RunStore(stored["db"]).get(s["run_id"])
    assert record.kind == "pendulum"
    assert [p.name for p in record.parameters] == GAIN_NAMES
    for p in record.parameters:
        assert p.known == pytest.approx(s["gains"][p.name]["known"])
        assert p.identified == pytest.approx(s["gains"][p.name]["identified"])
        assert p.std_error == pytest.approx(s["gains"][p.name]["std_error"])
    np.testing.assert_allclose(record.arrays["times"], np.arange(101) / 20.0)
    assert record.arrays["measurements"].shape == (101, 2)
    assert record.settings["num_nodes"] == 101


def test_json_at_a_folder_is_refused_before_work_and_summaries_follow_the_umask(tmp_path, capsys):
    folder = tmp_path / "folder"
    folder.mkdir()
    argv = [*SMALL, "--no-store", "--json", str(folder)]
    code, out, err = run_cli(argv, capsys)
    assert code == 2 and "is a folder; give a file path" in err and out == ""
    assert list(folder.iterdir()) == []
    summary = tmp_path / "new" / "s.json"
    assert run_cli([*SMALL, "--no-store", "--json", str(summary)], capsys)[0] == 0
    umask = os.umask(0)
    os.umask(umask)
    assert summary.stat().st_mode & 0o777 == 0o666 & ~umask
    assert [p.name for p in summary.parent.iterdir()] == ["s.json"]
    # a path that cannot be written was found only after the work, naming a temporary file
    code, out, err = run_cli([*SMALL, "--no-store", "--json", "/proc/colloc.json"], capsys)
    assert code == 2 and "--json '/proc/colloc.json': cannot write in '/proc'" in err
    assert out == ""


def test_runs_list_and_show(stored, capsys):
    run_id = stored["summary"]["run_id"]
    code, out, err = run_cli(["runs", "--db", stored["db"], "list"], capsys)
    assert code == 0 and err == ""
    assert run_id in out and "pendulum" in out
    code, out, err = run_cli(["runs", "--db", stored["db"], "show", run_id[:10]], capsys)
    assert code == 0 and err == ""
    assert out.startswith(f"run {run_id}")
    for name in GAIN_NAMES:
        assert name in out


def test_db_is_accepted_after_the_runs_subcommand_as_the_readme_writes_it(stored, capsys):
    before = run_cli(["runs", "--db", stored["db"], "list"], capsys)
    after = run_cli(["runs", "list", "--db", stored["db"]], capsys)
    assert after == before and after[0] == 0
    code, out, _ = run_cli(["runs", "list", "--db", stored["db"], "--kind", "bogus"], capsys)
    assert code == 0 and "no runs of kind 'bogus' stored (kinds stored: ['pendulum'])" in out


def test_reading_commands_create_nothing(tmp_path, capsys):
    typo = tmp_path / "typo.db"
    code, out, err = run_cli(["runs", "list", "--db", f"sqlite:///{typo}"], capsys)
    assert code == 2 and "there is no database at" in err and str(typo) in err
    assert not typo.exists()
    other = tmp_path / "other.db"
    with sqlite3.connect(other) as connection:
        connection.execute("CREATE TABLE notes (text)")
    for command in (["list"], ["show", "abcdef"], ["delete", "abcdef"]):
        code, out, err = run_cli(["runs", "--db", f"sqlite:///{other}", *command], capsys)
        assert code == 2 and "holds no colloc runs" in err and "found ['notes']" in err
    with sqlite3.connect(other) as connection:
        tables = connection.execute("SELECT name FROM sqlite_master").fetchall()
    assert tables == [("notes",)]


def test_runs_show_of_an_unknown_id_exits_2(stored, capsys):
    code, out, err = run_cli(["runs", "--db", stored["db"], "show", "ffffffffff"], capsys)
    assert code == 2
    assert "colloc runs: error:" in err and "'ffffffffff'" in err
    assert out == ""


def test_runs_export_npz(stored, tmp_path, capsys):
    run_id = stored["summary"]["run_id"]
    argv = ["runs", "--db", stored["db"], "export", run_id[:12], str(tmp_path), "--format", "npz"]
    code, out, _ = run_cli(argv, capsys)
    assert code == 0
    written = sorted(p.name for p in tmp_path.iterdir())
    assert written == sorted([f"{run_id}.json", f"{run_id}.npz"])
    assert all(str(tmp_path / name) in out for name in written)
    with np.load(tmp_path / f"{run_id}.npz") as data:
        np.testing.assert_allclose(data["times"], np.arange(101) / 20.0)
        assert data["identified_states"].shape == (101, 4)
    meta = json.loads((tmp_path / f"{run_id}.json").read_text())
    identified = {p["name"]: p["identified"] for p in meta["parameters"]}
    for name in GAIN_NAMES:
        assert identified[name] == pytest.approx(stored["summary"]["gains"][name]["identified"])


def test_runs_export_csv(stored, tmp_path, capsys):
    run_id = stored["summary"]["run_id"]
    argv = ["runs", "--db", stored["db"], "export", run_id, str(tmp_path), "--format", "csv"]
    code, _, _ = run_cli(argv, capsys)
    assert code == 0
    params = pd.read_csv(tmp_path / "parameters.csv")
    assert list(params["name"]) == GAIN_NAMES
    np.testing.assert_allclose(params["known"], SEED_GAINS, rtol=1e-6)
    times = pd.read_csv(tmp_path / "times.csv").to_numpy().ravel()
    np.testing.assert_allclose(times, np.arange(101) / 20.0)
    assert (tmp_path / "metadata.json").is_file()


def test_runs_export_into_a_folder_with_its_files_needs_overwrite(stored, tmp_path, capsys):
    run_id = stored["summary"]["run_id"]
    argv = ["runs", "--db", stored["db"], "export", run_id, str(tmp_path)]
    assert run_cli(argv, capsys)[0] == 0
    (tmp_path / "parameters.csv").write_text("mine\n")
    code, out, err = run_cli(argv, capsys)
    assert code == 2 and "already holds" in err and "'parameters.csv'" in err
    assert (tmp_path / "parameters.csv").read_text() == "mine\n"  # nothing replaced
    code, out, err = run_cli([*argv, "--overwrite"], capsys)
    assert code == 0 and (tmp_path / "parameters.csv").read_text() != "mine\n"


def test_runs_delete_needs_six_characters_of_the_id_or_yes(stored, tmp_path, capsys):
    db = f"sqlite:///{tmp_path / 'copy.db'}"
    src = stored["db"].removeprefix("sqlite:///")
    (tmp_path / "copy.db").write_bytes(open(src, "rb").read())
    run_id = stored["summary"]["run_id"]
    code, _, err = run_cli(["runs", "delete", run_id[:1], "--db", db], capsys)
    assert code == 2 and "shorter than 6 characters" in err
    assert run_id in run_cli(["runs", "list", "--db", db], capsys)[1]  # still there
    code, out, _ = run_cli(["runs", "delete", run_id[:1], "--yes", "--db", db], capsys)
    assert code == 0 and out.strip() == f"deleted {run_id}"


def test_runs_export_with_an_unknown_format_exits_2(stored, tmp_path, capsys):
    run_id = stored["summary"]["run_id"]
    target = tmp_path / "x"
    argv = ["runs", "--db", stored["db"], "export", run_id, str(target), "--format", "xlsx"]
    code, _, err = run_cli(argv, capsys)
    assert code == 2
    assert "format: expected one of ['csv', 'npz'], found 'xlsx'" in err
    assert not target.exists()


def test_plot_flag_writes_png_and_svg_figures(stored):
    out = stored["root"] / "out"
    stems = ["force", "states", "trajectory_comparison", "constraint_violations", "gains"]
    for stem in stems:
        with Image.open(out / f"{stem}.png") as image:
            assert image.format == "PNG" and image.size[0] > 100 and image.size[1] > 100
        root = ET.parse(out / f"{stem}.svg").getroot()
        assert root.tag.endswith("svg")


def test_animate_flag_writes_a_real_time_gif(stored):
    with Image.open(stored["root"] / "out" / "pendulum.gif") as gif:
        assert gif.format == "GIF"
        # 5 s of motion played in real time at the default 30 frames per second.
        assert 145 <= gif.n_frames <= 152


def test_noise_flags_reach_the_run_and_its_summary(tmp_path, capsys):
    argv = [*SMALL, "--process-noise", "0.5", "--input-noise", "1.0", "--no-store"]
    argv += ["--noise-model", "--uncertainty", "kkt", "--json", str(tmp_path / "s.json")]
    code, out, _ = run_cli(argv, capsys)
    assert code == 0, out
    summary = json.loads((tmp_path / "s.json").read_text())
    settings = summary["settings"]
    assert (settings["process_noise"], settings["input_noise"]) == (0.5, 1.0)
    assert settings["noise_model"] is True
    assert summary["uncertainty"]["method"] == "kkt"
    assert "standard errors: kkt" in out
    names = {s["name"]: s["kind"] for s in summary["residual_diagnostics"]["signals"]}
    assert names == {
        "q0": "tracking",
        "q1": "tracking",
        "F": "measured input",
        "w1": "process noise",
    }
    # by default the exact-dynamics fit of the same data, with sandwich errors
    argv = [*SMALL, "--process-noise", "0.5", "--no-store"]
    argv += ["--json", str(tmp_path / "t.json")]
    assert run_cli(argv, capsys)[0] == 0
    other = json.loads((tmp_path / "t.json").read_text())
    assert other["uncertainty"]["method"] == "sandwich"
    assert other["uncertainty"]["blocks"] == round(101**0.5)
    assert other["uncertainty"]["discretisation"].startswith("Richardson, order 2")
    assert {s["name"] for s in other["residual_diagnostics"]["signals"]} == {"q0", "q1"}
    assert other["settings"]["noise_model"] is False


def test_cache_info_and_clear(tmp_path, capsys):
    from colloc.numeric.cache import BuildCache

    folder = tmp_path / "cache"
    BuildCache(folder).put("a" * 64, {"x": 1})
    code, out, _ = run_cli(["cache", "info", "--dir", str(folder)], capsys)
    assert code == 0 and f"directory: {folder}" in out and "entries:   1 (" in out
    assert "used:      yes" in out
    folder.chmod(0o777)
    try:
        out = run_cli(["cache", "info", "--dir", str(folder)], capsys)[1]
        assert "used:      no: " in out and "writable by other users" in out
    finally:
        folder.chmod(0o700)
    code, out, _ = run_cli(["cache", "clear", "--dir", str(folder)], capsys)
    assert code == 0 and out.strip() == f"deleted 1 entries from {folder}"
    assert list(folder.iterdir()) == []


def test_a_read_only_database_fails_before_the_work(tmp_path, capsys):
    db = tmp_path / "runs.db"
    RunStore(f"sqlite:///{db}").close()
    read_only = f"sqlite:///file:{db}?mode=ro&uri=true"
    code, out, err = run_cli([*SMALL, "--db", read_only, "--out", str(tmp_path / "o")], capsys)
    assert code == 2 and "cannot be written" in err and "nothing was computed" in err
    assert out == ""


def test_a_store_failure_after_the_work_keeps_the_run_and_says_where(tmp_path, capsys, monkeypatch):
    from sqlalchemy.exc import OperationalError

    def failing_add(self, record, replace=False):
        raise OperationalError("INSERT", {}, Exception("database disk image is malformed"))

    monkeypatch.setattr(RunStore, "add", failing_add)
    out_dir, summary = tmp_path / "out", tmp_path / "s.json"
    argv = [*SMALL, "--db", f"sqlite:///{tmp_path / 'r.db'}", "--out", str(out_dir)]
    code, out, err = run_cli([*argv, "--json", str(summary)], capsys)
    assert code == 1  # finished, but not stored
    run_id = json.loads(summary.read_text())["run_id"]
    kept = out_dir / f"unstored-{run_id[:12]}"
    assert f"the finished run is kept in {kept}" in err and "malformed" in err
    with np.load(kept / f"{run_id}.npz") as arrays:
        assert arrays["times"].shape == (101,)
    assert json.loads((kept / f"{run_id}.json").read_text())["run_id"] == run_id


def test_a_database_locked_by_another_writer_after_the_check_keeps_the_run(
    tmp_path, capsys, monkeypatch
):
    import colloc.store.runs as runs_module

    db = tmp_path / "r.db"
    holders = []
    checked = RunStore.check_writable

    def check_then_lock(self):
        checked(self)  # the database is writable when the work starts...
        holder = sqlite3.connect(db, isolation_level=None)
        holder.execute("BEGIN IMMEDIATE")  # ...then another writer takes it and keeps it
        holders.append(holder)

    monkeypatch.setattr(runs_module, "BUSY_TIMEOUT_SECONDS", 0.3)
    monkeypatch.setattr(RunStore, "check_writable", check_then_lock)
    out_dir = tmp_path / "out"
    try:
        code, out, err = run_cli([*SMALL, "--db", f"sqlite:///{db}", "--out", str(out_dir)], capsys)
    finally:
        for holder in holders:
            holder.rollback()
            holder.close()
    assert code == 1 and "database is locked" in err
    (kept,) = out_dir.glob("unstored-*")
    assert f"the finished run is kept in {kept}" in err
    assert len(list(kept.glob("*.npz"))) == 1
    with RunStore(f"sqlite:///{db}") as store:
        assert store.list().empty  # nothing half-stored


def test_a_kill_runs_the_clean_ups_and_leaves_no_half_written_files(tmp_path):
    import signal
    import subprocess
    import sys

    argv = [sys.executable, "-c", "import sys; from colloc.cli import main; sys.exit(main())"]
    argv += ["pendulum", "-n", "1", "-d", "60", "-s", "200", "-r", "-p", "-a", "--no-store"]
    argv += ["--out", str(tmp_path / "out"), "--json", str(tmp_path / "s.json")]
    process = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert process.stdout is not None
    for line in process.stdout:  # wait until the work has started
        if "simulate" in line:
            break
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 143, err
    assert "terminated; nothing half-written was kept" in err
    left = [p.name for p in tmp_path.rglob("*") if p.suffix in (".part", ".tmp")]
    assert left == [] and not (tmp_path / "s.json").exists()


# ----------------------------------------------------------------------------- gait commands


@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["--duration", "1e6"], "GiB, more than the"),
        (["--duration", "60", "--out", "/proc/x"], "--out '/proc/x': cannot write in '/proc'"),
        (["--duration", "-1", "--nodes", "3"], "duration: expected a positive"),
    ],
)
def test_gait_simulate_refuses_before_any_work(tmp_path, capsys, flags, message):
    started = time.perf_counter()
    code, out, err = run_cli(["gait", "simulate", *flags], capsys)
    assert code == 2 and message in err and out == ""
    assert time.perf_counter() - started < 10.0  # refused, not attempted (1e6 s took 8 GB)


def test_a_long_gait_simulation_is_announced_with_an_estimate(tmp_path, monkeypatch, capsys):
    import colloc.gait.workflow as workflow

    def stop(settings, progress=None):  # the announcement comes before any work
        raise KeyboardInterrupt

    monkeypatch.setattr(workflow, "simulate_trial", stop)
    argv = ["gait", "simulate", "--duration", "480", "--out", str(tmp_path / "o")]
    code, out, _ = run_cli(argv, capsys)
    assert code == 130
    assert re.search(r"this will take a while: about [3-6] min", out)
    assert "480 s of walking, 4.8e+04 samples" in out


def test_runs_list_shows_each_kind_in_its_own_columns(tmp_path, capsys):
    """Gait runs were shown in the pendulum's columns (num_links NaN, a max_rel_error of
    62206 from gains near zero); the gait columns were then keyed by a kind no run has
    ("gait", where gait identify stores "gait-identify"), so real gait runs still were."""
    from colloc.identify.gait.outputs import KIND
    from colloc.store import ParameterRow, RunRecord, RunStore

    db = f"sqlite:///{tmp_path / 'runs.db'}"
    with RunStore(db) as store:
        store.add(
            RunRecord(
                "p1", "pendulum", {"num_links": 1, "scheme": "midpoint"}, {},
                statistics={"success": True, "iterations": 4},
                parameters=[ParameterRow("k0", 2.0, 2.1, 0.1)],
            )
        )  # fmt: skip
        store.add(
            RunRecord(
                "g1", KIND, {"trial": "trials/a", "method": "smoother", "points": None}, {},
                statistics={
                    "points": 20, "success": True, "K_relative_error": 0.31,
                    "validation": {"walks": True},
                },
                parameters=[ParameterRow("K[0][hip][x]", 1e-9, 6.2e-5, 1.0)],
            )
        )  # fmt: skip
    code, out, _ = run_cli(["runs", "list", "--db", db], capsys)
    assert code == 0
    pendulum, gait = out.split("\n\n")
    assert (
        pendulum.startswith("pendulum runs:")
        and "num_links" in pendulum
        and "max_rel_error" in pendulum
    )
    assert (
        gait.startswith(f"{KIND} runs:")
        and "K_relative_error" in gait
        and "validation.walks" in gait
    )
    assert "num_links" not in gait and "max_rel_error" not in gait
    # the schedule points the fit used, which the settings leave to the trial
    _, header, row = gait.split("\n")[:3]
    assert "points" in header.split() and "20" in row.split()
    # nor the relative error over a gain near zero ((6.2e-5 - 1e-9) / 1e-9 = 61999), in any
    # format (the row's timestamp may hold any digits, so no bare "62")
    row = gait.split("\n")[2]
    assert not any(text in row for text in ("61999", "62000", "6.2e+04", "6.20e+04"))


def test_every_option_of_every_command_says_what_it_does():
    """Six gait identify options had no help text (--structure, --scheme, --guess,
    --segment-nodes, --max-iter, --seed)."""
    import argparse

    from colloc.cli import build_parser

    silent = []

    def walk(parser: argparse.ArgumentParser, path: str) -> None:
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    walk(sub, f"{path} {name}")
            elif action.option_strings and action.help in (None, "") and action.dest != "help":
                silent.append(f"{path} {action.option_strings[0]}")

    walk(build_parser(), "colloc")
    assert silent == []
