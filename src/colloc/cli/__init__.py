"""The ``colloc`` command: the pendulum study and the results database."""

from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

STEPS = (
    "derive",
    "control design",
    "simulate",
    "build",
    "solve",
    "check",
    "store",
    "plot",
    "animate",
)


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, found {text!r}") from None
    return value


def _at_least_one(text: str) -> int:
    """A count: an integer >= 1 (``--workers -1`` waited for ever on a cluster of none)."""
    value = _positive_int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, found {text!r}")
    return value


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, found {text!r}") from None


def _process_noise(text: str) -> tuple[float, float]:
    """``JOINT[,TRUNK]`` standard deviations (the trunk's defaults to the joints')."""
    parts = [_number(v) for v in text.split(",")]
    if len(parts) not in (1, 2) or not all(v > 0 for v in parts):
        raise argparse.ArgumentTypeError(
            f"expected JOINT[,TRUNK] standard deviations > 0, found {text!r}"
        )
    return (parts[0], parts[-1])


def _lags(text: str) -> tuple[int, ...]:
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


def _exact_option_names(parser: argparse.ArgumentParser) -> None:
    """Refuse abbreviated option names in ``parser`` and every subcommand's parser:
    ``--numlink 2`` must not silently mean ``--numlinks 2`` (nor, in a batch file, slip a
    banned ``no-store`` past its check as ``no-s``)."""
    parser.allow_abbrev = False
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                _exact_option_names(child)


def _path(text: str) -> Path:
    """A path argument: empty text is refused (``Path("")`` would silently be the working
    folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a path, found an empty one")
    return Path(text)


_ALLOW_OTHER_TABLES_HELP = (
    "let colloc's tables go into a database that already holds other applications' tables "
    "(refused by default)"
)


def _output_problems(json_path: Path | None, out_dir: Path | None) -> list[str]:
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


#: ``colloc runs delete`` needs at least this much of an id (or --yes).
MIN_DELETE_PREFIX = 6


def _memory_bytes() -> float:
    """The machine's physical memory (infinite where the platform does not say)."""
    try:
        return float(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):
        return float("inf")


def _report_problems(command: str, problems: list[str]) -> bool:
    """Print every settings problem to stderr; True when there was any."""
    for line in problems:
        print(f"{command}: error: {line}", file=sys.stderr)
    return bool(problems)


def _step_printer(start: float) -> Callable[[str, str], None]:
    """``progress(step, detail)`` printing the elapsed time since ``start``."""

    def progress(step: str, detail: str) -> None:
        print(f"[{time.perf_counter() - start:7.2f} s] {step:<15} {detail}", flush=True)

    return progress


