"""``colloc runs``: list, show, export or delete stored runs."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from colloc.cli.common import path_arg

#: ``colloc runs delete`` needs at least this much of an id (or --yes).
MIN_DELETE_PREFIX = 6


def add_parser(sub: Any, default_url: str) -> None:
    """``colloc runs list | show | export | delete``."""
    r = sub.add_parser("runs", help="list, show, export or delete stored runs")
    r.add_argument("--db", default=default_url, help="results database URL (default %(default)s)")
    rs = r.add_subparsers(dest="runs_command", required=True)
    # --db is accepted after the subcommand too (colloc runs list --db URL)
    after = argparse.ArgumentParser(add_help=False)
    after.add_argument("--db", default=argparse.SUPPRESS, help="results database URL")
    lst = rs.add_parser("list", help="list stored runs", parents=[after])
    lst.add_argument("--kind", default=None, help="only runs of this kind (pendulum, gait, ...)")
    lst.add_argument("--batch", default=None, help="only the runs of this batch (id or prefix)")
    show = rs.add_parser("show", help="show one run (an id or a unique prefix)", parents=[after])
    show.add_argument("run_id")
    exp = rs.add_parser("export", help="export a run's arrays and parameters", parents=[after])
    exp.add_argument("run_id")
    exp.add_argument("directory", type=path_arg)
    exp.add_argument("--format", default="csv", help="csv or npz (default %(default)s)")
    exp.add_argument("--overwrite", action="store_true", help="replace files already there")
    dele = rs.add_parser("delete", help="delete a run", parents=[after])
    dele.add_argument("run_id", help=f"the id, or a unique prefix of >= {MIN_DELETE_PREFIX}")
    dele.add_argument("--yes", action="store_true", help="allow a shorter prefix")


def run(args: argparse.Namespace) -> int:
    """Run ``colloc runs ...``; the exit status."""
    from colloc.store import RunStore

    if args.runs_command == "delete" and len(args.run_id) < MIN_DELETE_PREFIX and not args.yes:
        print(
            f"colloc runs: error: run id {args.run_id!r} is shorter than {MIN_DELETE_PREFIX} "
            "characters; give more of the id (colloc runs list), or --yes to delete the run "
            "it names",
            file=sys.stderr,
        )
        return 2
    store = RunStore(args.db, create=False)  # reading (or deleting) creates nothing
    if args.runs_command == "list":
        frame = store.list(kind=args.kind, batch=args.batch)
        if frame.empty and args.kind is not None:
            kinds = sorted(set(store.list()["kind"]))
            print(f"no runs of kind {args.kind!r} stored (kinds stored: {kinds})")
        elif frame.empty:
            print("no runs stored")
        else:
            print(_tables(store, frame, args.batch))
    elif args.runs_command == "show":
        print(store.get(args.run_id).summary())
    elif args.runs_command == "export":
        exported = store.export(
            args.run_id, args.directory, format=args.format, overwrite=args.overwrite
        )
        for path in exported:
            print(path)
    elif args.runs_command == "delete":
        print(f"deleted {store.delete(args.run_id)}")
    return 0


def _tables(store: Any, frame: Any, batch: str | None) -> str:
    """One table per kind of run, each with its kind's own columns (KIND_COLUMNS)."""
    from colloc.store.runs import KIND_COLUMNS

    parts = []
    for kind in dict.fromkeys(frame["kind"]):
        if kind in KIND_COLUMNS:
            settings, statistics, relative = KIND_COLUMNS[kind]
            table = store.list(settings, statistics, kind=kind, batch=batch)
            if not relative:
                table = table.drop(columns=["max_rel_error"])
        else:
            table = frame[frame["kind"] == kind]
        shown = table.dropna(axis=1, how="all").to_string(index=False)
        parts.append(f"{kind} runs:\n{shown}" if frame["kind"].nunique() > 1 else shown)
    return "\n\n".join(parts)
