"""Cost of one Gauss-Newton step on the gait identification: linearize, condense, solve.

gait2d closed by the trial's ``GainScheduled`` controller (``T*`` and ``K`` unknown), backward
Euler on a window of the trial, tracking the 18 states and with ``--torques`` the six joint
torques, at the true controller scaled by 1.1 (T*) and 0.9 (K). Times, as the median of
``--repeats`` runs each, the linearization (``_Chain.blocks``), the condensation and the
banded bordered solve, per segment length:

    python benchmarks/gauss_newton_step.py --trial DIR --fit 10 --segment-nodes 25 50 --torques

One JSON record per segment length, appended to ``benchmarks/results/gauss_newton_step.json``.
"""

from __future__ import annotations

import argparse
import resource
import statistics
import time
from pathlib import Path

import gait_setup
import numpy as np
from results_file import append_record

from colloc import Problem, Tracking
from colloc.gait.trials import COLUMN_NOISE_GROUP, DEFAULT_NOISE_STD
from colloc.solve.gauss_newton.condensing import Step, segment_bounds
from colloc.solve.gauss_newton.structure import Chain
from colloc.transcription import BackwardEuler

RESULTS = Path(__file__).parent / "results" / "gauss_newton_step.json"


def median_seconds(fn, repeats: int) -> tuple[float, object]:
    """Median wall time of ``repeats`` calls of ``fn`` and its last result."""
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--trial", type=Path, required=True, help="trial directory")
    parser.add_argument("--start-time", type=float, default=10.0, help="window start [s]")
    parser.add_argument("--fit", type=float, default=10.0, help="window length [s]")
    parser.add_argument("--segment-nodes", type=int, nargs="+", default=[25, 50])
    parser.add_argument("--torques", action="store_true", help="also track the joint torques")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args()

    setup = gait_setup.load(args.trial)
    Tstar, K, gs, columns = setup.Tstar, setup.K, setup.gs, setup.columns
    gait, model = setup.dyn.gait, setup.dyn.model
    tracked = list(model.states) + (list(gait.torques) if args.torques else [])
    t, signals = setup.window(args.start_time, args.fit)
    weights = {y: 1.0 / DEFAULT_NOISE_STD[COLUMN_NOISE_GROUP[columns[y]]] ** 2 for y in tracked}
    t0 = time.perf_counter()
    problem = Problem(
        model.with_outputs(tracked).close_loop(gs),
        t,
        scheme=BackwardEuler(),
        known_trajectories=setup.known(signals),
        known_parameters=dict(setup.dyn.constants),
        objective=Tracking({y: signals[columns[y]].to_numpy() for y in tracked}, weights),
    )
    build = time.perf_counter() - t0
    z = problem.initial_guess(
        {x: signals[columns[x]].to_numpy() for x in model.states},
        gs.parameter_values(1.1 * Tstar, 0.9 * K),
    )
    chain = Chain(problem.nlp, problem.chain_structure())
    blocks_s, blocks = median_seconds(lambda: chain.blocks(problem.nlp, z), args.repeats)
    for length in args.segment_nodes:
        step = Step(chain, segment_bounds(chain.N, length))
        condense_s, reduced = median_seconds(
            lambda step=step: step.condense(blocks, np.inf, 1e-6), args.repeats
        )
        solve_s, _ = median_seconds(
            lambda step=step, reduced=reduced: step.solve(blocks, reduced, 1e-6), args.repeats
        )
        append_record(
            args.out,
            {
                "trial": str(args.trial),
                "fit_seconds": args.fit,
                "N": int(t.size),
                "parameters": len(gs.parameters),
                "torques_tracked": args.torques,
                "segment_nodes": length,
                "build_seconds": build,
                "blocks_seconds": blocks_s,
                "condense_seconds": condense_s,
                "solve_seconds": solve_s,
                "repeats": args.repeats,
                "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
            },
        )


if __name__ == "__main__":
    main()
