"""``colloc pendulum``: the seed's study, its flags, their checks and the run."""

from __future__ import annotations

import argparse
import math
import time
from typing import Any

from colloc.cli import common


def add_parser(sub: Any, default_url: str) -> None:
    """``colloc pendulum``: flags with the defaults of ``PendulumSettings``."""
    from pathlib import Path

    from colloc.identify.guesses import GAIN_GUESSES
    from colloc.identify.pendulum.settings import (
        SCHEME_NAMES,
        UNCERTAINTY_METHODS,
        PendulumSettings,
    )

    defaults = PendulumSettings()
    p = sub.add_parser(
        "pendulum",
        help="identify the LQR gains of an n-link pendulum on a cart (the seed's study)",
        description="Run N-link system identification: derive, design LQR, simulate, add "
        "noise, and recover the gains by direct collocation with IPOPT.",
    )
    p.add_argument(
        "-n",
        "--numlinks",
        type=common.positive_int,
        default=defaults.num_links,
        help="number of links in the pendulum (default %(default)s)",
    )
    p.add_argument(
        "-d",
        "--duration",
        type=common.number,
        default=defaults.duration,
        help="duration of the simulation in seconds (default %(default)s)",
    )
    p.add_argument(
        "-s",
        "--samplerate",
        type=common.number,
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
        type=common.positive_int,
        default=defaults.seed,
        help="random seed (default %(default)s)",
    )
    p.add_argument(
        "--amplitude",
        type=common.number,
        default=defaults.force_amplitude,
        help="amplitude of each sine of the cart force, N (default %(default)s)",
    )
    p.add_argument(
        "--noise-std",
        type=common.number,
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
        type=common.number,
        default=defaults.process_noise,
        metavar="STD",
        help="motor noise on every joint torque, N m per sample (default %(default)s: none); "
        "with --noise-model identified as a disturbance torque per joint",
    )
    p.add_argument(
        "--input-noise",
        type=common.number,
        default=defaults.input_noise,
        metavar="STD",
        help="noise on the measured cart force, N (default %(default)s: exact); with "
        "--noise-model identified as a measured input",
    )
    p.add_argument(
        "--noise-model",
        action="store_true",
        help="identify with the noise modelled (maximum a posteriori, moved to the marginal "
        "likelihood's optimum; see docs/process-noise.md) instead of the exact-dynamics fit "
        "with sandwich errors",
    )
    p.add_argument(
        "--uncertainty",
        default=defaults.uncertainty,
        help=f"standard errors: {', '.join(UNCERTAINTY_METHODS)} (default %(default)s)",
    )
    p.add_argument("--db", default=default_url, help="results database URL (default %(default)s)")
    p.add_argument("--no-store", action="store_true", help="do not store the run in the database")
    p.add_argument(
        "--db-allow-other-tables", action="store_true", help=common.ALLOW_OTHER_TABLES_HELP
    )
    p.add_argument(
        "--out",
        type=common.path_arg,
        default=Path("results"),
        help="directory for plots and animation",
    )
    p.add_argument(
        "--json", type=common.path_arg, default=None, help="write a machine-readable summary here"
    )
    p.add_argument(
        "--repeat",
        type=common.positive_int,
        default=None,
        metavar="N",
        help="run N noise realisations (seeds SEED .. SEED+N-1) as a batch on Dask and report "
        "each gain's spread against its mean standard error",
    )
    common.cluster_flags(p)


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
    from colloc.identify.pendulum.settings import PendulumSettings

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
    too_big = settings.too_big(common.memory_bytes())
    outputs = common.output_problems(args.json, args.out if (args.plot or args.animate) else None)
    return settings, settings.problems() + unused + too_big + outputs


def run(args: argparse.Namespace) -> int:
    """Run ``colloc pendulum``; the exit status."""
    from colloc.identify.pendulum.outputs import (
        pendulum_record,
        pendulum_run_id,
        pendulum_summary,
        save_pendulum_animation,
        save_pendulum_plots,
    )
    from colloc.identify.pendulum.settings import LONG_RUN_SECONDS
    from colloc.identify.pendulum.workflow import run_pendulum
    from colloc.identify.summaries import write_json_atomic

    settings, problems = pendulum_checks(args)
    if common.report_problems("colloc pendulum", problems):
        return 2
    needs = settings.estimated_needs()
    if needs["seconds"] > LONG_RUN_SECONDS:
        print(
            f"this will take a while: about {needs['seconds'] / 60:.0f} min by a rough "
            f"estimate ({needs['nodes']:.3g} nodes, {needs['variables']:.3g} unknowns, "
            f"{needs['derive_seconds']:.0f} s of it deriving the equations)",
            flush=True,
        )
    store = common.open_store(args)
    start = time.perf_counter()
    progress = common.step_printer(start)
    run = run_pendulum(settings, progress=progress, iterations=common.print_iteration)
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
        stored = common.store_or_keep("colloc pendulum", store, pendulum_record(run, run_id), args)
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
