"""``colloc gait smooth``: a trial's dynamically consistent motion, joint moments and residual
forces, without identifying a controller."""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from colloc.cli.common import (
    add_smoothing_options,
    number,
    output_problems,
    path_arg,
    positive_int,
    report_problems,
    step_printer,
)

#: What ``gait smooth`` writes in ``--out``.
TABLE_FILE = "smoothed.csv"
SUMMARY_FILE = "smooth.json"
FIGURES = ("smoothed_angles", "smoothed_torques")


def add_parser(gs: Any) -> None:
    """``colloc gait smooth TRIAL --out DIR``."""
    sp = gs.add_parser(
        "smooth",
        help="the motion of gait2d closest to a trial (free joint torques): dynamically "
        "consistent angles, rates and moments and the residual forces, as a table, figures "
        "and a JSON",
    )
    sp.add_argument("trial", type=path_arg, help="trial directory (colloc.data.read_trial)")
    sp.add_argument(
        "--out", type=path_arg, required=True, help=f"folder for {TABLE_FILE}, {SUMMARY_FILE}"
    )
    sp.add_argument(
        "--start", type=number, default=0.0, help="seconds from the record's start (default 0)"
    )
    sp.add_argument(
        "--duration", type=number, default=None, help="seconds smoothed (default: to the end)"
    )
    sp.add_argument(
        "--window-strides",
        type=positive_int,
        default=None,
        metavar="N",
        help="smooth in windows of N whole strides (memory follows the window; default one)",
    )
    add_smoothing_options(sp)
    sp.add_argument(
        "--overwrite",
        action="store_true",
        help=f"replace {TABLE_FILE} and {SUMMARY_FILE} already in --out",
    )
    sp.add_argument("--no-plots", action="store_true", help="write no figures")


def smooth_checks(args: argparse.Namespace) -> list[str]:
    """Every problem found before any work."""
    problems = output_problems(None, args.out)
    if not args.trial.is_dir():
        problems.append(f"trial: expected a trial directory, found {str(args.trial)!r}")
    if not args.overwrite:
        kept = [name for name in (TABLE_FILE, SUMMARY_FILE) if (args.out / name).exists()]
        if kept:
            problems.append(
                f"--out {str(args.out)!r}: already holds {kept}; give --overwrite to replace "
                "them (nothing else in the folder is touched)"
            )
    if args.start < 0:
        problems.append(f"--start: expected seconds >= 0, found {args.start}")
    if args.duration is not None and args.duration <= 0:
        problems.append(f"--duration: expected seconds > 0, found {args.duration}")
    return problems


def run(args: argparse.Namespace) -> int:
    """Run ``colloc gait smooth``; exit status 0, 1 if a window did not converge, 2 on bad
    input."""
    if report_problems("colloc gait smooth", smooth_checks(args)):
        return 2
    from colloc.gait.outputs import write_json
    from colloc.identify.gait.smooth import smooth_summary, smooth_trial, smoothed_table

    start = time.perf_counter()
    try:
        result = smooth_trial(
            args.trial,
            start=args.start,
            duration=args.duration,
            window_strides=args.window_strides,
            smooth_from=args.smooth_from,
            noise_levels=args.noise_levels,
            fit_places=args.fit_places,
            progress=step_printer(start),
        )
    except (ValueError, FileNotFoundError) as error:
        report_problems("colloc gait smooth", [str(error)])
        return 2
    table = smoothed_table(result)
    summary = smooth_summary(result, table)
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    temporary = out / f".{TABLE_FILE}.part"
    table.to_csv(temporary, index=False)
    temporary.replace(out / TABLE_FILE)
    if not args.no_plots:
        summary["figures"] = _figures(result, table, out)
    write_json(summary, out / SUMMARY_FILE)
    rms = summary["angle_rms_deg"]
    print(f"joint angles from the record: {min(rms.values()):.2f}-{max(rms.values()):.2f} deg RMS")
    if summary["torque_rms_from_record"]:
        moments = summary["torque_rms_from_record"].values()
        print(f"joint moments from the record's: {min(moments):.1f}-{max(moments):.1f} N m RMS")
    residual = summary["residual_rms"]
    print(
        "residual forces RMS: "
        + ", ".join(f"{name} {value:.3g}" for name, value in residual.items())
        + " (N, N, N m)"
    )
    for note in summary["notes"]:
        print(f"note: {note}")
    print(f"table -> {out / TABLE_FILE}; summary -> {out / SUMMARY_FILE}")
    return 0 if result.success else 1


def _figures(result: Any, table: Any, out: Path) -> list[str]:
    """The smoothed joint angles and moments against the record's, each as PNG and SVG."""
    import numpy as np

    from colloc.data.columns import JOINT_ANGLE_COLUMNS, TORQUE_COLUMNS
    from colloc.identify.gait.estimate import JOINT_NAMES
    from colloc.plot.common import save_figure
    from colloc.plot.gait_identification import plot_signal_comparison

    measured = result.trial.signals.iloc[result.rows]
    times = result.trial.time[result.rows]
    t = table["time"].to_numpy()
    paths = []
    for stem, columns, title, unit, scale in (
        (
            "smoothed_angles",
            JOINT_ANGLE_COLUMNS,
            "joint angles: record and smoother",
            "deg",
            180 / np.pi,
        ),
        ("smoothed_torques", TORQUE_COLUMNS, "joint moments: record and smoother", "N m", 1.0),
    ):
        if not set(columns) <= set(measured.columns):
            continue
        record = np.column_stack([np.interp(t, times, measured[c].to_numpy()) for c in columns])
        fitted = table[list(columns)].to_numpy()
        fig = plot_signal_comparison(
            t, scale * record, scale * fitted, JOINT_NAMES, title, "smoother", unit
        )
        paths += [str(p) for p in save_figure(fig, out, stem)]
    return paths
