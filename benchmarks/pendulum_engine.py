"""Engine benchmark on the seed's pendulum-on-cart identification.

Each case runs in a fresh process (so peak memory and cold/warm cache are honest) and
reports wall time split into derive / build / solve, IPOPT iterations, peak memory and the
largest relative gain error. Cases:

- 1 link, 60 s at 100 Hz, noise, 'close' guess, midpoint, exact Hessian: cold and warm cache;
- the same with backward Euler (the seed's scheme) to show its bias;
- 4 links (60 050 unknowns): build time and time per Hessian evaluation.

Usage: python benchmarks/pendulum_engine.py [--repeat 3] [--out benchmarks/results/engine.json]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from results_file import peak_rss_mb


def worker(num_links: int, scheme: str, cache_dir: str, hessian_evals: int) -> dict:
    """One identification, timed by phase (runs inside the child process)."""
    t0 = time.perf_counter()
    import numpy as np

    from colloc.identify import PendulumSettings
    from colloc.identify.pendulum.workflow import run_pendulum

    t_import = time.perf_counter() - t0
    settings = PendulumSettings(
        num_links=num_links,
        sensor_noise=True,
        scheme=scheme,
        initial_guess="close" if num_links == 1 else "direct",
    )
    run = run_pendulum(settings, cache=cache_dir)
    out = {
        "num_links": num_links,
        "scheme": scheme,
        "import": t_import,
        "derive": run.timings["derive"],
        "simulate": run.timings["simulate"],
        "build": run.timings["build"],
        "solve": run.timings["solve"],
        "end_to_end": run.timings["derive"] + run.timings["build"] + run.timings["solve"],
        "iterations": run.solution.stats["iterations"],
        "status": run.solution.stats["status"],
        "cache_hit": run.problem.cache_hit,
        "num_variables": run.solution.stats["num_variables"],
        "max_rel_gain_error": run.max_rel_gain_error,
        "max_gain_error_in_se": run.max_gain_error_in_se,
        "peak_rss_mb": peak_rss_mb(),
    }
    if hessian_evals:
        nlp, z = run.problem.nlp, run.solution.z
        lam = run.solution.multipliers
        t0 = time.perf_counter()
        for _ in range(hessian_evals):
            nlp.hessian(z, lam, 1.0)
        out["hessian_eval"] = (time.perf_counter() - t0) / hessian_evals
        t0 = time.perf_counter()
        for _ in range(hessian_evals):
            nlp.jacobian(z)
        out["jacobian_eval"] = (time.perf_counter() - t0) / hessian_evals
        out["nnz_hessian"] = nlp.nnz_hessian
        out["nnz_jacobian"] = nlp.nnz_jacobian
        del np
    return out


def run_case(num_links: int, scheme: str, cache_dir: str, hessian_evals: int = 0) -> dict:
    """Run :func:`worker` in a fresh interpreter and return its JSON."""
    cmd = [
        sys.executable,
        __file__,
        "--worker",
        str(num_links),
        scheme,
        cache_dir,
        str(hessian_evals),
    ]
    done = subprocess.run(cmd, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def median_of(rows: list[dict], key: str) -> float:
    """Median of a numeric field over repeated runs."""
    return statistics.median(r[key] for r in rows)


def main() -> None:
    """Run every case ``--repeat`` times and write medians and raw rows as JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results/engine.json"))
    parser.add_argument("--skip-4link", action="store_true")
    args = parser.parse_args()
    cases: dict[str, list[dict]] = {
        "1link_cold": [],
        "1link_warm": [],
        "1link_backward_euler": [],
        "4link": [],
    }
    for _ in range(args.repeat):
        with tempfile.TemporaryDirectory() as cache:
            cases["1link_cold"].append(run_case(1, "midpoint", cache))
            cases["1link_warm"].append(run_case(1, "midpoint", cache))
            cases["1link_backward_euler"].append(run_case(1, "backward-euler", cache))
            if not args.skip_4link:
                cases["4link"].append(run_case(4, "midpoint", cache, hessian_evals=20))
    keys = (
        "derive",
        "build",
        "solve",
        "end_to_end",
        "iterations",
        "peak_rss_mb",
        "max_rel_gain_error",
        "hessian_eval",
        "jacobian_eval",
    )
    summary = {
        name: {k: median_of(rows, k) for k in keys if rows and k in rows[0]}
        for name, rows in cases.items()
        if rows
    }
    for name, med in summary.items():
        text = ", ".join(f"{k} {v:.4g}" for k, v in med.items())
        print(f"{name:22s} {text}")
    print(
        "midpoint vs backward Euler, max relative gain error: "
        f"{summary['1link_cold']['max_rel_gain_error']:.4%} vs "
        f"{summary['1link_backward_euler']['max_rel_gain_error']:.4%}"
    )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"median": summary, "runs": cases}, indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--worker":
        print(json.dumps(worker(int(sys.argv[2]), sys.argv[3], sys.argv[4], int(sys.argv[5]))))
    else:
        main()