def _identify_parser(gs: Any, default_url: str) -> None:
    """``colloc gait identify``: flags with the defaults of ``GaitIdentifySettings``."""
    from colloc.identify import gait_settings as gi

    d = gi.GaitIdentifySettings(trial=Path("."))
    idp = gs.add_parser(
        "identify",
        help="identify the gain-scheduled controller T*(phi) - K(phi) s of a walking trial by "
        "direct collocation; fit on its first part, validate on the rest",
    )
    idp.add_argument("trial", type=_path, help="trial directory (colloc.data.read_trial)")
    idp.add_argument(
        "--fit-fraction",
        type=_number,
        default=d.fit_fraction,
        help="share of the trial to fit, split at the nearest right heel strike "
        "(default %(default)s)",
    )
    idp.add_argument(
        "--points",
        type=_positive_int,
        default=None,
        help=f"schedule points P (default: the trial's controller's, else {gi.DEFAULT_POINTS})",
    )
    idp.add_argument(
        "--feedback",
        choices=gi.FEEDBACK_CHOICES,
        default=d.feedback,
        help="fed-back signals s: the trial's recorded set (metadata; else joint angles and "
        "rates) or a named set (default %(default)s)",
    )
    idp.add_argument("--structure", choices=gi.STRUCTURES, default=d.structure)
    idp.add_argument("--scheme", choices=gi.SCHEMES, default=d.scheme)
    idp.add_argument(
        "--phase",
        choices=gi.PHASES,
        default=d.phase,
        help="phase: causal (reset at each right heel strike, then rising at the stride rate: "
        "what a real-time controller can know), linear between right heel strikes, or the "
        "trial's controller_phase column (default %(default)s)",
    )
    idp.add_argument("--guess", choices=gi.GUESSES, default=d.guess)
    idp.add_argument(
        "--method",
        choices=gi.METHODS,
        default=d.method,
        help="the smoother (the model fully actuated, fitted to the data; then the schedule's "
        "least squares on its signals) or the closed-loop collocation problem "
        "(default %(default)s)",
    )
    idp.add_argument(
        "--track",
        default=",".join(d.track),
        help=f"tracked signals, comma-separated from {list(gi.TRACK_CHOICES)} "
        "(default %(default)s)",
    )
    idp.add_argument(
        "--start", type=_number, default=d.start, help="fit window start, s (default 0)"
    )
    idp.add_argument(
        "--duration",
        type=_number,
        default=None,
        help="fit window length, s (default: up to the split)",
    )
    idp.add_argument("--segment-nodes", type=_positive_int, default=d.segment_nodes)
    idp.add_argument("--max-iter", type=int, default=d.max_iter)
    idp.add_argument(
        "--process-noise",
        type=_process_noise,
        default=None,
        metavar="JOINT[,TRUNK]",
        help="estimate motor noise on each joint torque (std, N m) and residual forces on the "
        "trunk (std, N; default: JOINT) as disturbances: the maximum a posteriori fit, "
        "standard errors by the sandwich over strides (default: exact dynamics)",
    )
    idp.add_argument(
        "--instrument-lags",
        type=_lags,
        default=d.instrument_lags,
        metavar="LAGS",
        help="method smoother: fit the schedule by two-stage least squares with the fed-back "
        "states this many samples earlier as instruments, which removes the bias of motor noise "
        "that reaches them within a sample; 'none': ordinary least squares (default "
        + ",".join(str(v) for v in d.instrument_lags)
        + ")",
    )
    idp.add_argument(
        "--window-strides",
        type=_positive_int,
        default=d.window_strides,
        metavar="N",
        help="method smoother: smooth in windows of N whole strides sharing the controller "
        "(memory follows the window; default: one window)",
    )
    idp.add_argument(
        "--workers",
        type=_positive_int,
        default=None,
        metavar="N",
        help="smooth the stride windows (--window-strides) on a local Dask cluster of N worker "
        "processes (default: one after another in this process)",
    )
    idp.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="smooth the stride windows on a running Dask cluster (tcp://host:8786) instead",
    )
    idp.add_argument(
        "--no-simulate",
        action="store_true",
        help="skip the forward simulation of the held-out part",
    )
    idp.add_argument("--seed", type=_positive_int, default=d.seed, help="random seed")
    idp.add_argument("--db", default=default_url, help="results database URL")
    idp.add_argument("--no-store", action="store_true", help="do not store the run")
    idp.add_argument("--db-allow-other-tables", action="store_true", help=_ALLOW_OTHER_TABLES_HELP)
    idp.add_argument("--out", type=_path, default=Path("gait-identification"), help="figures")
    idp.add_argument("--no-plots", action="store_true", help="do not draw figures")
    idp.add_argument("--json", type=_path, default=None, help="write a summary here")


def _open_store(args: argparse.Namespace) -> Any:
    """The results store of ``--db``, opened before any work so a bad URL fails fast; None
    with ``--no-store``."""
    if args.no_store:
        return None
    from colloc.store import RunStore  # SQLAlchemy and pandas: only when storing

    store = RunStore(args.db, allow_other_tables=args.db_allow_other_tables)
    store.check_writable()  # a read-only or locked database fails now, not after the work
    return store


def _store_or_keep(command: str, store: Any, record: Any, args: argparse.Namespace) -> bool:
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


