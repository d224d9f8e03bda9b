"""The cost between IPOPT and colloc's arrays: per-call times, colloc's own against IPOPT's.

For the seed's pendulum identification (``--links 1 4``: midpoint, sensor noise, the
'direct' gain guess), solves the built problem from its optimum perturbed by 2 % (seeded)
for ``--max-iter`` iterations through each binding (``capi``: colloc's ctypes driver of
IPOPT's C interface; ``cyipopt``: cyipopt's ``Problem``, for comparison), with IPOPT's
timing statistics on. Per call of the objective, gradient, constraints, Jacobian and
Hessian it reports (a) colloc's own evaluation time (median of ``--repeats`` direct calls),
(b) IPOPT's wall time per call, and their ratio:

    python benchmarks/callback_overhead.py --links 1 4

One JSON record per (case, binding), appended to
``benchmarks/results/callback_overhead.json``.
"""

from __future__ import annotations

import argparse
import re
import statistics
import tempfile
import time
from functools import partial
from pathlib import Path

import numpy as np
from results_file import append_record

from colloc.identify import PendulumSettings
from colloc.identify.pendulum import run_pendulum
from colloc.solve import ipopt
from colloc.solve.ipopt_capi import CProblem

RESULTS = Path(__file__).parent / "results" / "callback_overhead.json"
#: name -> (IPOPT's timing label, its call-count label)
CALLS = {
    "objective": ("Objective function", "Number of objective function evaluations"),
    "gradient": ("Objective function gradient", "Number of objective gradient evaluations"),
    "constraints": ("Equality constraints", "Number of equality constraint evaluations"),
    "jacobian": (
        "Equality constraint Jacobian",
        "Number of equality constraint Jacobian evaluations",
    ),
    "hessian": ("Lagrangian Hessian", "Number of Lagrangian Hessian evaluations"),
}


def own_seconds(fn, repeats: int) -> float:
    """Median wall time of ``repeats`` calls."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def make_problem(binding: str, nlp, callbacks, lower, upper):
    """The binding's problem object (both take cyipopt's ``problem_obj`` interface)."""
    zeros = np.zeros(nlp.m)
    if binding == "capi":
        return CProblem(nlp.n, nlp.m, callbacks, lower, upper, zeros, zeros)
    import cyipopt

    return cyipopt.Problem(
        n=nlp.n, m=nlp.m, problem_obj=callbacks, lb=lower, ub=upper, cl=zeros, cu=zeros
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--links", type=int, nargs="+", default=[1, 4])
    parser.add_argument(
        "--bindings", nargs="+", choices=["capi", "cyipopt"], default=["capi", "cyipopt"]
    )
    parser.add_argument("--max-iter", type=int, default=15)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args()

    for links in args.links:
        run = run_pendulum(
            PendulumSettings(num_links=links, sensor_noise=True, initial_guess="direct")
        )
        problem, nlp = run.problem, run.problem.nlp
        rng = np.random.default_rng(args.seed)
        z0 = run.solution.z * (1 + 0.02 * rng.standard_normal(nlp.n))
        lam = run.solution.multipliers
        own = {
            "objective": own_seconds(partial(nlp.objective, z0), args.repeats),
            "gradient": own_seconds(partial(nlp.gradient, z0), args.repeats),
            "constraints": own_seconds(partial(nlp.constraints, z0), args.repeats),
            "jacobian": own_seconds(partial(nlp.jacobian, z0), args.repeats),
            "hessian": own_seconds(partial(nlp.hessian, z0, lam, 1.0), args.repeats),
        }
        lower, upper = problem.variable_bounds()
        for binding in args.bindings:
            callbacks = ipopt._Callbacks(nlp, None)
            solver = make_problem(binding, nlp, callbacks, lower, upper)
            with tempfile.TemporaryDirectory() as tmp:
                log_file = Path(tmp) / "ipopt.log"
                options = {
                    **ipopt.DEFAULT_OPTIONS,
                    "max_iter": args.max_iter,
                    "print_level": 0,
                    "file_print_level": 5,
                    "output_file": str(log_file),
                    "print_timing_statistics": "yes",
                    "sb": "yes",
                }
                for key, value in options.items():
                    solver.add_option(key, value)
                t0 = time.perf_counter()
                _, info = solver.solve(z0)
                wall = time.perf_counter() - t0
                log = log_file.read_text()
            solver.close()
            per_call = {}
            for name, (label, count_label) in CALLS.items():
                seconds = re.search(
                    rf" {label}\.*:\s*[0-9.]+ \(sys:\s*[0-9.]+ wall:\s*([0-9.]+)\)", log
                )
                count = re.search(rf"{count_label}\s*=\s*(\d+)", log)
                calls = int(count.group(1)) if count else 0
                ipopt_s = float(seconds.group(1)) / calls if seconds and calls else None
                per_call[name] = {
                    "own_ms": 1e3 * own[name],
                    "ipopt_ms": None if ipopt_s is None else 1e3 * ipopt_s,
                    "ratio": None if ipopt_s is None else ipopt_s / own[name],
                    "calls": calls,
                }
            append_record(
                args.out,
                {
                    "case": f"pendulum {links} link(s), midpoint",
                    "binding": binding,
                    "variables": nlp.n,
                    "nnz_jacobian": int(nlp.nnz_jacobian),
                    "nnz_hessian": int(nlp.nnz_hessian),
                    "status": int(info["status"]),
                    "solve_wall_seconds": wall,
                    "per_call": per_call,
                },
            )


if __name__ == "__main__":
    main()
