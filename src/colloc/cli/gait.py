"""``colloc gait``: simulate a perturbed-walking trial, identify its controller, and (in
:mod:`colloc.cli.lab`) make a trial from a lab's exports."""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from colloc.cli.common import (
    ALLOW_OTHER_TABLES_HELP,
    add_smoothing_options,
    lags_arg,
    memory_bytes,
    number,
    open_store,
    output_problems,
    path_arg,
    positive_int,
    print_iteration,
    process_noise_arg,
    report_problems,
    step_printer,
    store_or_keep,
    worker_count,
)


def add_parser(sub: Any, default_url: str) -> None:
    """``colloc gait simulate | identify | trial-from-lab | smooth | plan``."""
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
        "--duration", type=number, default=60.0, help="seconds of walking (default %(default)s)"
    )
    sim.add_argument(
        "--speed", type=number, default=1.2, help="mean belt speed, m/s (default %(default)s)"
    )
    sim.add_argument(
        "--seed", type=positive_int, default=0, help="random seed (default %(default)s)"
    )
    sim.add_argument(
        "--out", type=path_arg, default=Path("gait-simulation"), help="output directory"
    )
    sim.add_argument(
        "--points",
        type=positive_int,
        default=None,
        help="schedule points P of the trial's controller (default 20, the fewest measured to "
        "walk the 8-minute record)",
    )
    sim.add_argument(
        "--nodes",
        type=positive_int,
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
        type=number,
        default=0.0,
        metavar="NM",
        help="standard deviation of Gaussian noise on each joint torque in the simulation, N m "
        "(default %(default)s; real walking has some, e.g. 2-5)",
    )
    sim.add_argument(
        "--noise",
        type=number,
        default=1.0,
        help="sensor noise as a multiple of the default lab noise, 0 for none "
        "(default %(default)s)",
    )
    sim.add_argument(
        "--lab-export",
        action="store_true",
        help="also write the markers, force plates and belt speed a gait lab would have "
        "recorded, 1 mm marker noise, in each format colloc gait trial-from-lab reads: "
        "markers on the landmarks with plates at the markers' rate in lab-export.tsv, "
        "lab-export.trc with lab-export_grf.mot and its _grf.xml, and lab-export.c3d; and "
        "skin markers (thigh and shank clusters, pelvis markers) with plates at --plate-rate "
        "and a static trial in lab-skin.tsv, lab-skin.trc with lab-skin_grf.mot, lab-skin.c3d "
        "and lab-skin-static.tsv/.trc/.c3d (read them with --static)",
    )
    sim.add_argument(
        "--plate-rate",
        type=number,
        default=1000.0,
        help="with --lab-export: the skin-marker export's force-plate rate [Hz], a whole "
        "multiple of the 100 Hz record (default %(default)s)",
    )
    sim.add_argument(
        "--perturbation-scale",
        type=number,
        default=1.0,
        help="factor on the record's speed deviations (default %(default)s)",
    )

    _identify_parser(gs, default_url)
    from colloc.cli.lab import add_parser as lab_parser
    from colloc.cli.plan import add_parser as plan_parser
    from colloc.cli.smooth import add_parser as smooth_parser

    lab_parser(gs)
    smooth_parser(gs)
    plan_parser(gs)


