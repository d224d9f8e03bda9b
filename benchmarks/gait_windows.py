"""Benchmark the default gait identification by fit length, stride windows and Dask workers:
wall time per step, peak memory (this process and each worker's), problem size, the errors of
``K`` and ``T*`` against the trial's controller with their bounds, the share of entries within
3 SE, the held-out torque VAF and whether the held-out part is walked (its strides and
joint-angle RMS), and each stride window's nodes, iterations, wall time and worker process
(``windows``: the sum per process against the smoothing step's wall time shows how evenly
the workers were loaded).

    python benchmarks/gait_windows.py --trial DIR --duration 60 120 240 360 \
        [--window-strides 20] [--workers 0 1 2] [--repeat 3] [--no-simulate] \
        [--fit-fraction 0.75]

``--workers 0`` smooths the windows one after another in the identifying process; ``N >= 1``
on a local Dask cluster of N one-thread worker processes (the cluster's start-up is inside the
``smooth`` step's time, as a user meets it). Each case runs in its own process, so its peak
RSS is its own, and appends one JSON record to ``benchmarks/results/gait_windows.json``. Quote
medians over ``--repeat``: the machine is shared.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

from results_file import append_record

from colloc.numeric.memory import peak_rss_mb

RESULTS = Path(__file__).parent / "results" / "gait_windows.json"


def one_case(
    trial: Path,
    duration: float,
    window_strides: int | None,
    workers: int,
    simulate: bool,
    fit_fraction: float = 0.75,
) -> dict:
    """One identification here; its summary with the workers' peak memory."""
    from colloc.identify.gait.outputs import gait_run_id, gait_summary
    from colloc.identify.gait.settings import GaitIdentifySettings
    from colloc.identify.gait.workflow import identify_gait

    settings = GaitIdentifySettings(
        trial=trial,
        duration=duration,
        window_strides=window_strides,
        simulate_validation=simulate,
        fit_fraction=fit_fraction,
    )
    worker_rss: list[float] = []
    if workers:
        from colloc.batch.cluster import client_map, dask_client

        with dask_client(workers) as client:
            run = identify_gait(settings, map_windows=client_map(client))
            # each worker's own peak and its forked solvers' (colloc.numeric.memory)
            worker_rss = list(client.run(peak_rss_mb).values())
    else:
        run = identify_gait(settings)
    summary = gait_summary(run, gait_run_id(run))
    keep = (
        "times", "problem", "status", "iterations", "K_relative_error",
        "Tstar_relative_error", "direct_K_relative_error", "direct_Tstar_relative_error",
        "K_relative_bound", "Tstar_relative_bound", "fraction_within_3se", "peak_rss_mb",
        "windows",
    )  # fmt: skip
    record = {key: summary.get(key) for key in keep}
    # per iteration: the smoothing step's wall time over the windows' IPOPT iterations
    record["smooth_seconds_per_iteration"] = summary["times"]["smooth"] / max(
        summary["iterations"], 1
    )
    validation = summary.get("validation", {})
    record |= {
        "trial": str(trial),
        "duration": duration,
        "window_strides": window_strides,
        "workers": workers,
        "worker_peak_rss_mb": worker_rss,
        "torque_vaf": validation.get("torque_vaf"),
        "walks": validation.get("walks"),
        "strides": validation.get("strides"),
        "measured_strides": validation.get("measured_strides"),
        "angle_rms": validation.get("angle_rms"),
        "direct_walks": (validation.get("direct_walk") or {}).get("walks"),
    }
    return record


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--trial", type=Path, required=True)
    parser.add_argument("--duration", type=float, nargs="+", default=[60.0])
    parser.add_argument("--window-strides", type=int, default=None)
    parser.add_argument("--workers", type=int, nargs="+", default=[0])
    parser.add_argument("--fit-fraction", type=float, default=0.75)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--no-simulate", action="store_true")
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        record = one_case(
            args.trial,
            args.duration[0],
            args.window_strides,
            args.workers[0],
            not args.no_simulate,
            args.fit_fraction,
        )
        print(json.dumps(record))
        return
    for duration in args.duration:
        for workers in args.workers:
            for repeat in range(args.repeat):
                command = [
                    sys.executable, __file__, "--child", "--trial", str(args.trial),
                    "--duration", str(duration), "--workers", str(workers),
                    "--fit-fraction", str(args.fit_fraction),
                ]  # fmt: skip
                if args.window_strides is not None:
                    command += ["--window-strides", str(args.window_strides)]
                if args.no_simulate:
                    command.append("--no-simulate")
                done = subprocess.run(command, capture_output=True, text=True, check=False)
                if done.returncode != 0:
                    record = {
                        "duration": duration,
                        "workers": workers,
                        "error": done.stderr[-2000:],
                    }
                else:
                    record = json.loads(done.stdout.strip().splitlines()[-1])
                record["repeat"] = repeat
                append_record(args.out, record)
                times = record.get("times") or {}
                print(
                    f"{duration:5.0f} s, workers {workers}, #{repeat}: smooth "
                    f"{times.get('smooth', float('nan')):.0f} s, total "
                    f"{sum(times.values()) if times else float('nan'):.0f} s, K "
                    f"{record.get('K_relative_error')}, bound {record.get('K_relative_bound')}, "
                    f"peak {record.get('peak_rss_mb')} MB + workers "
                    f"{record.get('worker_peak_rss_mb')}",
                    flush=True,
                )


if __name__ == "__main__":
    main()
