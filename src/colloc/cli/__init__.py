"""The ``colloc`` command: the pendulum study, gait, the results database, batches.

Each command group is a module with its parser, its checks and its handler
(:mod:`colloc.cli.pendulum`, :mod:`colloc.cli.gait`, :mod:`colloc.cli.lab`,
:mod:`colloc.cli.runs`, :mod:`colloc.cli.cache`, :mod:`colloc.cli.batch`); this one assembles
them and runs one.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from collections.abc import Callable, Sequence
from typing import Any

#: The command's description in its help (``colloc --help``).
DESCRIPTION = "The ``colloc`` command: the pendulum study and the results database."


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``colloc`` command."""
    from colloc.cli import cache, gait, pendulum, runs
    from colloc.cli.batch import add_parser as add_batch_parser
    from colloc.cli.common import exact_option_names
    from colloc.store import DEFAULT_URL

    parser = argparse.ArgumentParser(prog="colloc", description=DESCRIPTION)
    sub = parser.add_subparsers(dest="command", required=True)
    pendulum.add_parser(sub, DEFAULT_URL)
    gait.add_parser(sub, DEFAULT_URL)
    add_batch_parser(sub, DEFAULT_URL)
    cache.add_parser(sub)
    runs.add_parser(sub, DEFAULT_URL)
    exact_option_names(parser)
    return parser


def _command(name: str) -> Callable[[argparse.Namespace], int]:
    """The handler of a command group, imported when it runs."""
    from importlib import import_module

    return import_module(f"colloc.cli.{name}").run  # type: ignore[no-any-return]


#: Subcommands of ``colloc batch``; anything else after it is a batch file to run.
BATCH_SUBCOMMANDS = ("run", "report", "list")


def _with_batch_run(argv: list[str]) -> list[str]:
    """``colloc batch SPEC.yaml ...`` is ``colloc batch run SPEC.yaml ...``."""
    if (
        len(argv) >= 2
        and argv[0] == "batch"
        and argv[1] not in BATCH_SUBCOMMANDS
        and not argv[1].startswith("-")
    ):
        return ["batch", "run", *argv[1:]]
    return argv


class _Terminated(Exception):
    """SIGTERM, raised where the program is so that its clean-ups run."""


def _raise_terminated(signum: int, frame: Any) -> None:
    raise _Terminated


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``colloc`` command; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(_with_batch_run(list(sys.argv[1:] if argv is None else argv)))
    previous = None
    if threading.current_thread() is threading.main_thread():
        # a kill (SIGTERM) runs the same clean-ups as Ctrl-C: no .part files, no half results
        previous = signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        if args.command == "pendulum" and args.repeat is not None:
            # N seeds of the pendulum are a batch: the batch group runs them
            from colloc.cli.batch import pendulum_repeat

            return pendulum_repeat(args)
        return _command(args.command)(args)
    except _Terminated:
        print("terminated; nothing half-written was kept", file=sys.stderr)
        return 143
    except (ValueError, TypeError, LookupError, OSError, RuntimeError) as exc:
        # RuntimeError: a solve or a simulation that did not succeed (its message says why).
        print(f"colloc {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted; nothing half-written was kept", file=sys.stderr)
        return 130
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    sys.exit(main())
