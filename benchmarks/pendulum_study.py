"""The pendulum study's bars: n = 1..4 links, 'direct' and 'close' guesses, 60 s at 100 Hz.

For each case: IPOPT status and iterations, the identified objective against the objective
with the gains fixed at the truth (a spurious local minimum would be worse), the largest
relative gain error and the largest error in standard errors, and the times.

Usage: python benchmarks/pendulum_study.py [--links 1 2 3 4] [--guesses direct close]
       [--out benchmarks/results/study.json]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path


def worker(num_links: int, guess: str, seed: int) -> dict:
    """One ``colloc pendulum`` run inside this process (started fresh by :func:`main`)."""
    t0 = time.perf_counter()
    from colloc.identify import PendulumSettings
    from colloc.identify.pendulum.workflow import run_pendulum

    settings = PendulumSettings(
        num_links=num_links,
        duration=60.0,
        sample_rate=100.0,
        sensor_noise=True,
        initial_guess=guess,
        seed=seed,
        check_true_gains=True,
    )
    run = run_pendulum(settings)
    wall = time.perf_counter() - t0
    return {
        "num_links": num_links,
        "guess": guess,
        "seed": seed,
        "status": run.solution.stats["status"],
        "iterations": run.solution.stats["iterations"],
        "objective": run.solution.stats["objective"],
        "objective_at_true_gains": run.objective_at_true_gains,
        "not_worse_than_truth": run.solution.stats["objective"]
        <= run.objective_at_true_gains * (1 + 1e-9),
        "max_rel_gain_error": run.max_rel_gain_error,
        "max_gain_error_in_se": run.max_gain_error_in_se,
        "times": run.timings,
        "end_to_end_without_check": run.timings["total"],
        "wall_including_imports": wall,
    }


def main() -> None:
    """Run the grid of cases, each in a fresh process, and write JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--links", type=int, nargs="+", default=[1, 2, 3, 4])
    parser.add_argument("--guesses", nargs="+", default=["direct", "close"])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results/study.json"))
    args = parser.parse_args()
    rows = []
    for n in args.links:
        for guess in args.guesses:
            cmd = [sys.executable, __file__, "--worker", str(n), guess, str(args.seed)]
            done = subprocess.run(cmd, capture_output=True, text=True)
            if done.returncode != 0:
                rows.append({"num_links": n, "guess": guess, "error": done.stderr[-2000:]})
                print(f"n={n} {guess}: FAILED\n{done.stderr[-800:]}")
                continue
            row = json.loads(done.stdout.strip().splitlines()[-1])
            rows.append(row)
            print(
                f"n={n} -i {guess:7s} {row['status']:28s} it={row['iterations']:4d} "
                f"J={row['objective']:.6g} J(true)={row['objective_at_true_gains']:.6g} "
                f"max rel err={row['max_rel_gain_error']:.3%} max |err|/SE="
                f"{row['max_gain_error_in_se']:.2f} total={row['times']['total']:.1f} s",
                flush=True,
            )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(rows, indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--worker":
        print(json.dumps(worker(int(sys.argv[2]), sys.argv[3], int(sys.argv[4]))))
    else:
        main()
