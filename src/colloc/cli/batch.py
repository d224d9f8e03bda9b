"""``colloc batch`` and ``colloc pendulum --repeat``: batch files to tasks, a progress bar.

Each entry of a batch file is turned into the command line of its kind and checked by the
same parser and checks as that command, so an entry accepts exactly the command's options and
gets the same errors, named by the entry. Every problem of every entry is reported before
anything runs.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import math
import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from colloc.cli import gait, pendulum
from colloc.cli.common import (
    ALLOW_OTHER_TABLES_HELP,
    cluster_flags,
    exact_option_names,
    path_arg,
    report_problems,
)
from colloc.cli.gait import gait_identify_checks, gait_simulate_checks
from colloc.cli.pendulum import pendulum_checks


@dataclass(frozen=True)
class Kind:
    """How a batch entry of one kind becomes a task.

    Attributes
    ----------
    words : tuple of str
        The command words before the options (``("gait", "identify")``).
    checks : callable
        The command's checks after parsing: ``checks(args) -> (settings, problems)``.
    positional : tuple of str
        Options given as positional arguments (the trial folder).
    outputs : callable
        ``outputs(args, settings) -> dict`` of the :class:`colloc.batch.Task` fields
        ``out``, ``plot``, ``animate``, ``json``.
    reads_trial : bool
        Its ``trial`` may be written by a simulation of the same batch.
    writes_trial : bool
        It writes a trial into ``out/trial``.
    """

    words: tuple[str, ...]
    checks: Callable[..., tuple[Any, list[str]]]
    positional: tuple[str, ...]
    outputs: Callable[[argparse.Namespace, Any], dict[str, Any]]
    reads_trial: bool = False
    writes_trial: bool = False


def _pendulum_outputs(args: argparse.Namespace, settings: Any) -> dict[str, Any]:
    plots = args.plot or args.animate
    return {
        "out": args.out if plots else None,
        "plot": args.plot,
        "animate": args.animate,
        "json": args.json,
    }


def _identify_outputs(args: argparse.Namespace, settings: Any) -> dict[str, Any]:
    return {
        "out": None if args.no_plots else args.out,
        "plot": not args.no_plots,
        "json": args.json,
    }


def _simulate_outputs(args: argparse.Namespace, settings: Any) -> dict[str, Any]:
    return {"out": Path(settings.out)}


#: The kinds of batch entry.
KINDS: dict[str, Kind] = {
    "pendulum": Kind(("pendulum",), pendulum_checks, (), _pendulum_outputs),
    "gait-simulate": Kind(
        ("gait", "simulate"), gait_simulate_checks, (), _simulate_outputs, writes_trial=True
    ),
    "gait-identify": Kind(
        ("gait", "identify"), gait_identify_checks, ("trial",), _identify_outputs, reads_trial=True
    ),
}

#: Options a batch entry may not set: the batch decides them.
BATCH_LEVEL = ("db", "no-store", "repeat", "workers", "scheduler", "db-allow-other-tables")

#: Options that make no run: asked for in a batch file, they are an error, not a help page.
NOT_RUNS = ("help",)


def entry_argv(kind: str, options: dict[str, Any]) -> list[str]:
    """The command line of one batch entry.

    Parameters
    ----------
    kind : str
        A key of :data:`KINDS`.
    options : dict
        Option name (long form, dashes) -> value: ``True`` gives the bare flag, ``False`` and
        ``None`` leave it out, a list is joined by commas.

    Returns
    -------
    list of str
    """
    words, positional = KINDS[kind].words, KINDS[kind].positional
    argv = list(words)
    for key in positional:
        if key in options:
            argv.append(_text(options[key]))
    for key, value in options.items():
        if key in positional or value is None or value is False:
            continue
        argv.append(f"--{key}")
        if value is not True:
            argv.append(_text(value))
    return argv


def _text(value: Any) -> str:
    if isinstance(value, list | tuple):
        return ",".join(_text(v) for v in value)
    return str(value)


def _parse(
    parser: argparse.ArgumentParser, argv: list[str]
) -> tuple[argparse.Namespace | None, str | None]:
    """Parse without exiting: the namespace, or argparse's error message."""
    with contextlib.redirect_stderr(io.StringIO()) as err:
        try:
            return parser.parse_args(argv), None
        except SystemExit:
            lines = [line for line in err.getvalue().splitlines() if "error:" in line]
            message = lines[-1].split("error:", 1)[1].strip() if lines else "invalid options"
            return None, message


