"""What the commands of ``colloc`` share: argument types, problem reports, progress lines and
the results store. Each command group's parser, checks and handler live in their own module
(:mod:`colloc.cli.pendulum`, :mod:`colloc.cli.gait`, ...); :mod:`colloc.cli` assembles them."""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any


def positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, found {text!r}") from None
    return value


#: Local Dask workers allowed per core: each is a process holding colloc and a window's
#: problem (hundreds of MB); beyond this a machine only swaps (--workers 1000000000 took
#: 4 GB in 8 s before failing).
WORKERS_PER_CORE = 4


def worker_count(text: str) -> int:
    """Local worker processes: 1 to :data:`WORKERS_PER_CORE` per core of this machine."""
    value = positive_int(text)
    most = WORKERS_PER_CORE * (os.cpu_count() or 1)
    if not 1 <= value <= most:
        raise argparse.ArgumentTypeError(
            f"expected 1 to {most} local workers ({WORKERS_PER_CORE} per core on this machine; "
            f"for more, start a Dask cluster and give --scheduler), found {text!r}"
        )
    return value


def at_least_one(text: str) -> int:
    """A count: an integer >= 1 (``--workers -1`` waited for ever on a cluster of none)."""
    value = positive_int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, found {text!r}")
    return value


def number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, found {text!r}") from None


def process_noise_arg(text: str) -> tuple[float, float]:
    """``JOINT[,TRUNK]`` standard deviations (the trunk's defaults to the joints')."""
    parts = [number(v) for v in text.split(",")]
    if len(parts) not in (1, 2) or not all(v > 0 for v in parts):
        raise argparse.ArgumentTypeError(
            f"expected JOINT[,TRUNK] standard deviations > 0, found {text!r}"
        )
    return (parts[0], parts[-1])


def lags_arg(text: str) -> tuple[int, ...]:
    """``1,2`` -> (1, 2); ``none`` -> () (ordinary least squares)."""
    if text.strip().lower() == "none":
        return ()
    try:
        lags = tuple(int(v) for v in text.split(","))
    except ValueError:
        lags = ()
    if not lags or any(v < 1 for v in lags):
        raise argparse.ArgumentTypeError(
            f"expected whole numbers of samples >= 1 separated by commas, or none; found {text!r}"
        )
    return lags


#: ``--noise-levels`` names (colloc.identify.gait.settings.NOISE_LEVEL_NAMES, repeated here so
#: that parsing imports nothing heavy) and their units.
NOISE_LEVEL_UNITS = {"marker": "m", "force": "N", "moment": "N m", "torque_prior": "N m"}


def noise_levels_arg(text: str) -> tuple[tuple[str, float], ...]:
    """``marker=0.001,force=2`` -> (("marker", 0.001), ("force", 2.0)): each a known name and
    a positive standard deviation, no name twice."""
    pairs, problems = [], []
    for item in (part.strip() for part in text.split(",")):
        name, sep, value = item.partition("=")
        name = name.strip()
        try:
            number_value = float(value) if sep else float("nan")
        except ValueError:
            number_value = float("nan")
        if name not in NOISE_LEVEL_UNITS:
            problems.append(f"unknown name {name!r}")
        elif not 0 < number_value < float("inf"):
            problems.append(f"{name}: expected a standard deviation > 0, found {value!r}")
        else:
            pairs.append((name, number_value))
    names = [n for n, _ in pairs]
    problems += [f"{n} given twice" for n in sorted({n for n in names if names.count(n) > 1})]
    if problems:
        units = ", ".join(f"{n} [{u}]" for n, u in NOISE_LEVEL_UNITS.items())
        raise argparse.ArgumentTypeError(
            f"expected NAME=VALUE pairs separated by commas ({units}); " + "; ".join(problems)
        )
    return tuple(pairs)


def add_smoothing_options(parser: argparse.ArgumentParser, prefix: str = "") -> None:
    """``--smooth-from`` and ``--noise-levels``: what the gait smoother tracks and the marker
    smoother's noise levels (``gait identify`` and ``gait smooth``); ``prefix`` leads each
    help text (e.g. the method the options belong to)."""
    from colloc.identify.gait.settings import SMOOTH_SOURCES

    parser.add_argument(
        "--smooth-from",
        choices=SMOOTH_SOURCES,
        default="auto",
        help=prefix + "what the smoother tracks: 'markers', a lab trial's raw markers and "
        "plates; 'markers-only', its markers without the plates; 'angles', the trial's angles, trunk pose and torques (a lab's through its 6 Hz "
        "filter, inverse kinematics and dynamics); 'auto', markers when the trial has them "
        "(default %(default)s)",
    )
    parser.add_argument(
        "--noise-levels",
        type=noise_levels_arg,
        default=(),
        metavar="NAME=VALUE,...",
        help=prefix + "the marker smoother's noise levels instead of those the trial "
        "estimated: NAME=VALUE pairs separated by commas, from marker [m], force [N], moment "
        "[N m] (each plate sample) and torque_prior [N m] (the torques' prior about the "
        "inverse dynamics, default 20)",
    )
    parser.add_argument(
        "--fit-places",
        action="store_true",
        help=prefix + "estimate each marker's place in its segment with the motion (two "
        "parameters per marker under a 10 mm prior about the static trial's or the walk's "
        "least-squares place; the JSON gives each estimate and the share of it the record "
        "determines) instead of keeping those places",
    )


