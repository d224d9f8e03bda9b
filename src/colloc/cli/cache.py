"""``colloc cache``: where the build cache is and what it holds; clear it."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any


def add_parser(sub: Any) -> None:
    """``colloc cache info | clear``."""
    c = sub.add_parser("cache", help="the build cache: where it is, what it holds; clear it")
    c.add_argument("cache_command", choices=("info", "clear"))
    c.add_argument("--dir", type=Path, default=None, help="cache directory (default: colloc's)")


def run(args: argparse.Namespace) -> int:
    """Run ``colloc cache ...``; the exit status."""
    from colloc.numeric.cache import BuildCache

    store = BuildCache(args.dir)
    if args.cache_command == "clear":
        print(f"deleted {store.clear()} entries from {store.directory}")
        return 0
    entries = store.entries()
    size = sum(path.stat().st_size for path in entries)
    print(f"directory: {store.directory}")
    print(f"entries:   {len(entries)} ({size / 2**20:.1f} MiB)")
    reason = store.untrusted()
    print(f"used:      {'no: ' + reason if reason else 'yes'}")
    return 0
