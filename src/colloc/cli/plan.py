"""``colloc gait plan``: how long to record for a target bound on the gains, from a pilot walk."""

from __future__ import annotations

import argparse
from typing import Any

from colloc.cli.common import number, output_problems, path_arg, report_problems


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
        help="a trial that records its controller, e.g. colloc gait simulate's (its walk is "
        "the design)",
    )
    pp.add_argument(
        "--target-k",
        type=number,
        default=None,
        help="relative bound of K wanted, e.g. 0.2 for 20 %%",
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
    if args.target_k is None and args.length is None:
        problems.append("--target-k / --length: expected at least one, found neither")
    if not args.pilot.is_dir():
        problems.append(f"pilot: expected a trial directory, found {str(args.pilot)!r}")
    if report_problems("colloc gait plan", problems):
        return 2
    from colloc.gait.outputs import write_json
    from colloc.identify.gait_plan import plan_record

    try:
        plan = plan_record(
            args.pilot,
            target_k=args.target_k,
            record_seconds=args.length,
            noise_std=args.torque_noise,
            fit_fraction=args.fit_fraction,
        )
    except ValueError as error:
        report_problems("colloc gait plan", [str(error)])
        return 2
    for length, bound in zip(plan.fitted_seconds, plan.K_bound, strict=True):
        print(f"pilot, {length:.0f} s fitted: K bound {100 * bound:.1f} %")
    print(f"law: K bound = {plan.K_coefficient:.3g} / sqrt(fitted seconds)")
    if plan.needed_record_seconds is not None and plan.target_K is not None:
        print(
            f"for a K bound of {100 * plan.target_K:g} %: fit {plan.needed_fit_seconds:.0f} s, "
            f"record {plan.needed_record_seconds:.0f} s (fit fraction {plan.fit_fraction:g})"
        )
    if plan.K_bound_at_length is not None:
        print(f"a {plan.record_seconds:g} s record: K bound {100 * plan.K_bound_at_length:.1f} %")
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
