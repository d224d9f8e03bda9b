"""On-disk cache of built CasADi functions, keyed by a hash of expressions and settings."""

from __future__ import annotations

import hashlib
import json
import logging
import os
import tempfile
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import casadi as ca

logger = logging.getLogger(__name__)

#: Bump when the layout of cached entries changes.
CACHE_FORMAT = 1


def default_cache_dir() -> Path:
    """``$COLLOC_CACHE_DIR``, else ``$XDG_CACHE_HOME/colloc``, else ``~/.cache/colloc``."""
    if os.environ.get("COLLOC_CACHE_DIR"):
        return Path(os.environ["COLLOC_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "colloc"


def cache_key(parts: Iterable[str]) -> str:
    """A stable hash of the text ``parts`` (plus the cache format and CasADi version)."""
    h = hashlib.sha256()
    for part in (f"format={CACHE_FORMAT}", f"casadi={ca.CasadiMeta.version()}", *parts):
        h.update(part.encode())
        h.update(b"\0")
    return h.hexdigest()


class BuildCache:
    """A directory of JSON files, one per key; writes are atomic (temp file + rename).

    Parameters
    ----------
    directory : path, optional
        Where entries live; default :func:`default_cache_dir`.
    """

    def __init__(self, directory: str | Path | None = None) -> None:
        self.directory = Path(directory) if directory is not None else default_cache_dir()

    def _path(self, key: str) -> Path:
        return self.directory / f"{key}.json"

    def get(self, key: str) -> dict[str, Any] | None:
        """The entry stored under ``key``, or ``None`` (a corrupt entry counts as missing)."""
        path = self._path(key)
        if not path.is_file():
            return None
        try:
            with path.open(encoding="utf-8") as fh:
                return json.load(fh)
        except (OSError, ValueError) as exc:
            logger.warning("ignoring unreadable cache entry %s: %s", path, exc)
            return None

    def put(self, key: str, entry: dict[str, Any]) -> None:
        """Store ``entry`` under ``key``; failures are logged, never raised (a cache is optional)."""
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=self.directory, suffix=".tmp")
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                json.dump(entry, fh)
            os.replace(tmp, self._path(key))
        except OSError as exc:
            logger.warning("could not write cache entry in %s: %s", self.directory, exc)


def expression_digest(exprs: Iterable[Any]) -> str:
    """A hash of SymPy expressions that visits every distinct subexpression once.

    ``srepr`` prints shared subexpressions again at every use, which for equations from
    Kane's method is exponentially longer than the expression graph (seconds for gait2d);
    this walks the graph with a memo instead.
    """
    import sympy as sm

    memo: dict[Any, bytes] = {}

    def digest(root: Any) -> bytes:
        stack: list[tuple[Any, bool]] = [(root, False)]
        while stack:
            node, ready = stack.pop()
            if node in memo:
                continue
            args = getattr(node, "args", ())
            if not args or not isinstance(node, sm.Basic):
                memo[node] = hashlib.sha256(sm.srepr(node).encode()).digest()
                continue
            if not ready:
                stack.append((node, True))
                stack.extend((a, False) for a in args if a not in memo)
                continue
            h = hashlib.sha256(type(node).__name__.encode())
            for a in args:
                h.update(memo[a])
            memo[node] = h.digest()
        return memo[root]

    total = hashlib.sha256()
    for e in exprs:
        total.update(digest(e))
    return total.hexdigest()