def _entries_parser() -> argparse.ArgumentParser:
    """The parser of a batch's entries: the commands a batch runs, as ``colloc`` parses them."""
    from colloc.store import DEFAULT_URL

    parser = argparse.ArgumentParser(prog="colloc")
    sub = parser.add_subparsers(dest="command", required=True)
    pendulum.add_parser(sub, DEFAULT_URL)
    gait.add_parser(sub, DEFAULT_URL)
    exact_option_names(parser)
    return parser


def build_tasks(entries: list[Any]) -> tuple[list[Any], list[str]]:
    """Tasks from a batch file's entries, and every problem of every entry.

    Parameters
    ----------
    entries : list of colloc.batch.Entry

    Returns
    -------
    tasks : list of colloc.batch.Task
        Complete only when ``problems`` is empty.
    problems : list of str
        Each naming its entry (``runs[i] (kind, entry n)``).
    """
    from colloc.batch.tasks import Task, folder_digest, task_key
    from colloc.gait.outputs import TRIAL_DIR

    problems: list[str] = []
    tasks: list[Task] = []
    made: dict[Path, Task] = {}  # trial folders written by the batch's simulations
    outs: dict[Path, int] = {}  # their output folders
    writes: dict[Path, int] = {}
    keys: dict[str, int] = {}  # entries by the run they compute
    parser = _entries_parser()
    for entry in entries:
        where = entry.where()
        forbidden = [k for k in entry.options if k in BATCH_LEVEL]
        if forbidden:
            problems.append(
                f"{where}: {forbidden} are set for the whole batch (colloc batch --db, "
                "--workers, --scheduler), not per entry"
            )
            continue
        asks_help = [k for k in entry.options if k in NOT_RUNS]
        if asks_help:
            words = " ".join(KINDS[entry.kind].words)
            problems.append(
                f"{where}: {asks_help[0]!r} makes no run; `colloc {words} --help` lists the "
                "options an entry may set"
            )
            continue
        args, error = _parse(parser, entry_argv(entry.kind, entry.options))
        if args is None:
            problems.append(f"{where}: {error}")
            continue
        kind = KINDS[entry.kind]
        producer = made.get(Path(args.trial).resolve()) if kind.reads_trial else None
        if kind.reads_trial:
            settings, found = kind.checks(args, require_trial=producer is None)
            simulated = outs.get(Path(args.trial).resolve())
            if simulated is not None:
                found = [p for p in found if not p.startswith("trial:")] + [
                    f"trial {str(args.trial)!r} is the output folder of the simulation of "
                    f"entry {simulated}; its trial is {str(Path(args.trial) / TRIAL_DIR)!r}"
                ]
            # the trial enters the key by its content (or its maker's key), not its path
            inputs: dict[str, Any] = (
                {"trial": folder_digest(args.trial)}
                if producer is None
                else {"trial_from": producer.key}
            )
        else:
            settings, found = kind.checks(args)
            inputs = {}
        problems += [f"{where}: {p}" for p in found]
        if found:
            continue  # its settings are not a run: no key, no task
        task = Task(
            entry.position,
            entry.kind,
            settings,
            key=task_key(entry.kind, _plain(settings), inputs),
            after=() if producer is None else (producer.position,),
            **kind.outputs(args, settings),
        )
        if kind.writes_trial:  # into out/trial
            made[(Path(settings.out) / TRIAL_DIR).resolve()] = task
            outs[Path(settings.out).resolve()] = entry.position
        twin = keys.get(task.key)
        if twin is not None:
            problems.append(
                f"{where}: the same run as entry {twin} (the same options and inputs); "
                "remove one, or make them differ (e.g. the seed)"
            )
        keys.setdefault(task.key, entry.position)
        for path in _written(task):
            if path in writes:
                problems.append(
                    f"{where}: writes into {str(path)!r} as entry {writes[path]} does; give "
                    "each entry its own (e.g. out: 'results/seed-{seed}')"
                )
            writes.setdefault(path, entry.position)
        tasks.append(task)
    return tasks, problems


def _written(task: Any) -> list[Path]:
    paths = [task.json] if task.json is not None else []
    if task.out is not None:
        paths.append(task.out)
    return [Path(p).resolve() for p in paths]


