"""End-to-end cost of ``colloc gait simulate`` (colloc.gait.workflow.simulate_trial).

Runs the workflow once with the given settings and reports the wall time of each step
(cycle, settle, design, simulate, trial, figures, animation), the design's Floquet spectral
radius and tuning statistics, the simulated seconds per wall second of the closed-loop
simulation, the stride count, whether the walker fell, and the peak resident memory. A
design whose closed loop is not stable is refused by the workflow; that is reported as
``refused: <message>`` with no simulation figures.

Usage: python benchmarks/gait_simulate.py [--duration 480] [--speed 1.2] [--points 200]
       [--feedback all|joints+trunk|joints] [--out benchmarks/results/gait_simulate.json]
       [--trial-dir /tmp/gait-sim-bench]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

from results_file import peak_rss_mb


def run(duration: float, speed: float, points: int, feedback: str, trial_dir: Path) -> dict:
    from colloc.gait.workflow import (
        GaitSimulationSettings,
        UnstableControllerError,
        simulate_trial,
    )

    settings = GaitSimulationSettings(
        duration=duration, speed=speed, num_points=points, feedback=feedback, out=trial_dir
    )
    steps: dict[str, float] = {}
    last = [time.perf_counter(), None]

    def progress(step: str, detail: str) -> None:
        now = time.perf_counter()
        if last[1] is not None:
            steps[str(last[1])] = now - float(last[0])
        last[:] = [now, step]
        print(f"[{step}] {detail}", flush=True)

    start = time.perf_counter()
    out: dict = {
        "settings": {
            "duration": duration,
            "speed": speed,
            "points": points,
            "feedback": feedback,
        },
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version()},
    }
    try:
        result = simulate_trial(settings, progress=progress)
    except UnstableControllerError as error:
        out |= {"refused": str(error), "wall_time": time.perf_counter() - start}
        return out | {"peak_rss_mb": peak_rss_mb()}
    record = result.record
    out |= {
        "wall_time": time.perf_counter() - start,
        "step_wall_time": result.summary.get("wall_times", steps),
        "simulated_seconds": float(record.times[-1]),
        "simulated_s_per_wall_s": float(record.stats["realtime_factor"]),
        "stride_count": int(record.stats["num_strides"]),
        "fell": bool(record.fell),
        "message": record.message,
        "spectral_radius": float(result.design_info.spectral_radius),
        "tuning": result.summary.get("controller_tuning", {}),
        "settled_cycle": result.summary.get("cycle", {}),
        "hip_height_range_m": [float(record.states[:, 1].min()), float(record.states[:, 1].max())],
        "peak_rss_mb": peak_rss_mb(),
    }
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=480.0)
    parser.add_argument("--speed", type=float, default=1.2)
    parser.add_argument("--points", type=int, default=200)
    parser.add_argument("--feedback", default="all")
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results/gait_simulate.json"))
    parser.add_argument("--trial-dir", type=Path, default=Path("/tmp/gait-sim-bench"))
    args = parser.parse_args()
    result = run(args.duration, args.speed, args.points, args.feedback, args.trial_dir)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2, default=str) + "\n")
    print(json.dumps(result, indent=2, default=str))


if __name__ == "__main__":
    main()
