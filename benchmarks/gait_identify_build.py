"""Build cost of a gait identification problem with many schedule parameters.

gait2d closed by ``GainScheduled`` (P points, feedback 'all': 6 + 6 x 17 parameters per
point), midpoint, N nodes at 100 Hz, joint angles and trunk pose tracked; every run builds
without the disk cache (cold) and then fills an initial guess with every parameter:

    python benchmarks/gait_identify_build.py --points 200 --nodes 1000

Prints and appends to ``benchmarks/results/gait_identify_build.json``: parameters,
variables, nonzeros, derive / build / guess seconds.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from results_file import append_record

from colloc import GainScheduled, Problem, Tracking
from colloc.gait.design import FEEDBACK_SETS
from colloc.gait.orbit import GaitDynamics

RESULTS = Path(__file__).parent / "results" / "gait_identify_build.json"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--points", type=int, default=200)
    parser.add_argument("--nodes", type=int, default=1000)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args()
    dyn = GaitDynamics.build()
    gait, model = dyn.gait, dyn.model
    gs = GainScheduled(args.points, [model.states[i] for i in FEEDBACK_SETS["all"]], gait.torques)
    closed = model.close_loop(gs)
    t = np.arange(args.nodes) * 0.01
    known = {gait.belt_speed: np.full(t.size, 1.2), gs.phase: t / 1.2}
    measured = {q: np.zeros(t.size) for q in model.states[:9]}
    start = time.perf_counter()
    problem = Problem(
        closed,
        t,
        known_trajectories=known,
        known_parameters=dyn.constants,
        objective=Tracking(measured),
        cache=False,
    )
    built = time.perf_counter()
    problem.initial_guess({}, dict.fromkeys(gs.parameters, 0.1))
    record = {
        "points": args.points,
        "nodes": args.nodes,
        "parameters": len(gs.parameters),
        "variables": problem.layout.num_variables,
        "nnz_jacobian": int(problem.nlp.nnz_jacobian),
        "nnz_hessian": int(problem.nlp.nnz_hessian),
        "derive_seconds": problem.derive_time,
        "build_seconds": built - start,
        "guess_seconds": time.perf_counter() - built,
    }
    append_record(args.out, record)


if __name__ == "__main__":
    main()
