"""The cost between IPOPT and colloc's arrays: per-call times, colloc's own against IPOPT's.

For the seed's pendulum identification (``--links 1 4``: midpoint, sensor noise, the
'direct' gain guess), solves the built problem from its optimum perturbed by 2 % (seeded)
for ``--max-iter`` iterations through each binding (``capi``: colloc's ctypes driver of
IPOPT's C interface; ``cyipopt``: cyipopt's ``Problem``, for comparison), with IPOPT's
timing statistics on. Per call of the objective, gradient, constraints, Jacobian and
Hessian it reports (a) colloc's own evaluation time (median of ``--repeats`` direct calls),
(b) IPOPT's wall time per call, and their ratio; and (c) the same evaluations timed inside the
solve, in the callbacks IPOPT calls, so that the binding's own share (IPOPT's time over (c))
is told apart from the evaluation running slower between MUMPS factorizations (caches cold):

    python benchmarks/callback_overhead.py --links 1 4 --gait-trial DIR

``--gait-trial`` adds gait2d closed by ``GainScheduled`` on the first ``--gait-seconds``
(60) of a trial from ``colloc gait simulate``: midpoint, all 18 states free, the six joint
angles and the trunk pose tracked, the trial's own controller known (with the controller
unknown MUMPS needs minutes per factorization at this size, see issue 14; the Jacobian and
Hessian of the states, which are nearly all of the nonzeros, are the same evaluations).

One JSON record per (case, binding), appended to
``benchmarks/results/callback_overhead.json``.
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import tempfile
import time
from functools import partial
from pathlib import Path

import numpy as np
from results_file import append_record

from colloc.identify import PendulumSettings
from colloc.identify.pendulum.workflow import run_pendulum
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


class Timed:
    """IPOPT's callbacks with every value/derivative call timed (seconds, per name)."""

    def __init__(self, callbacks) -> None:
        self.callbacks = callbacks
        self.seconds: dict[str, list[float]] = {name: [] for name in CALLS}
        for name in CALLS:
            setattr(self, name, self._timed(name, getattr(callbacks, name)))
        self.jacobianstructure = callbacks.jacobianstructure
        self.hessianstructure = callbacks.hessianstructure
        self.intermediate = callbacks.intermediate

    def _timed(self, name, fn):
        def call(*args):
            t0 = time.perf_counter()
            out = fn(*args)
            self.seconds[name].append(time.perf_counter() - t0)
            return out

        return call


def measure(case: str, nlp, z0, lam, lower, upper, args) -> None:
    """Time one case through each binding and append its records."""
    own = {
        "objective": own_seconds(partial(nlp.objective, z0), args.repeats),
        "gradient": own_seconds(partial(nlp.gradient, z0), args.repeats),
        "constraints": own_seconds(partial(nlp.constraints, z0), args.repeats),
        "jacobian": own_seconds(partial(nlp.jacobian, z0), args.repeats),
        "hessian": own_seconds(partial(nlp.hessian, z0, lam, 1.0), args.repeats),
    }
    for binding in args.bindings:
        callbacks = Timed(ipopt._Callbacks(nlp, None))
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
            inside = callbacks.seconds[name]
            inside_s = sum(inside) / len(inside) if inside else None
            per_call[name] = {
                "own_ms": 1e3 * own[name],
                "ipopt_ms": None if ipopt_s is None else 1e3 * ipopt_s,
                "ratio": None if ipopt_s is None else ipopt_s / own[name],
                "in_solve_ms": None if inside_s is None else 1e3 * inside_s,
                "binding_ratio": None if not (ipopt_s and inside_s) else ipopt_s / inside_s,
                "calls": calls,
            }
        record = {
            "case": case,
            "binding": binding,
            "variables": nlp.n,
            "nnz_jacobian": int(nlp.nnz_jacobian),
            "nnz_hessian": int(nlp.nnz_hessian),
            "status": int(info["status"]),
            "solve_wall_seconds": wall,
            "per_call": per_call,
        }
        print(json.dumps(record))
        append_record(args.out, record)


def gait_case(trial: Path, seconds: float):
    """The gait tracking problem with the trial's controller known, its start and bounds."""
    import gait_setup

    from colloc import Problem, Tracking
    from colloc.gait.trials import STATE_COLUMNS
    from colloc.transcription import Midpoint

    setup = gait_setup.load(trial)
    model, gs = setup.dyn.model, setup.gs
    t, signals = setup.window(0.0, seconds)
    tracked = list(model.states[:9])
    weights = {y: 1.0 / setup.sigma(y) ** 2 / t.size for y in tracked}
    measured = {y: signals[setup.columns[y]].to_numpy() for y in tracked}
    problem = Problem(
        model.with_outputs(tracked).close_loop(gs),
        t,
        scheme=Midpoint(),
        known_trajectories=setup.known(signals),
        known_parameters={**setup.dyn.constants, **gs.parameter_values(setup.Tstar, setup.K)},
        objective=Tracking(measured, weights),
    )
    states = {x: signals[c].to_numpy() for x, c in zip(model.states, STATE_COLUMNS, strict=True)}
    z0 = problem.initial_guess(states)
    return problem, z0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--links", type=int, nargs="*", default=[1, 4])
    parser.add_argument(
        "--bindings", nargs="+", choices=["capi", "cyipopt"], default=["capi", "cyipopt"]
    )
    parser.add_argument("--gait-trial", type=Path, default=None, help="trial directory")
    parser.add_argument("--gait-seconds", type=float, default=60.0)
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
        lower, upper = problem.variable_bounds()
        case = f"pendulum {links} link(s), midpoint"
        measure(case, nlp, z0, run.solution.multipliers, lower, upper, args)
    if args.gait_trial is not None:
        problem, z0 = gait_case(args.gait_trial, args.gait_seconds)
        lower, upper = problem.variable_bounds()
        lam = np.ones(problem.nlp.m)
        case = f"gait2d GainScheduled, {args.gait_seconds:g} s, midpoint, controller known"
        measure(case, problem.nlp, z0, lam, lower, upper, args)


if __name__ == "__main__":
    main()