def _plain(settings: Any) -> dict[str, Any]:
    plain = settings.to_dict()
    plain.pop("trial", None)  # the trial enters the key by its content, not its path
    return plain


class _Progress:
    """A tqdm bar over the runs: done / failed / skipped, elapsed and remaining."""

    def __init__(self) -> None:
        self.bar: Any = None
        self.counts = {"done": 0, "failed": 0, "skipped": 0}
        self.failures: list[Any] = []

    def start(self, to_run: int, skipped: int) -> None:
        from tqdm import tqdm

        if skipped:
            print(f"{skipped} entries already done (runs stored): skipped", flush=True)
        self.bar = tqdm(total=to_run, unit="run", file=sys.stderr, dynamic_ncols=True)

    def result(self, result: Any) -> None:
        self.counts[result.status] = self.counts.get(result.status, 0) + 1
        if result.status == "failed":
            self.failures.append(result)
        if result.status == "skipped" or self.bar is None:
            return
        self.bar.set_postfix(done=self.counts["done"], failed=self.counts["failed"], refresh=False)
        self.bar.update(1)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _execute(
    tasks: list[Any], url: str, spec: dict[str, Any], args: argparse.Namespace
) -> tuple[Any, _Progress]:
    from colloc.batch.execute import run_batch

    progress = _Progress()
    start = time.perf_counter()
    try:
        outcome = run_batch(
            tasks,
            url,
            spec=spec,
            workers=args.workers,
            scheduler=args.scheduler,
            on_start=progress.start,
            on_result=progress.result,
            allow_other_tables=args.db_allow_other_tables,
        )
    finally:
        progress.close()
    wall = time.perf_counter() - start
    ran = [r for r in outcome.results.values() if r.status != "skipped"]
    busy = sum(r.seconds for r in ran)
    print(
        f"batch {outcome.batch_id[:12]}: {outcome.count('done')} done, "
        f"{outcome.count('failed')} failed, {outcome.count('skipped')} skipped; wall "
        f"{wall:.1f} s on {outcome.workers} workers, {busy:.1f} s of runs "
        f"(sum of run times / workers / wall = "
        f"{busy / max(outcome.workers, 1) / wall if wall > 0 else math.nan:.2f})"
    )
    known = [r.cache_hit for r in ran if r.cache_hit is not None]
    if known:
        print(
            f"build cache: {sum(known)} of {len(known)} runs found their problem built "
            f"({len(known) - sum(known)} built it)"
        )
    for failure in progress.failures:
        entry = tasks[failure.position]
        print(f"  failed: entry {failure.position} ({entry.kind}): {failure.error}")
    return outcome, progress


def _batch_run(args: argparse.Namespace) -> int:
    from colloc.batch.spec import BatchSpecError, read_batch_spec
    from colloc.store import DEFAULT_URL

    try:
        spec = read_batch_spec(args.spec, tuple(KINDS))
        file_problems: list[str] = []
    except BatchSpecError as error:
        if error.partial is None:
            raise
        spec, file_problems = error.partial, error.problems
    tasks, problems = build_tasks(spec.entries)
    problems = file_problems + problems
    if spec.workers is not None and args.workers is None:
        args.workers = spec.workers
    url = args.db or spec.db or DEFAULT_URL
    if problems:
        for line in problems:
            print(f"colloc batch: error: {line}", file=sys.stderr)
        print(f"colloc batch: {len(problems)} problem(s); nothing was run", file=sys.stderr)
        return 2
    if args.check:
        print(f"{args.spec}: {len(tasks)} entries, all valid")
        return 0
    source = {"file": os.fspath(args.spec), "spec": spec.source}
    outcome, _ = _execute(tasks, url, source, args)
    print(f"report: colloc batch report {outcome.batch_id[:12]} --db {url}")
    return 1 if outcome.count("failed") else 0