def _identify_parser(gs: Any, default_url: str) -> None:
    """``colloc gait identify``: flags with the defaults of ``GaitIdentifySettings``."""
    from colloc.identify.gait import settings as gi

    d = gi.GaitIdentifySettings(trial=Path("."))
    idp = gs.add_parser(
        "identify",
        help="identify the gain-scheduled controller T*(phi) - K(phi) s of a walking trial by "
        "direct collocation; fit on its first part, validate on the rest",
    )
    idp.add_argument("trial", type=path_arg, help="trial directory (colloc.data.read_trial)")
    idp.add_argument(
        "--fit-fraction",
        type=number,
        default=d.fit_fraction,
        help="share of the trial to fit, split at the nearest right heel strike "
        "(default %(default)s)",
    )
    idp.add_argument(
        "--points",
        type=positive_int,
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
    idp.add_argument(
        "--structure",
        choices=gi.STRUCTURES,
        default=d.structure,
        help="gains identified: full (each torque on every fed-back state) or joint-isolated "
        "(each torque on its own joint's angle and rate) (default %(default)s)",
    )
    idp.add_argument(
        "--scheme",
        choices=gi.SCHEMES,
        default=d.scheme,
        help="collocation scheme of the fit's dynamics (default %(default)s; backward Euler is "
        "first order, kept for comparison)",
    )
    idp.add_argument(
        "--phase",
        choices=gi.PHASES,
        default=d.phase,
        help="phase: causal (reset at each right heel strike, then rising at the stride rate: "
        "what a real-time controller can know), linear between right heel strikes, or the "
        "trial's controller_phase column (default %(default)s)",
    )
    idp.add_argument(
        "--guess",
        choices=gi.GUESSES,
        default=d.guess,
        help="the controller's starting values: direct (least squares of the measured torques "
        "on the measured feedback) or zero (default %(default)s)",
    )
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
        "--start", type=number, default=d.start, help="fit window start, s (default 0)"
    )
    idp.add_argument(
        "--duration",
        type=number,
        default=None,
        help="fit window length, s (default: up to the split)",
    )
    idp.add_argument(
        "--segment-nodes",
        type=positive_int,
        default=d.segment_nodes,
        help="method closed-loop: nodes per condensing segment of the Gauss-Newton solver "
        "(default %(default)s)",
    )
    idp.add_argument(
        "--max-iter",
        type=int,
        default=d.max_iter,
        help="solver iterations at most (default %(default)s)",
    )
    idp.add_argument(
        "--process-noise",
        type=process_noise_arg,
        default=None,
        metavar="JOINT[,TRUNK]",
        help="estimate motor noise on each joint torque (std, N m) and residual forces on the "
        "trunk (std, N; default: JOINT) as disturbances: the maximum a posteriori fit, "
        "standard errors by the sandwich over strides (default: exact dynamics)",
    )
    idp.add_argument(
        "--instrument-lags",
        type=lags_arg,
        default=d.instrument_lags,
        metavar="LAGS",
        help="method smoother: fit the schedule by two-stage least squares with the fed-back "
        "states this many samples earlier as instruments, which removes the bias of motor noise "
        "that reaches them within a sample; 'none': ordinary least squares (default "
        + ",".join(str(v) for v in d.instrument_lags)
        + ")",
    )
    idp.add_argument(
        "--truth",
        type=path_arg,
        default=None,
        metavar="SIMULATED_TRIAL",
        help="take the true controller (and its P, feedback and phase law) from this trial's "
        "metadata: a lab export of a simulated walk scored like the walk itself",
    )
    add_smoothing_options(idp, "method smoother: ")
    idp.add_argument(
        "--design-bound",
        choices=gi.DESIGN_BOUNDS,
        default=d.design_bound,
        help="method smoother: 'full' also computes the whole design's Cramer-Rao bound, the "
        "states unknown and the motor noise a residual of the closed loop (on a trial's "
        "angles; about 60 ms per sample on one core), beside the schedule's own with the "
        "states known (default %(default)s)",
    )
    idp.add_argument(
        "--window-strides",
        type=positive_int,
        default=d.window_strides,
        metavar="N",
        help="method smoother: smooth in windows of N whole strides sharing the controller "
        "(memory follows the window; default: one window)",
    )
    idp.add_argument(
        "--workers",
        type=worker_count,
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
    idp.add_argument(
        "--seed",
        type=positive_int,
        default=d.seed,
        help="seeds any random draw (none in the default settings; recorded with the run; "
        "default %(default)s)",
    )
    idp.add_argument("--db", default=default_url, help="results database URL")
    idp.add_argument("--no-store", action="store_true", help="do not store the run")
    idp.add_argument("--db-allow-other-tables", action="store_true", help=ALLOW_OTHER_TABLES_HELP)
    idp.add_argument("--out", type=path_arg, default=Path("gait-identification"), help="figures")
    idp.add_argument("--no-plots", action="store_true", help="do not draw figures")
    idp.add_argument("--json", type=path_arg, default=None, help="write a summary here")


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
    from colloc.identify.gait.settings import GaitIdentifySettings

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
        truth=args.truth,
        smooth_from=args.smooth_from,
        noise_levels=args.noise_levels,
        fit_places=args.fit_places,
        design_bound=args.design_bound,
    )
    outputs = output_problems(args.json, None if args.no_plots else args.out)
    spread = []
    if (args.workers is not None or args.scheduler is not None) and args.window_strides is None:
        spread.append(
            "--workers/--scheduler: expected --window-strides N (the stride windows are what "
            "the workers smooth), found none"
        )
    if args.workers is not None and args.scheduler is not None:
        spread.append(
            "--workers/--scheduler: expected one of them (local workers, or a running "
            f"cluster's), found both: --workers {args.workers} --scheduler {args.scheduler}"
        )
    return settings, settings.problems(require_trial=require_trial) + outputs + spread


