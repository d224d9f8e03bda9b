"""The process that runs a batch, and whether it is still alive.

A batch killed with SIGKILL cannot record its own end; the next batch that opens the log
asks whether each running batch's process is still alive. A process is named by its host,
pid and start time (from ``/proc`` where there is one), so that a pid reused by another
process is not taken for the batch's.
"""

from __future__ import annotations

import os
import socket
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class ProcessOwner:
    """A process on a host.

    Attributes
    ----------
    host : str
    pid : int
    process_start : str or None
        The kernel's start time of the process (clock ticks since boot), when known.
    """

    host: str
    pid: int
    process_start: str | None

    @classmethod
    def this_process(cls) -> ProcessOwner:
        """The calling process.

        Returns
        -------
        ProcessOwner
        """
        return cls(socket.gethostname(), os.getpid(), _start_time(os.getpid()))

    def alive(self) -> bool | None:
        """Whether the process is still running: None when it is on another host.

        Returns
        -------
        bool or None
        """
        if self.host != socket.gethostname():
            return None
        try:
            os.kill(self.pid, 0)
        except ProcessLookupError:
            return False
        except PermissionError:
            pass  # another user's process: it exists
        now = _start_time(self.pid)
        return self.process_start is None or now is None or now == self.process_start


def _start_time(pid: int) -> str | None:
    """Field 22 of ``/proc/<pid>/stat`` (start time in clock ticks), or None without /proc."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = text.rsplit(")", 1)[-1].split()  # the command name may hold spaces
    return fields[19] if len(fields) > 19 else None
