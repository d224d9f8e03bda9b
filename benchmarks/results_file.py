"""Append one benchmark record to a JSON list file (shared by the gait identification probes)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from colloc.numeric.memory import peak_rss_mb

__all__ = ["append_record", "peak_rss_mb"]


def append_record(path: Path, record: dict[str, Any]) -> None:
    """Print ``record`` and append it to the JSON list at ``path`` (created if missing)."""
    print(json.dumps(record, indent=1))
    path.parent.mkdir(parents=True, exist_ok=True)
    previous = json.loads(path.read_text()) if path.is_file() else []
    path.write_text(json.dumps([*previous, record], indent=1) + "\n")
