"""``colloc gait plan``: how long to record for a target bound on the gains, from a pilot walk
(the user's, or one simulated for the subject, speed, schedule and noise planned for)."""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import tempfile
import time
from pathlib import Path
from typing import Any

from colloc.cli.common import (
    number,
    output_problems,
    path_arg,
    positive_int,
    report_problems,
    step_printer,
)

#: Options that describe the pilot to simulate when none is given: the parsed option's
#: destination, the simulation setting it sets (GaitSimulationSettings) and its flag.
PILOT_OPTIONS = (
    ("speed", "speed", "--speed"),
    ("mass", "body_mass", "--mass"),
    ("height", "height", "--height"),
    ("points", "num_points", "--points"),
    ("motor_noise", "motor_noise", "--motor-noise"),
    ("noise", "noise", "--noise"),
    ("seed", "seed", "--seed"),
    ("pilot_seconds", "duration", "--pilot-seconds"),
)


def add_parser(gs: Any) -> None:
    """``colloc gait plan PILOT --target-k 0.2 | --length S``."""
    pp = gs.add_parser(
        "plan",
        help="the record length a target Cramér–Rao bound on K needs (or the bound a length "
        "reaches), from a pilot trial of the subject, speed, schedule and noise planned for",
    )
    pp.add_argument(
        "pilot",
        type=path_arg,
        nargs="?",
        default=None,
        help="a trial that records its controller, e.g. colloc gait simulate's (its walk is "
        "the design); without it a pilot is simulated from the options below",
    )
    sim = pp.add_argument_group(
        "the pilot simulated when none is given (the study planned for; defaults as colloc "
        "gait simulate's)"
    )
    sim.add_argument("--speed", type=number, default=None, help="mean belt speed [m/s]")
    sim.add_argument("--mass", type=number, default=None, help="body mass [kg]")
    sim.add_argument("--height", type=number, default=None, help="body height [m]")
    sim.add_argument(
        "--points", type=positive_int, default=None, help="schedule points P of the controller"
    )
    sim.add_argument(
        "--motor-noise",
        type=number,
        default=None,
        help="motor noise on each torque [N m] (default 3, real walking's; without it the "
        "fit's bars are too narrow, docs/gait-guide.md)",
    )
    sim.add_argument(
        "--noise",
        type=number,
        default=None,
        help="the lab's sensor noise as a multiple of the default lab noise",
    )
    sim.add_argument(
        "--pilot-seconds", type=number, default=None, help="length of the pilot walk [s] (60)"
    )
    sim.add_argument("--seed", type=int, default=None, help="seed of the pilot (0)")
    pp.add_argument(
        "--target-k",
        type=number,
        default=None,
        help="relative bound of K wanted, e.g. 0.2 for 20 %%",
    )
    pp.add_argument(
        "--target-tstar",
        type=number,
        default=None,
        help="relative bound of T* wanted too (the record meets both targets)",
    )
    pp.add_argument(
        "--length", type=number, default=None, help="a record length [s] to give the bound of"
    )
    pp.add_argument(
        "--torque-noise",
        type=number,
        default=None,
        help="the torque equations' noise [N m] (default: the pilot's torque and motor noise)",
    )
    pp.add_argument(
        "--fit-fraction",
        type=number,
        default=0.75,
        help="share of a record fitted, the rest validated (default %(default)s)",
    )
    pp.add_argument("--json", type=path_arg, default=None, help="write the plan as JSON here")
    pp.add_argument("--out", type=path_arg, default=None, help="folder for the figure")