def path_arg(text: str) -> Path:
    """A path argument: empty text is refused (``Path("")`` would silently be the working
    folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a path, found an empty one")
    return Path(text)


ALLOW_OTHER_TABLES_HELP = (
    "let colloc's tables go into a database that already holds other applications' tables "
    "(refused by default)"
)


def output_problems(json_path: Path | None, out_dir: Path | None) -> list[str]:
    """What stops ``--json`` or ``--out`` from being written, found before any work (a file
    is created and removed where each will go)."""
    problems = []
    targets = [("--json", json_path, json_path.parent if json_path else None)]
    targets.append(("--out", out_dir, out_dir))
    for flag, given, folder in targets:
        if given is None or folder is None:
            continue
        if flag == "--json" and given.is_dir():
            problems.append(f"{flag} {str(given)!r}: is a folder; give a file path")
            continue
        if folder.exists() and not folder.is_dir():
            problems.append(f"{flag} {str(given)!r}: {str(folder)!r} is a file, not a folder")
            continue
        existing = folder
        while not existing.exists() and existing != existing.parent:
            existing = existing.parent
        try:
            with tempfile.TemporaryFile(dir=existing):
                pass
        except OSError as error:
            problems.append(f"{flag} {str(given)!r}: cannot write in {str(existing)!r} ({error})")
    return problems


def memory_bytes() -> float:
    """The machine's physical memory (infinite where the platform does not say)."""
    try:
        return float(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):
        return float("inf")


def report_problems(command: str, problems: list[str]) -> bool:
    """Print every settings problem to stderr; True when there was any."""
    for line in problems:
        print(f"{command}: error: {line}", file=sys.stderr)
    return bool(problems)


def step_printer(start: float) -> Callable[[str, str], None]:
    """``progress(step, detail)`` printing the elapsed time since ``start``."""

    def progress(step: str, detail: str) -> None:
        print(f"[{time.perf_counter() - start:7.2f} s] {step:<15} {detail}", flush=True)

    return progress


def open_store(args: argparse.Namespace) -> Any:
    """The results store of ``--db``, opened before any work so a bad URL fails fast; None
    with ``--no-store``."""
    if args.no_store:
        return None
    from colloc.store import RunStore  # SQLAlchemy and pandas: only when storing

    store = RunStore(args.db, allow_other_tables=args.db_allow_other_tables)
    store.check_writable()  # a read-only or locked database fails now, not after the work
    return store


def store_or_keep(command: str, store: Any, record: Any, args: argparse.Namespace) -> bool:
    """Store ``record``; if the database fails now, keep the run in ``--out`` and say where."""
    from colloc.store.export import export_record

    try:
        store.add(record, replace=True)
        return True
    except Exception as error:  # noqa: BLE001 - any database failure: keep the finished run
        folder = Path(args.out) / f"unstored-{record.run_id[:12]}"
        kept = export_record(record, folder, format="npz", overwrite=True)
        print(
            f"{command}: error: storing the run in {args.db} failed "
            f"({type(error).__name__}: {error}); the finished run is kept in {folder} "
            f"({', '.join(p.name for p in kept)}: arrays, parameters and settings)",
            file=sys.stderr,
        )
        return False


def print_iteration(row: dict[str, float]) -> None:
    """One line per solver iteration, under the step lines."""
    print(
        f"{'':12}{'':16}iter {int(row['iteration']):3d}  objective {row['objective']:.6e}  "
        f"infeasibility {row['infeasibility']:.2e}",
        flush=True,
    )


def cluster_flags(parser: argparse.ArgumentParser) -> None:
    """``--workers`` and ``--scheduler``: where a batch runs."""
    parser.add_argument(
        "--workers",
        type=at_least_one,
        default=None,
        help="workers of the local Dask cluster, one thread each (default: one per core)",
    )
    parser.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="run on a running Dask cluster instead (e.g. tcp://host:8786); its workers must "
        "reach the database and the files",
    )


def exact_option_names(parser: argparse.ArgumentParser) -> None:
    """Refuse abbreviated option names in ``parser`` and every subcommand's parser:
    ``--numlink 2`` must not silently mean ``--numlinks 2`` (nor, in a batch file, slip a
    banned ``no-store`` past its check as ``no-s``).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Changed in place.
    """
    parser.allow_abbrev = False
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                exact_option_names(child)