def _print_iteration(row: dict[str, float]) -> None:
    """One line per solver iteration, under the step lines."""
    print(
        f"{'':12}{'':16}iter {int(row['iteration']):3d}  objective {row['objective']:.6e}  "
        f"infeasibility {row['infeasibility']:.2e}",
        flush=True,
    )


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``colloc`` command."""
    from colloc.identify.guesses import GAIN_GUESSES
    from colloc.identify.pendulum_settings import (
        SCHEME_NAMES,
        UNCERTAINTY_METHODS,
        PendulumSettings,
    )
    from colloc.store import DEFAULT_URL

    defaults = PendulumSettings()
    parser = argparse.ArgumentParser(prog="colloc", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser(
        "pendulum",
        help="identify the LQR gains of an n-link pendulum on a cart (the seed's study)",
        description="Run N-link system identification: derive, design LQR, simulate, add "
        "noise, and recover the gains by direct collocation with IPOPT.",
    )
    p.add_argument(
        "-n",
        "--numlinks",
        type=_positive_int,
        default=defaults.num_links,
        help="number of links in the pendulum (default %(default)s)",
    )
    p.add_argument(
        "-d",
        "--duration",
        type=_number,
        default=defaults.duration,
        help="duration of the simulation in seconds (default %(default)s)",
    )
    p.add_argument(
        "-s",
        "--samplerate",
        type=_number,
        default=defaults.sample_rate,
        help="sample rate of the data and the discretization, Hz (default %(default)s)",
    )
    p.add_argument(
        "-i",
        "--initialconditions",
        default=defaults.initial_guess,
        help=f"initial guess of the gains: {', '.join(GAIN_GUESSES)} (default %(default)s)",
    )
    p.add_argument("-r", "--sensornoise", action="store_true", help="add noise to the sensor data")
    p.add_argument(
        "-a", "--animate", action="store_true", help="save an animation of the identified motion"
    )
    p.add_argument("-p", "--plot", action="store_true", help="save result plots (PNG and SVG)")
    p.add_argument(
        "--scheme",
        default=defaults.scheme,
        help=f"collocation scheme: {', '.join(SCHEME_NAMES)} (default %(default)s)",
    )
    p.add_argument(
        "--hessian", default=defaults.hessian, help="exact or limited-memory (default %(default)s)"
    )
    p.add_argument(
        "--seed",
        type=_positive_int,
        default=defaults.seed,
        help="random seed (default %(default)s)",
    )
    p.add_argument(
        "--amplitude",
        type=_number,
        default=defaults.force_amplitude,
        help="amplitude of each sine of the cart force, N (default %(default)s)",
    )
    p.add_argument(
        "--noise-std",
        type=_number,
        default=None,
        help=f"angle noise standard deviation with -r, degrees (default {defaults.noise_std_deg})",
    )
    p.add_argument(
        "--check-true-gains",
        action="store_true",
        help="also solve with the gains fixed at the truth and report that objective",
    )
    p.add_argument(
        "--process-noise",
        type=_number,
        default=defaults.process_noise,
        metavar="STD",
        help="motor noise on every joint torque, N m per sample (default %(default)s: none); "
        "with --noise-model identified as a disturbance torque per joint",
    )
    p.add_argument(
        "--input-noise",
        type=_number,
        default=defaults.input_noise,
        metavar="STD",
        help="noise on the measured cart force, N (default %(default)s: exact); with "
        "--noise-model identified as a measured input",
    )
    p.add_argument(
        "--noise-model",
        action="store_true",
        help="identify with the noise modelled (maximum a posteriori; biased on 2 links, see "
        "docs/process-noise.md) instead of the exact-dynamics fit with sandwich errors",
    )
    p.add_argument(
        "--uncertainty",
        default=defaults.uncertainty,
        help=f"standard errors: {', '.join(UNCERTAINTY_METHODS)} (default %(default)s)",
    )
    p.add_argument("--db", default=DEFAULT_URL, help="results database URL (default %(default)s)")
    p.add_argument("--no-store", action="store_true", help="do not store the run in the database")
    p.add_argument("--db-allow-other-tables", action="store_true", help=_ALLOW_OTHER_TABLES_HELP)
    p.add_argument(
        "--out", type=_path, default=Path("results"), help="directory for plots and animation"
    )
    p.add_argument("--json", type=_path, default=None, help="write a machine-readable summary here")
    p.add_argument(
        "--repeat",
        type=_positive_int,
        default=None,
        metavar="N",
        help="run N noise realisations (seeds SEED .. SEED+N-1) as a batch on Dask and report "
        "each gain's spread against its mean standard error",
    )
    _cluster_flags(p)

    g = sub.add_parser(
        "gait", help="planar walking: synthetic perturbed-walking trials, controller identification"
    )
    gs = g.add_subparsers(dest="gait_command", required=True)
    sim = gs.add_parser(
        "simulate",
        help="find a walking cycle, design its gain-scheduled controller, and simulate a "
        "perturbed-walking trial",
    )
    sim.add_argument(
        "--duration", type=_number, default=60.0, help="seconds of walking (default %(default)s)"
    )
    sim.add_argument(
        "--speed", type=_number, default=1.2, help="mean belt speed, m/s (default %(default)s)"
    )
    sim.add_argument(
        "--seed", type=_positive_int, default=0, help="random seed (default %(default)s)"
    )
    sim.add_argument("--out", type=_path, default=Path("gait-simulation"), help="output directory")
    sim.add_argument(
        "--points",
        type=_positive_int,
        default=None,
        help="schedule points P of the trial's controller (default 20, the fewest measured to "
        "walk the 8-minute record)",
    )
    sim.add_argument(
        "--nodes",
        type=_positive_int,
        default=None,
        help="collocation nodes of the walking cycle (default: 60, then 100 and 160 until the "
        "cycle settles at the speed)",
    )
    sim.add_argument("--structure", default="full", help="gain structure: full or joint-isolated")
    sim.add_argument(
        "--feedback",
        default="all",
        help="fed-back states: joints (angles and rates), joints+trunk, or all but the hip's "
        "forward position (default %(default)s)",
    )
    sim.add_argument(
        "--unperturbed", action="store_true", help="constant belt speed instead of the record"
    )
    sim.add_argument(
        "--motor-noise",
        type=_number,
        default=0.0,
        metavar="NM",
        help="standard deviation of Gaussian noise on each joint torque in the simulation, N m "
        "(default %(default)s; real walking has some, e.g. 2-5)",
    )
    sim.add_argument(
        "--noise",
        type=_number,
        default=1.0,
        help="sensor noise as a multiple of the default lab noise, 0 for none "
        "(default %(default)s)",
    )
    sim.add_argument(
        "--lab-export",
        action="store_true",
        help="also write the markers, force plates and belt speed a gait lab would have "
        "recorded (lab-export.tsv, 1 mm marker noise; see colloc gait trial-from-lab)",
    )
    sim.add_argument(
        "--perturbation-scale",
        type=_number,
        default=1.0,
        help="factor on the record's speed deviations (default %(default)s)",
    )

    _identify_parser(gs, DEFAULT_URL)
    from colloc.cli.lab import add_parser as lab_parser

    lab_parser(gs)

    _batch_parser(sub, DEFAULT_URL)

    c = sub.add_parser("cache", help="the build cache: where it is, what it holds; clear it")
    c.add_argument("cache_command", choices=("info", "clear"))
    c.add_argument("--dir", type=Path, default=None, help="cache directory (default: colloc's)")

    r = sub.add_parser("runs", help="list, show, export or delete stored runs")
    r.add_argument("--db", default=DEFAULT_URL, help="results database URL (default %(default)s)")
    rs = r.add_subparsers(dest="runs_command", required=True)
    # --db is accepted after the subcommand too (colloc runs list --db URL)
    after = argparse.ArgumentParser(add_help=False)
    after.add_argument("--db", default=argparse.SUPPRESS, help="results database URL")
    lst = rs.add_parser("list", help="list stored runs", parents=[after])
    lst.add_argument("--kind", default=None)
    lst.add_argument("--batch", default=None, help="only the runs of this batch (id or prefix)")
    show = rs.add_parser("show", help="show one run (an id or a unique prefix)", parents=[after])
    show.add_argument("run_id")
    exp = rs.add_parser("export", help="export a run's arrays and parameters", parents=[after])
    exp.add_argument("run_id")
    exp.add_argument("directory", type=_path)
    exp.add_argument("--format", default="csv", help="csv or npz (default %(default)s)")
    exp.add_argument("--overwrite", action="store_true", help="replace files already there")
    dele = rs.add_parser("delete", help="delete a run", parents=[after])
    dele.add_argument("run_id", help=f"the id, or a unique prefix of >= {MIN_DELETE_PREFIX}")
    dele.add_argument("--yes", action="store_true", help="allow a shorter prefix")
    _exact_option_names(parser)
    return parser


def _cluster_flags(parser: argparse.ArgumentParser) -> None:
    """``--workers`` and ``--scheduler``: where a batch runs."""
    parser.add_argument(
        "--workers",
        type=_at_least_one,
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


def _batch_parser(sub: Any, default_url: str) -> None:
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
    run.add_argument("spec", type=_path, help="the batch file (YAML)")
    run.add_argument("--db-allow-other-tables", action="store_true", help=_ALLOW_OTHER_TABLES_HELP)
    run.add_argument(
        "--check", action="store_true", help="check every entry and stop, running nothing"
    )
    _cluster_flags(run)
    report = bs.add_parser("report", help="write a batch's tables and figures", parents=[db])
    report.add_argument("batch_id", help="the id, or a unique prefix")
    report.add_argument(
        "--out", type=_path, default=None, help="folder (default: batch-report-<id prefix>)"
    )
    bs.add_parser("list", help="list recorded batches", parents=[db])


def pendulum_checks(args: argparse.Namespace) -> tuple[Any, list[str]]:
    """The settings of ``colloc pendulum`` and every problem found before any work.

    Parameters
    ----------
    args : argparse.Namespace
        As :func:`build_parser` parses ``colloc pendulum ...``.

    Returns
    -------
    settings : PendulumSettings
    problems : list of str
        Invalid settings, options without effect, a run too big for this machine's memory,
        outputs that cannot be written (empty when the run may start).
    """
    from colloc.identify.pendulum_settings import PendulumSettings

    settings = PendulumSettings(
        num_links=args.numlinks,
        duration=args.duration,
        sample_rate=args.samplerate,
        initial_guess=args.initialconditions,
        sensor_noise=args.sensornoise,
        noise_std_deg=PendulumSettings.noise_std_deg if args.noise_std is None else args.noise_std,
        force_amplitude=args.amplitude,
        scheme=args.scheme,
        hessian=args.hessian,
        seed=args.seed,
        check_true_gains=args.check_true_gains,
        process_noise=args.process_noise,
        input_noise=args.input_noise,
        noise_model=args.noise_model,
        uncertainty=args.uncertainty,
    )
    unused = (
        [f"--noise-std {args.noise_std}: has no effect without -r (no sensor noise is added)"]
        if args.noise_std is not None and not args.sensornoise
        else []
    )
    too_big = settings.too_big(_memory_bytes())
    outputs = _output_problems(args.json, args.out if (args.plot or args.animate) else None)
    return settings, settings.problems() + unused + too_big + outputs


def _pendulum(args: argparse.Namespace) -> int:
    from colloc.identify.pendulum import run_pendulum
    from colloc.identify.pendulum_outputs import (
        pendulum_record,
        pendulum_run_id,
        pendulum_summary,
        save_pendulum_animation,
        save_pendulum_plots,
    )
    from colloc.identify.pendulum_settings import LONG_RUN_SECONDS
    from colloc.identify.summaries import write_json_atomic

    settings, problems = pendulum_checks(args)
    if args.repeat is not None:
        from colloc.cli.batch import pendulum_repeat

        return pendulum_repeat(args, settings, problems)
    if _report_problems("colloc pendulum", problems):
        return 2
    needs = settings.estimated_needs()
    if needs["seconds"] > LONG_RUN_SECONDS:
        print(
            f"this will take a while: about {needs['seconds'] / 60:.0f} min by a rough "
            f"estimate ({needs['nodes']:.3g} nodes, {needs['variables']:.3g} unknowns, "
            f"{needs['derive_seconds']:.0f} s of it deriving the equations)",
            flush=True,
        )
    store = _open_store(args)
    start = time.perf_counter()
    progress = _step_printer(start)
    run = run_pendulum(settings, progress=progress, iterations=_print_iteration)
    run_id = pendulum_run_id(run)
    stats = run.solution.stats
    print(
        f"\nIPOPT: {stats['message']} after {stats['iterations']} iterations, "
        f"objective {stats['objective']:.6g}"
    )
    if run.objective_at_true_gains is not None:
        print(f"objective with the true gains: {run.objective_at_true_gains:.6g}")
    method = run.uncertainty.method if run.uncertainty is not None else "none"
    print(
        f"\n{'gain':<8} {'known':>12} {'identified':>12} {'std error':>10} {'scheme err':>10} "
        f"{'initial':>12}"
    )
    for name, k, i, s, d, g in zip(
        run.gain_names,
        run.known_gains,
        run.identified_gains,
        run.standard_errors,
        run.discretisation_errors,
        run.initial_gains,
        strict=True,
    ):
        error = f"{s:10.5f}" if math.isfinite(s) else f"{'n/a':>10}"
        scheme = f"{d:10.2e}" if math.isfinite(d) else f"{'n/a':>10}"
        print(f"{name:<8} {k:12.5f} {i:12.5f} {error} {scheme} {g:12.5f}")
    print(f"standard errors: {method}")
    if run.uncertainty is not None and run.uncertainty.discretisation_note:
        print(f"scheme error: {run.uncertainty.discretisation_note}")
    print(f"max relative gain error: {run.max_rel_gain_error:.3%}")
    for note in run.notes:
        print(f"note: {note}")
    stored = True
    if store is not None:
        progress("store", f"run {run_id[:12]} -> {args.db}")
        stored = _store_or_keep("colloc pendulum", store, pendulum_record(run, run_id), args)
    if args.plot:
        progress("plot", f"figures -> {args.out}")
        for path in save_pendulum_plots(run, args.out):
            print(f"  {path}")
    if args.animate:
        progress("animate", f"animation -> {args.out}")
        print(f"  {save_pendulum_animation(run, args.out / 'pendulum.gif')}")
    total = time.perf_counter() - start
    times = ", ".join(f"{k} {v:.2f} s" for k, v in run.timings.items())
    print(f"times: {times}; with storing and figures {total:.2f} s")
    if args.json is not None:
        write_json_atomic(pendulum_summary(run, run_id), args.json)
        print(f"summary -> {args.json}")
    return 0 if stats["success"] and stored else 1


def _runs(args: argparse.Namespace) -> int:
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
        else:
            print(
                "no runs stored"
                if frame.empty
                else frame.dropna(axis=1, how="all").to_string(index=False)
            )
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


def gait_identify_checks(
    args: argparse.Namespace, *, require_trial: bool = True
) -> tuple[Any, list[str]]:
    """The settings of ``colloc gait identify`` and every problem found before any work.

    Parameters
    ----------
    args : argparse.Namespace
        As :func:`build_parser` parses ``colloc gait identify ...``.
    require_trial : bool, optional
        False when the trial folder is made before the run (by a batch's simulation).

    Returns
    -------
    settings : GaitIdentifySettings
    problems : list of str
        Invalid settings and outputs that cannot be written (empty when the run may start;
        the trial itself is read, and checked, by the run).
    """
    from colloc.identify.gait_settings import GaitIdentifySettings

    settings = GaitIdentifySettings(
        trial=args.trial,
        fit_fraction=args.fit_fraction,
        points=args.points,
        feedback=args.feedback,
        structure=args.structure,
        scheme=args.scheme,
        phase=args.phase,
        guess=args.guess,
        track=tuple(t.strip() for t in args.track.split(",") if t.strip()),
        start=args.start,
        duration=args.duration,
        segment_nodes=args.segment_nodes,
        max_iter=args.max_iter,
        simulate_validation=not args.no_simulate,
        seed=args.seed,
        process_noise=args.process_noise,
        method=args.method,
        instrument_lags=args.instrument_lags,
        window_strides=args.window_strides,
    )
    outputs = _output_problems(args.json, None if args.no_plots else args.out)
    spread = []
    if (args.workers is not None or args.scheduler is not None) and args.window_strides is None:
        spread.append(
            "--workers/--scheduler: expected --window-strides N (the stride windows are what "
            "the workers smooth), found none"
        )
    return settings, settings.problems(require_trial=require_trial) + outputs + spread


def _gait_identify(args: argparse.Namespace) -> int:
    settings, problems = gait_identify_checks(args)
    if _report_problems("colloc gait identify", problems):
        return 2
    from colloc.identify.gait import identify_gait
    from colloc.identify.gait_outputs import (
        gait_record,
        gait_run_id,
        gait_summary,
        save_gait_plots,
    )
    from colloc.identify.summaries import write_json_atomic

    store = _open_store(args)
    start = time.perf_counter()
    progress = _step_printer(start)
    if args.workers is not None or args.scheduler is not None:
        from colloc.batch.cluster import client_map, dask_client

        progress("workers", f"Dask: {args.scheduler or f'{args.workers} local workers'}")
        from colloc.numeric.memory import peak_rss_mb

        with dask_client(args.workers, args.scheduler) as client:
            run = identify_gait(
                settings, progress, _print_iteration, map_windows=client_map(client)
            )
            # each worker's peak with its forked solvers': what the windows cost in memory
            worker_peaks = [float(v) for v in client.run(peak_rss_mb).values()]
    else:
        run = identify_gait(settings, progress=progress, iterations=_print_iteration)
        worker_peaks = []
    run_id = gait_run_id(run)
    summary = gait_summary(run, run_id) | {"worker_peak_rss_mb": worker_peaks}
    print(
        f"\nsolver: {run.solver['status']} after {run.solver['iterations']} iterations "
        f"(objective {run.solver['objective']:.6g}, largest defect "
        f"{run.solver['constraint_violation']:.2e})"
    )
    for key in ("K_relative_error", "Tstar_relative_error", "direct_K_relative_error"):
        if summary[key] is not None:
            print(f"{key}: {summary[key]:.2%}")
    if summary["fraction_within_3se"] is not None:
        print(f"entries within 3 SE of the truth: {summary['fraction_within_3se']:.1%}")
    vaf = run.validation["torque_vaf"]
    print(f"held-out torque VAF ({' / '.join(vaf)}):")
    for joint in vaf["collocation"]:
        print(f"  {joint:<12}" + "".join(f" {vaf[name][joint]:8.4f}" for name in vaf))
    print(f"held-out forward simulation: {_walk_line(run.validation)}")
    if run.validation.get("direct_walk"):
        print(f"  under the direct fit: {_walk_line(run.validation['direct_walk'])}")
    workers_said = (
        f", workers {', '.join(f'{v:.0f}' for v in worker_peaks)} MB" if worker_peaks else ""
    )
    print(f"peak memory: {run.peak_rss_mb:.0f} MB here{workers_said}")
    for note in run.notes:
        print(f"note: {note}")
    stored = True
    if store is not None:
        progress("store", f"run {run_id[:12]} -> {args.db}")
        stored = _store_or_keep("colloc gait identify", store, gait_record(run, run_id), args)
    if not args.no_plots:
        progress("plot", f"figures -> {args.out}")
        for path in save_gait_plots(run, args.out):
            print(f"  {path}")
    if args.json is not None:
        write_json_atomic(summary, args.json)
        print(f"summary -> {args.json}")
    walked = run.validation.get("walks") is not False
    return 0 if run.solver["success"] and walked and stored else 1


def _walk_line(walk: dict[str, Any]) -> str:
    """A held-out forward simulation in a line: its end, its strides, its angles' RMS."""
    line = str(walk.get("message"))
    if walk.get("strides") is not None:
        of = walk.get("measured_strides")
        line += f"; {walk['strides']} strides" + (f" of the record's {of}" if of else "")
    rms_deg = walk.get("angle_rms_deg") or {}
    if rms_deg:
        line += (
            f"; joint angles {min(rms_deg.values()):.1f}-{max(rms_deg.values()):.1f} deg RMS "
            "from the measured"
        )
    return line


def _gait(args: argparse.Namespace) -> int:
    return GAIT_COMMANDS[args.gait_command](args)


def gait_simulate_checks(args: argparse.Namespace) -> tuple[Any, list[str]]:
    """The settings of ``colloc gait simulate`` and every problem found before any work.

    Parameters
    ----------
    args : argparse.Namespace
        As :func:`build_parser` parses ``colloc gait simulate ...``.

    Returns
    -------
    settings : GaitSimulationSettings
    problems : list of str
        Invalid settings, a trial too big for this machine's memory, an output folder that
        cannot be written (empty when the run may start).
    """
    from colloc.gait.workflow import GaitSimulationSettings

    # Flags left out take the settings' defaults (defined once, in colloc.gait.settings).
    optional = {"num_points": args.points} if args.points is not None else {}
    settings = GaitSimulationSettings(
        duration=args.duration,
        speed=args.speed,
        seed=args.seed,
        out=args.out,
        num_nodes=args.nodes,
        **optional,
        structure=args.structure,
        feedback=args.feedback,
        perturbed=not args.unperturbed,
        perturbation_scale=args.perturbation_scale,
        motor_noise=args.motor_noise,
        noise=args.noise,
    )
    too_big = settings.too_big(_memory_bytes())
    return settings, settings.problems() + too_big + _output_problems(None, args.out)


def _gait_simulate(args: argparse.Namespace) -> int:
    from colloc.gait.settings import LONG_SIMULATION_SECONDS
    from colloc.gait.workflow import simulate_trial

    settings, problems = gait_simulate_checks(args)
    if _report_problems("colloc gait simulate", problems):
        return 2
    needs = settings.estimated_needs()
    if needs["seconds"] > LONG_SIMULATION_SECONDS:
        print(
            f"this will take a while: about {needs['seconds'] / 60:.0f} min by a rough "
            f"estimate ({settings.duration:g} s of walking, {needs['samples']:.3g} samples)",
            flush=True,
        )
    start = time.perf_counter()
    result = simulate_trial(settings, progress=_step_printer(start))
    if args.lab_export:
        from colloc.lab import lab_export_from_record, write_lab_export
        from colloc.models.gait2d_params import load_parameters

        params = load_parameters(settings.body_mass, settings.height)
        export = lab_export_from_record(result.record, params, seed=settings.seed)
        result.files["lab export"] = write_lab_export(export, result.out / "lab-export.tsv")
    for name, path in result.files.items():
        print(f"  {name}: {path}")
    for note in result.notes:
        print(f"note: {note}")
    summary = result.summary
    strides = summary["strides"]
    print(
        f"strides: {strides['right']} right, {strides['left']} left; fell: {result.fell} "
        f"({summary['message']}); wall time {time.perf_counter() - start:.1f} s"
    )
    return 1 if result.fell else 0


def _cache(args: argparse.Namespace) -> int:
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


def _gait_trial_from_lab(args: argparse.Namespace) -> int:
    from colloc.cli.lab import run

    return run(args)


GAIT_COMMANDS = {
    "simulate": _gait_simulate,
    "identify": _gait_identify,
    "trial-from-lab": _gait_trial_from_lab,
}


def _batch(args: argparse.Namespace) -> int:
    from colloc.cli.batch import BATCH_COMMANDS

    return BATCH_COMMANDS[args.batch_command](args)


COMMANDS = {
    "pendulum": _pendulum,
    "gait": _gait,
    "runs": _runs,
    "cache": _cache,
    "batch": _batch,
}

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
        return COMMANDS[args.command](args)
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