def _gait_identify(args: argparse.Namespace) -> int:
    settings, problems = gait_identify_checks(args)
    if report_problems("colloc gait identify", problems):
        return 2
    from colloc.identify.gait.outputs import (
        gait_record,
        gait_run_id,
        gait_summary,
        save_gait_plots,
    )
    from colloc.identify.gait.workflow import identify_gait
    from colloc.identify.summaries import write_json_atomic

    store = open_store(args)
    start = time.perf_counter()
    progress = step_printer(start)
    if args.workers is not None or args.scheduler is not None:
        from colloc.batch.cluster import (
            SchedulerError,
            WorkersLostError,
            client_map,
            dask_client,
        )

        progress("workers", f"Dask: {args.scheduler or f'{args.workers} local workers'}")
        from colloc.numeric.memory import peak_rss_mb

        try:
            with dask_client(args.workers, args.scheduler) as client:
                run = identify_gait(
                    settings, progress, print_iteration, map_windows=client_map(client)
                )
                # each worker's peak with its forked solvers': what the windows cost in memory
                worker_peaks = [float(v) for v in client.run(peak_rss_mb).values()]
        except (SchedulerError, WorkersLostError) as error:
            report_problems("colloc gait identify", [f"--{error}"])
            return 2
    else:
        run = identify_gait(settings, progress=progress, iterations=print_iteration)
        worker_peaks = []
    run_id = gait_run_id(run)
    summary = gait_summary(run, run_id) | {"worker_peak_rss_mb": worker_peaks}
    print(
        f"\nsolver: {run.solver['status']} after {run.solver['iterations']} iterations "
        f"(objective {run.solver['objective']:.6g}, largest defect "
        f"{run.solver['constraint_violation']:.2e})"
    )
    for key in (
        "K_relative_error",
        "Tstar_relative_error",
        "direct_K_relative_error",
        "K_relative_bound_states_known",
        "K_relative_bound_full_design",
    ):
        if summary.get(key) is not None:
            print(f"{key}: {summary[key]:.2%}")
    if summary["fraction_within_3se"] is not None:
        print(f"entries within 3 SE of the truth: {summary['fraction_within_3se']:.1%}")
    vaf = run.validation["torque_vaf"]
    print(f"held-out torque VAF ({' / '.join(vaf)}):")
    for joint in vaf["collocation"]:
        print(f"  {joint:<12}" + "".join(f" {vaf[name][joint]:8.4f}" for name in vaf))
    print(f"held-out forward simulation: {_walk_line(run.validation)}")
    for name, label in (("direct_walk", "the direct fit"), ("truth_walk", "the true controller")):
        if run.validation.get(name):
            print(f"  under {label}: {_walk_line(run.validation[name])}")
    against = run.validation.get("against_truth_walk") or {}
    if against.get("angle_rms_deg"):
        by_sample, by_phase = against["angle_rms_deg"], against.get("angle_rms_phase_deg") or {}
        print(
            f"  identified walk against the true controller's over {against['seconds']:.1f} s: "
            f"{_span(by_sample)} deg RMS sample by sample"
            + (f", {_span(by_phase)} deg between mean strides" if by_phase else "")
        )
    workers_said = (
        f", workers {', '.join(f'{v:.0f}' for v in worker_peaks)} MB" if worker_peaks else ""
    )
    print(f"peak memory: {run.peak_rss_mb:.0f} MB here{workers_said}")
    for note in run.notes:
        print(f"note: {note}")
    stored = True
    if store is not None:
        progress("store", f"run {run_id[:12]} -> {args.db}")
        stored = store_or_keep("colloc gait identify", store, gait_record(run, run_id), args)
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
        line += f"; joint angles {_span(rms_deg)} deg RMS from the measured"
    by_phase = walk.get("angle_rms_phase_deg") or {}
    if by_phase:
        line += f" ({_span(by_phase)} between mean strides)"
    return line


