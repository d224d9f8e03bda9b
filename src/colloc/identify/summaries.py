"""JSON helpers shared by the studies' summaries: plain values and atomic writes."""

from __future__ import annotations

import json
import os
import secrets
from pathlib import Path
from typing import Any

import numpy as np


def write_json_atomic(data: dict[str, Any], path: Path) -> Path:
    """Write JSON through a temporary file so a failure never leaves half a file.

    Parameters
    ----------
    data : dict
        JSON-serialisable content (see :func:`plain`).
    path : Path

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # Not tempfile.mkstemp: its 0600 mode would survive the rename; this one follows umask.
    tmp = path.parent / f".{path.name}.{secrets.token_hex(8)}.part"
    try:
        with open(tmp, "x", encoding="utf-8") as fh:
            json.dump(data, fh, indent=2)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def finite_or_none(value: float | None) -> float | None:
    """``float(value)``, or None for None, NaN and infinities."""
    return None if value is None or not np.isfinite(value) else float(value)


def plain(value: Any) -> Any:
    """A JSON-friendly copy: NaN/inf become None, NumPy scalars and arrays Python values."""
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, list | tuple):
        return [plain(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value
