"""The temporary IPOPT log folders of solves whose process was killed are removed.

Reference: processes started and ended here (so their ids are known to be gone) and this
process (alive).
"""

from __future__ import annotations

import os
import subprocess
import sys

from colloc.solve.ipopt import SCRATCH_PREFIX, sweep_scratch_folders


def _ended_pid() -> int:
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_only_the_folders_of_ended_processes_are_removed(tmp_path):
    dead = tmp_path / f"{SCRATCH_PREFIX}{_ended_pid()}-abc123"
    alive = tmp_path / f"{SCRATCH_PREFIX}{os.getpid()}-def456"
    unnamed = tmp_path / f"{SCRATCH_PREFIX}r8vr8fr6"  # the old naming: no process id
    other = tmp_path / "something-else-1"
    for folder in (dead, alive, unnamed, other):
        folder.mkdir()
        (folder / "ipopt.log").write_text("iteration log\n")
    removed = sweep_scratch_folders(tmp_path)
    assert removed == [dead]
    assert not dead.exists()
    assert alive.is_dir() and unnamed.is_dir() and other.is_dir()
    assert sweep_scratch_folders(tmp_path) == []  # nothing left to remove