def _span(values: dict[str, float]) -> str:
    """``lowest-highest`` of a joint -> value mapping, to a tenth."""
    return f"{min(values.values()):.1f}-{max(values.values()):.1f}"


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
        plate_rate=args.plate_rate if args.lab_export else None,
    )
    too_big = settings.too_big(memory_bytes())
    return settings, settings.problems() + too_big + output_problems(None, args.out)


def _gait_simulate(args: argparse.Namespace) -> int:
    from colloc.gait.settings import LONG_SIMULATION_SECONDS
    from colloc.gait.workflow import simulate_trial

    settings, problems = gait_simulate_checks(args)
    if report_problems("colloc gait simulate", problems):
        return 2
    needs = settings.estimated_needs()
    if needs["seconds"] > LONG_SIMULATION_SECONDS:
        print(
            f"this will take a while: about {needs['seconds'] / 60:.0f} min by a rough "
            f"estimate ({settings.duration:g} s of walking, {needs['samples']:.3g} samples)",
            flush=True,
        )
    start = time.perf_counter()
    result = simulate_trial(settings, progress=step_printer(start))
    if args.lab_export:
        from colloc.lab import lab_export_from_record
        from colloc.lab.synthetic_skin import skin_lab_from_record
        from colloc.lab.writers import write_lab_files, write_skin_lab
        from colloc.models.gait2d_params import load_parameters

        params = load_parameters(settings.body_mass, settings.height)
        export = lab_export_from_record(result.record, params, seed=settings.seed)
        for role, path in write_lab_files(export, result.out).items():
            result.files[f"lab export ({role})"] = path
        skin = skin_lab_from_record(result.record, params, seed=settings.seed)
        for role, path in write_skin_lab(skin, result.out).items():
            result.files[f"lab export, skin markers ({role})"] = path
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


def _gait_trial_from_lab(args: argparse.Namespace) -> int:
    from colloc.cli.lab import run

    return run(args)


def _gait_smooth(args: argparse.Namespace) -> int:
    from colloc.cli.smooth import run

    return run(args)


def _gait_plan(args: argparse.Namespace) -> int:
    from colloc.cli.plan import run

    return run(args)


GAIT_COMMANDS = {
    "simulate": _gait_simulate,
    "identify": _gait_identify,
    "trial-from-lab": _gait_trial_from_lab,
    "smooth": _gait_smooth,
    "plan": _gait_plan,
}


def run(args: argparse.Namespace) -> int:
    """Run ``colloc gait ...``; the exit status."""
    return GAIT_COMMANDS[args.gait_command](args)
