"""Append one benchmark record to a JSON list file (shared by the gait identification probes)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any


def append_record(path: Path, record: dict[str, Any]) -> None:
    """Print ``record`` and append it to the JSON list at ``path`` (created if missing)."""
    print(json.dumps(record, indent=1))
    path.parent.mkdir(parents=True, exist_ok=True)
    previous = json.loads(path.read_text()) if path.is_file() else []
    path.write_text(json.dumps([*previous, record], indent=1) + "\n")


def peak_rss_mb() -> float:
    """Peak resident memory [MB] of this process or of its largest finished child: colloc
    solves IPOPT in a forked child (the watchdog), whose factors the parent never holds, so
    this process's own peak alone misses the solve's memory."""
    import resource

    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return max(own, children) / 1024
