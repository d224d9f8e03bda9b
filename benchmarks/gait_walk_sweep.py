"""Do synthetic perturbed walks last? A sweep of speeds x seeds x motor noise.

Each case is one ``colloc gait simulate`` (colloc.gait.workflow.simulate_trial) with the
default perturbation record at scale 1, the default controller (P = 20, feedback on every
state but the hip's place) and the given motor noise. Recorded per case: the seconds walked,
strides, whether it fell and the fall in words (colloc.gait.falls), or the reason it was
refused before the work, and the wall time. Cases run in separate processes (``--workers``);
every finished case is appended to the JSON at once with the commit it ran, and a case already
there (same speed, seed, noise and duration) is not run again, so an interrupted sweep resumes
(start a new ``--out`` after changing the code).

The closing table counts, per speed and noise, the runs that walked the whole duration.

Usage: python benchmarks/gait_walk_sweep.py [--speeds 0.8 0.9 ... 1.6] [--seeds 1 2]
       [--motor-noise 0 3 5] [--cases SPEED:SEED:NOISE ...] [--duration 480] [--workers 2]
       [--out benchmarks/results/gait_walk_sweep.json]
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import platform
import subprocess
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path


def walk(speed: float, seed: int, motor_noise: float, duration: float) -> dict:
    """One case: its settings, what happened and what it cost."""
    from colloc.gait.workflow import GaitSimulationSettings, simulate_trial

    case = {"speed": speed, "seed": seed, "motor_noise": motor_noise, "duration": duration}
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="colloc-sweep-") as folder:
        settings = GaitSimulationSettings(
            duration=duration,
            speed=speed,
            seed=seed,
            motor_noise=motor_noise,
            out=Path(folder),
            animation_seconds=0.5,
        )
        try:
            result = simulate_trial(settings)
        except (ValueError, RuntimeError) as error:  # refused, or no cycle at this speed
            return case | {"refused": str(error), "wall_time": time.perf_counter() - start}
    record = result.record
    return case | {
        "walked_seconds": float(record.times[-1]),
        "strides": int(record.stats["num_strides"]),
        "fell": bool(record.fell),
        "message": record.message,
        "cycle_nodes": result.summary.get("cycle", {}).get("cycle_nodes"),
        "spectral_radius": float(result.design_info.spectral_radius),
        "walk_compiled": result.summary.get("walk_compiled"),
        "wall_time": time.perf_counter() - start,
    }


def code_version() -> str:
    """The commit the sweep runs (``+dirty`` when the work tree has changes)."""
    root = Path(__file__).resolve().parents[1]

    def git(*args: str) -> str:
        return subprocess.run(
            ["git", *args], capture_output=True, text=True, cwd=root
        ).stdout.strip()

    dirty = git("status", "--porcelain", "--untracked-files=no")
    return git("rev-parse", "--short", "HEAD") + ("+dirty" if dirty else "")


def _key(case: dict) -> tuple:
    return (case["speed"], case["seed"], case["motor_noise"], case["duration"])


def table(cases: list[dict]) -> str:
    """Per speed (rows) and motor noise (columns): runs that walked it all / runs."""
    noises = sorted({c["motor_noise"] for c in cases})
    lines = ["speed m/s | " + " | ".join(f"noise {n:g} N m" for n in noises)]
    for speed in sorted({c["speed"] for c in cases}):
        cells = []
        for noise in noises:
            group = [c for c in cases if c["speed"] == speed and c["motor_noise"] == noise]
            walked = sum(1 for c in group if c.get("fell") is False)
            refused = sum(1 for c in group if "refused" in c)
            cells.append(f"{walked}/{len(group)}" + (f" ({refused} refused)" if refused else ""))
        lines.append(f"{speed:g} | " + " | ".join(cells))
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    # every 0.1 m/s: a grid of every 0.2 m/s hid two speeds between its points whose walks
    # all fell within seconds (1.35 and 1.5 m/s, docs/gait.md)
    parser.add_argument(
        "--speeds", type=float, nargs="*", default=[round(0.8 + 0.1 * k, 1) for k in range(9)]
    )
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--motor-noise", type=float, nargs="+", default=[0.0, 3.0, 5.0])
    parser.add_argument(
        "--cases",
        nargs="*",
        default=[],
        metavar="SPEED:SEED:NOISE",
        help="single cases run before the grid, e.g. 1.25:47:3",
    )
    parser.add_argument("--duration", type=float, default=480.0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results/gait_walk_sweep.json"))
    args = parser.parse_args()
    previous = json.loads(args.out.read_text())["cases"] if args.out.is_file() else []
    done = {_key(c) for c in previous}
    single = [(float(v), int(s), float(n)) for v, s, n in (c.split(":") for c in args.cases)]
    grid = itertools.product(args.speeds, args.seeds, args.motor_noise)
    todo = [
        (speed, seed, noise, args.duration)
        for speed, seed, noise in [*single, *grid]
        if (speed, seed, noise, args.duration) not in done
    ]
    cases = list(previous)
    machine = {"cpus": os.cpu_count(), "python": platform.python_version()}
    commit = code_version()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        futures = [pool.submit(walk, *case) for case in todo]
        for future in as_completed(futures):
            case = future.result() | {"commit": commit}
            cases.append(case)
            said = case.get("refused") or case["message"]
            print(
                f"{case['speed']:g} m/s seed {case['seed']} noise {case['motor_noise']:g}: {said}"
            )
            partial = args.out.with_suffix(".partial")
            partial.write_text(json.dumps({"machine": machine, "cases": cases}, indent=1) + "\n")
            partial.replace(args.out)
    print(table(cases))


if __name__ == "__main__":
    main()
