"""Benchmark the smoother that tracks a lab's raw markers and plates
(:func:`colloc.identify.gait.markers.marker_smoother`): per second of record, the wall time
split into set-up (model and data), build (the collocation problems) and solve (IPOPT, every
stage), the IPOPT iterations and the peak memory; with ``--truth`` (the simulated trial the
lab export was made from) the smoothed angles and torques against it, beside the lab's 6 Hz
inverse kinematics and dynamics.

    colloc gait simulate --duration 130 --motor-noise 3 --lab-export --out SIM
    colloc gait trial-from-lab SIM/lab-export.tsv --mass 75 --height 1.8 \
        --belt-speed LeftBeltSpeed --out LAB
    python benchmarks/gait_marker_smoother.py --trial LAB --truth SIM/trial \
        --duration 30 60 120 [--no-plates] [--window-strides 4] [--repeat 3]

Each case runs in a fresh process (the peak RSS is its own) and appends one JSON record to
``benchmarks/results/gait_marker_smoother.json``. Quote medians over ``--repeat``: the
machine is shared.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

from results_file import append_record, peak_rss_mb

RESULTS = Path(__file__).parent / "results" / "gait_marker_smoother.json"


def one_case(
    trial_dir: Path,
    truth_dir: Path | None,
    start: float,
    duration: float,
    plates: bool,
    window_strides: int | None = None,
) -> dict:
    import numpy as np

    from colloc.data.columns import JOINT_ANGLE_COLUMNS, TORQUE_COLUMNS
    from colloc.data.split import stride_windows
    from colloc.data.trial import read_trial
    from colloc.gait.orbit import GaitDynamics
    from colloc.identify.gait.markers import marker_smoother, tracking_fit
    from colloc.models.gait2d_params import load_parameters

    clock = time.perf_counter()
    trial = read_trial(trial_dir)
    meta = trial.metadata
    t = trial.time - trial.time[0]
    rows = np.flatnonzero((t >= start - 1e-9) & (t <= start + duration + 1e-9))
    dynamics = GaitDynamics.build(load_parameters(float(meta["body_mass"]), float(meta["height"])))
    setup = time.perf_counter() - clock
    windows = (
        [(0, rows.size)]
        if window_strides is None
        else stride_windows(trial.time[rows], trial.right_heel_strikes, window_strides)
    )
    solve = build = 0.0
    iterations, successes, fits, stages = 0, [], [], []
    failures: list[dict[str, object]] = []
    times, states, torques = [], [], []
    for first, stop in windows:
        clock = time.perf_counter()
        smoother, facts = marker_smoother(dynamics, trial, rows[first:stop], use_plates=plates)
        setup += time.perf_counter() - clock
        try:
            result = smoother.run()
        except (RuntimeError, ValueError) as error:  # a window that fails is recorded, not fatal
            failures.append({"first": int(first), "stop": int(stop), "error": str(error)[:500]})
            successes.append(False)
            continue
        window_solve = sum(s.seconds for s in result.stages)
        solve += window_solve
        build += result.seconds - window_solve
        iterations += int(sum(s.iterations for s in result.stages))
        successes.append(bool(result.stages[-1].success))
        stages.append([s.describe() for s in result.stages])
        fits.append(tracking_fit(result.problem, result.z))
        times.append(result.times)
        states.append(result.states)
        torques.append(result.torques)
    record = {
        "trial": str(trial_dir),
        "start": start,
        "duration": float(trial.time[rows[-1]] - trial.time[rows[0]]),
        "plates": plates,
        "window_strides": window_strides,
        "windows": len(windows),
        "setup_seconds": setup,
        "build_seconds": build,
        "solve_seconds": solve,
        "seconds_per_record_second": (setup + build + solve) / duration,
        "iterations": iterations,
        "stages": stages,
        "success": all(successes),
        "failed_windows": failures,
        "peak_rss_mb": peak_rss_mb(),
        "fit": fits,
        "noise": facts["noise"],
    }
    if truth_dir is not None and times:
        truth = read_trial(truth_dir)
        node_times = np.concatenate(times)

        def at_nodes(columns: list[str]) -> np.ndarray:
            return np.column_stack(
                [np.interp(node_times, truth.time, truth.signals[c]) for c in columns]
            )

        true_angles = at_nodes(list(JOINT_ANGLE_COLUMNS))
        true_torques = at_nodes(list(TORQUE_COLUMNS))
        lab = trial.signals.iloc[rows]

        def rms(a: np.ndarray, b: np.ndarray) -> list[float]:
            return np.sqrt(np.mean((a - b) ** 2, axis=0)).tolist()

        lab_angles = np.column_stack(
            [np.interp(node_times, trial.time[rows], lab[c]) for c in JOINT_ANGLE_COLUMNS]
        )
        lab_torques = np.column_stack(
            [np.interp(node_times, trial.time[rows], lab[c]) for c in TORQUE_COLUMNS]
        )
        record["angle_rms_deg"] = {
            "marker_smoother": np.degrees(
                rms(np.concatenate(states)[:, 3:9], true_angles)
            ).tolist(),
            "inverse_kinematics_6hz": np.degrees(rms(lab_angles, true_angles)).tolist(),
        }
        record["torque_rms_nm"] = {
            "marker_smoother": rms(np.concatenate(torques), true_torques),
            "inverse_dynamics_6hz": rms(lab_torques, true_torques),
        }
        record["truth_note"] = (
            "the truth trial's angles carry its own measurement noise (0.25 deg) and its "
            "torques 1 N m: read the errors as an upper bound"
            if truth.metadata.get("noise")
            else "noise-free truth"
        )
    return record


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--trial", type=Path, required=True, help="a lab trial (trial-from-lab)")
    parser.add_argument("--truth", type=Path, help="the simulated trial it was recorded from")
    parser.add_argument("--start", type=float, default=0.0)
    parser.add_argument("--duration", type=float, nargs="+", default=[30.0])
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--no-plates", action="store_true", help="track the markers alone")
    parser.add_argument(
        "--window-strides",
        type=int,
        default=None,
        help="smooth in windows of N whole strides, as gait identify --window-strides",
    )
    parser.add_argument("--one", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        record = one_case(
            args.trial,
            args.truth,
            args.start,
            args.duration[0],
            not args.no_plates,
            args.window_strides,
        )
        print(json.dumps(record))
        return
    for duration in args.duration:
        for _ in range(args.repeat):
            command = [sys.executable, __file__, "--one", "--trial", str(args.trial)]
            command += ["--start", str(args.start), "--duration", str(duration)]
            if args.truth:
                command += ["--truth", str(args.truth)]
            if args.no_plates:
                command.append("--no-plates")
            if args.window_strides is not None:
                command += ["--window-strides", str(args.window_strides)]
            out = subprocess.run(command, capture_output=True, text=True)
            if out.returncode != 0:
                print(out.stderr[-3000:], file=sys.stderr)
                out.check_returncode()
            record = json.loads(out.stdout.strip().splitlines()[-1])
            append_record(RESULTS, record)
            print(
                f"{duration:5.0f} s: {record['seconds_per_record_second']:.2f} s per second of "
                f"record, {record['iterations']} iterations, {record['peak_rss_mb']:.0f} MB"
            )


if __name__ == "__main__":
    main()