def run(args: argparse.Namespace) -> int:
    """Run ``colloc gait plan``; 0, or 2 on bad input."""
    problems = output_problems(args.json, args.out)
    if args.target_k is None and args.target_tstar is None and args.length is None:
        problems.append("--target-k / --target-tstar / --length: expected at least one, found none")
    given = [flag for dest, _, flag in PILOT_OPTIONS if getattr(args, dest) is not None]
    simulation = None
    if args.pilot is not None:
        if not args.pilot.is_dir():
            problems.append(f"pilot: expected a trial directory, found {str(args.pilot)!r}")
        if given:
            problems.append(
                f"{', '.join(given)}: these describe a pilot to simulate, but the pilot "
                f"{str(args.pilot)!r} was given; give one or the other"
            )
    else:
        simulation, more = _pilot_settings(args)
        problems += more
    if report_problems("colloc gait plan", problems):
        return 2
    from colloc.gait.outputs import write_json
    from colloc.identify.gait.plan import plan_for_subject, plan_record

    options = {
        "target_k": args.target_k,
        "record_seconds": args.length,
        "noise_std": args.torque_noise,
        "fit_fraction": args.fit_fraction,
        "target_tstar": args.target_tstar,
    }
    # a pilot simulated without --out lives in a temporary folder for the plan's time
    scratch_needed = simulation is not None and args.out is None
    temporary = tempfile.TemporaryDirectory(prefix="colloc-pilot-") if scratch_needed else None
    with temporary or contextlib.nullcontext() as scratch:
        try:
            if simulation is None:
                print("smoothing the pilot as identify would (its design)", flush=True)
                plan = plan_record(
                    args.pilot, **options, progress=step_printer(time.perf_counter())
                )
            else:
                # the pilot is kept beside the plan when it has a folder, for plans to come
                where = args.out / "pilot" if scratch is None else Path(scratch) / "pilot"
                simulation = dataclasses.replace(simulation, out=where)
                print(f"simulating a {simulation.duration:g} s pilot walk -> {where}", flush=True)
                plan = plan_for_subject(
                    simulation, **options, progress=step_printer(time.perf_counter())
                )
        except ValueError as error:
            report_problems("colloc gait plan", [str(error)])
            return 2
    if simulation is not None and args.out is None:
        plan.notes.append(
            "the pilot was simulated in a temporary folder, now removed (--out keeps it)"
        )
    for length, bound in zip(plan.fitted_seconds, plan.K_bound, strict=True):
        print(f"pilot, {length:.0f} s fitted: K bound {100 * bound:.1f} %")
    print(f"law: K bound = {plan.K_coefficient:.3g} / sqrt(fitted seconds)")
    if plan.needed_record_seconds is not None:
        wanted = " and ".join(
            f"a {name} bound of {100 * target:g} %"
            for name, target in (("K", plan.target_K), ("T*", plan.target_Tstar))
            if target is not None
        )
        print(
            f"for {wanted}: fit {plan.needed_fit_seconds:.0f} s, "
            f"record {plan.needed_record_seconds:.0f} s (fit fraction {plan.fit_fraction:g})"
        )
    if plan.K_bound_at_length is not None and plan.Tstar_bound_at_length is not None:
        print(
            f"a {plan.record_seconds:g} s record: K bound {100 * plan.K_bound_at_length:.1f} %, "
            f"T* bound {100 * plan.Tstar_bound_at_length:.1f} %"
        )
    for note in plan.notes:
        print(f"note: {note}")
    summary = plan.to_dict()
    if args.out is not None:
        from colloc.plot.common import save_figure
        from colloc.plot.gait_identification import plot_bound_against_length

        args.out.mkdir(parents=True, exist_ok=True)
        fig = plot_bound_against_length(
            plan.fitted_seconds, plan.K_bound, plan.K_coefficient, plan.target_K,
            plan.needed_fit_seconds,
        )  # fmt: skip
        summary["figures"] = [str(p) for p in save_figure(fig, args.out, "bound_against_length")]
    if args.json is not None:
        write_json(summary, args.json)
    return 0


def _pilot_settings(args: argparse.Namespace) -> tuple[Any, list[str]]:
    """The pilot's simulation settings from the options given (the rest at ``colloc gait
    simulate``'s defaults, the length at the plan's), and their problems."""
    from colloc.gait.settings import GaitSimulationSettings
    from colloc.identify.gait.plan import PILOT_MOTOR_NOISE, PILOT_SECONDS

    # the plan's own defaults for the pilot's length and motor noise, the rest simulate's
    chosen = {"duration": PILOT_SECONDS, "motor_noise": PILOT_MOTOR_NOISE} | {
        field: getattr(args, dest)
        for dest, field, _ in PILOT_OPTIONS
        if getattr(args, dest) is not None
    }
    settings = GaitSimulationSettings(**chosen)
    flags = {field: flag for _, field, flag in PILOT_OPTIONS}
    problems = []
    for problem in settings.problems():
        name = problem.split(":", 1)[0]
        problems.append(problem.replace(name, flags.get(name, name), 1))
    return settings, problems
