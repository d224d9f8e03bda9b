"""On-disk cache of built CasADi functions, keyed by a hash of expressions and settings."""

from __future__ import annotations

import hashlib
import hmac
import json
import logging
import os
import secrets
import stat
import tempfile
import warnings
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import casadi as ca

logger = logging.getLogger(__name__)

#: Bump when the layout of cached entries changes.
CACHE_FORMAT = 3

#: The secret that signs entries, private to the user, beside them.
KEY_FILE = ".key"


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

    Each entry records the cache format, its key and an HMAC-SHA256 of its payload under a
    secret that only this user can read (``.key`` in the directory, created with mode 0600),
    and is used only when all three match: CasADi deserialises the payload into functions it
    will run, so only entries colloc itself wrote are loaded; a checksum anyone could
    recompute would not do. A directory, key or entry another user could have written (not
    owned by this user, or writable by group or others) is not read at all. Either way the
    entry is rebuilt and a warning names the file. What is inside a payload is checked again
    by whoever deserialises it (:meth:`colloc.numeric.stencil.StencilFunctions.from_bytes`).

    Parameters
    ----------
    directory : path, optional
        Where entries live; default :func:`default_cache_dir`.
    """

    def __init__(self, directory: str | Path | None = None) -> None:
        self.directory = Path(directory) if directory is not None else default_cache_dir()

    def path(self, key: str) -> Path:
        """The file that holds (or would hold) the entry under ``key``.

        Parameters
        ----------
        key : str

        Returns
        -------
        Path
        """
        return self.directory / f"{key}.json"

    def _secret(self, create: bool) -> bytes | None:
        """The signing secret; made on first use when ``create``; None if absent or untrusted."""
        path = self.directory / KEY_FILE
        if create and not path.exists():
            try:
                fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
            except FileExistsError:
                pass  # another process made it first
            else:
                with os.fdopen(fd, "wb") as fh:
                    fh.write(secrets.token_bytes(32))
        if self.untrusted(path) is not None:
            return None
        try:
            secret = path.read_bytes()
        except OSError:
            return None
        return secret if len(secret) == 32 else None

    def untrusted(self, path: Path | None = None) -> str | None:
        """Why ``path`` (default: the directory) must not be read, or None when it may.

        Parameters
        ----------
        path : Path, optional

        Returns
        -------
        str or None
        """
        target = self.directory if path is None else path
        try:
            info = target.stat()
        except OSError:
            return None
        owner = getattr(os, "getuid", lambda: info.st_uid)()
        if info.st_uid != owner:
            return f"{target} belongs to another user (uid {info.st_uid})"
        if info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
            return f"{target} is writable by other users (mode {stat.filemode(info.st_mode)})"
        return None

    def get(self, key: str) -> dict[str, Any] | None:
        """The entry stored under ``key``, or ``None`` (missing, unreadable, stale or untrusted:
        each but the first with a warning naming the file)."""
        path = self.path(key)
        if not path.is_file():
            return None
        reason = self.untrusted() or self.untrusted(path)
        secret = self._secret(create=False) if reason is None else None
        if reason is None and secret is None:
            reason = (
                f"no signing key that this user alone can write ({self.directory / KEY_FILE}): "
                "the entry cannot be shown to be colloc's own"
            )
        if reason is None and secret is not None:
            try:
                with path.open(encoding="utf-8") as fh:
                    entry = json.load(fh)
                reason = _entry_problem(entry, key, secret)
            except (OSError, ValueError) as exc:
                reason = f"unreadable ({exc})"
        if reason is not None:
            warnings.warn(
                f"build cache entry {path} not used, rebuilding: {reason}",
                UserWarning,
                stacklevel=3,
            )
            return None
        payload: dict[str, Any] = entry["payload"]
        return payload

    def put(self, key: str, entry: dict[str, Any]) -> None:
        """Store ``entry`` under ``key``; failures are logged, never raised (a cache is optional)."""
        try:
            self.directory.mkdir(parents=True, exist_ok=True, mode=0o700)
            secret = self._secret(create=True)
            if secret is None:
                logger.warning("no usable signing key in %s: entry not written", self.directory)
                return
            record = {"format": CACHE_FORMAT, "key": key, "hmac": _payload_mac(entry, secret)}
            record["payload"] = entry
            fd, tmp = tempfile.mkstemp(dir=self.directory, suffix=".tmp")  # 0600: private
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                json.dump(record, fh)
            os.replace(tmp, self.path(key))
        except OSError as exc:
            logger.warning("could not write cache entry in %s: %s", self.directory, exc)

    def entries(self) -> list[Path]:
        """The entry files in the directory.

        Returns
        -------
        list of Path
        """
        if not self.directory.is_dir():
            return []
        return sorted(p for p in self.directory.glob("*.json") if len(p.stem) == 64)

    def clear(self) -> int:
        """Delete every entry (only colloc's: files named by a key) and the signing secret, so
        that entries written under the old secret are never trusted again.

        Returns
        -------
        int
            How many were deleted.
        """
        count = 0
        for path in self.entries():
            path.unlink(missing_ok=True)
            count += 1
        (self.directory / KEY_FILE).unlink(missing_ok=True)
        return count


def _payload_mac(payload: dict[str, Any], secret: bytes) -> str:
    text = json.dumps(payload, sort_keys=True).encode()
    return hmac.new(secret, text, hashlib.sha256).hexdigest()


def _entry_problem(entry: Any, key: str, secret: bytes) -> str | None:
    """What is wrong with a loaded entry, or None."""
    if not isinstance(entry, dict) or "payload" not in entry:
        return "not an entry of this cache format (written by an older colloc?)"
    if entry.get("format") != CACHE_FORMAT:
        return f"cache format {entry.get('format')!r}, this colloc writes {CACHE_FORMAT}"
    if entry.get("key") != key:
        return "stored under another key"
    mac = entry.get("hmac")
    if not isinstance(mac, str) or not hmac.compare_digest(
        mac, _payload_mac(entry["payload"], secret)
    ):
        return "not signed by this user's colloc (its content or signature was changed)"
    return None


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