def pendulum_repeat(args: argparse.Namespace) -> int:
    """``colloc pendulum ... --repeat N``: N seeds as one batch, then the per-gain report.

    Parameters
    ----------
    args : argparse.Namespace
        ``colloc pendulum``'s, with ``repeat`` set; checked by
        :func:`colloc.cli.pendulum.pendulum_checks` (the first seed's settings).

    Returns
    -------
    int
        The exit status.
    """
    from colloc.batch.report import pendulum_table, write_batch_report
    from colloc.batch.tasks import Task, task_key

    settings, problems = pendulum_checks(args)
    unsupported = [
        f"{flag}: not with --repeat (the batch report goes to --out)"
        for flag, given in (("-p/--plot", args.plot), ("-a/--animate", args.animate))
        if given
    ]
    if args.json is not None:
        unsupported.append("--json: not with --repeat (the batch report goes to --out)")
    if args.no_store:
        unsupported.append("--no-store: --repeat stores every run (the batch needs them)")
    if report_problems("colloc pendulum", problems + unsupported):
        return 2
    tasks = []
    for i in range(args.repeat):
        seeded = replace(settings, seed=settings.seed + i)
        tasks.append(Task(i, "pendulum", seeded, key=task_key("pendulum", seeded.to_dict(), {})))
    spec = {"command": "colloc pendulum --repeat", "repeat": args.repeat, **settings.to_dict()}
    outcome, _ = _execute(tasks, args.db, spec, args)
    from colloc.store import RunStore

    with RunStore(args.db) as store:
        run_ids = store.batches.run_ids(outcome.batch_id)
        table = pendulum_table(store, run_ids)
        folder = args.out / f"batch-{outcome.batch_id[:12]}"
        written = write_batch_report(store, outcome.batch_id, folder)
    if not table.empty:
        shown = table[["gain", "known", "mean", "spread", "mean_se", "spread_over_se"]]
        print(shown.to_string(index=False, float_format=lambda v: f"{v:.5g}"))
        print("spread_over_se near 1: the reported standard errors match the scatter")
    print(f"report -> {folder} ({len(written)} files)")
    return 1 if outcome.count("failed") else 0


def _batch_report(args: argparse.Namespace) -> int:
    from colloc.batch.report import write_batch_report
    from colloc.store import DEFAULT_URL, RunStore

    with RunStore(args.db or DEFAULT_URL, create=False) as store:
        full_id = store.batches.resolve(args.batch_id)
        folder = args.out or Path(f"batch-report-{full_id[:12]}")
        for path in write_batch_report(store, full_id, folder):
            print(path)
    return 0


def _batch_list(args: argparse.Namespace) -> int:
    from colloc.store import DEFAULT_URL, RunStore

    with RunStore(args.db or DEFAULT_URL, create=False) as store:
        frame = store.batches.list()
    print("no batches recorded" if frame.empty else frame.to_string(index=False))
    return 0


#: The handler of each ``colloc batch`` subcommand.
BATCH_COMMANDS: dict[str, Callable[[argparse.Namespace], int]] = {
    "run": _batch_run,
    "report": _batch_report,
    "list": _batch_list,
}


def add_parser(sub: Any, default_url: str) -> None:
    """``colloc batch [run] SPEC.yaml``, ``colloc batch report ID``, ``colloc batch list``."""
    b = sub.add_parser(
        "batch",
        help="many runs at once from a YAML file, on Dask; their record and report",
        description="colloc batch SPEC.yaml runs every entry of the file (the same as "
        "'colloc batch run SPEC.yaml').",
    )
    bs = b.add_subparsers(dest="batch_command", required=True)
    db = argparse.ArgumentParser(add_help=False)
    db.add_argument(
        "--db", default=None, help=f"results database URL (default: the file's, else {default_url})"
    )
    run = bs.add_parser("run", help="run a batch file", parents=[db])
    run.add_argument("spec", type=path_arg, help="the batch file (YAML)")
    run.add_argument("--db-allow-other-tables", action="store_true", help=ALLOW_OTHER_TABLES_HELP)
    run.add_argument(
        "--check", action="store_true", help="check every entry and stop, running nothing"
    )
    cluster_flags(run)
    report = bs.add_parser("report", help="write a batch's tables and figures", parents=[db])
    report.add_argument("batch_id", help="the id, or a unique prefix")
    report.add_argument(
        "--out", type=path_arg, default=None, help="folder (default: batch-report-<id prefix>)"
    )
    bs.add_parser("list", help="list recorded batches", parents=[db])


def run(args: argparse.Namespace) -> int:
    """Run ``colloc batch ...``; the exit status."""
    return BATCH_COMMANDS[args.batch_command](args)
