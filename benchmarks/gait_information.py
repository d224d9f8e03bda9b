"""How well can a trial determine the gait controller? The Cramer-Rao bound of T* and K.

Builds the gait identification problem (gait2d closed by ``GainScheduled`` with the trial's
own feedback set and P, the trial's ``controller_phase``, all states free, ``T*`` and ``K``
unknown) on a window of a **noise-free** synthetic trial, puts it at the truth (the trial's
states and its true controller) and computes :func:`colloc.cramer_rao_bound` with the
tracking weights ``1 / sigma^2`` of the default lab noise (1 mm, 0.25 deg, their 6 Hz rates,
1 N m torques). Reports the bound's expected relative errors
``sqrt(sum var K) / ||K||`` and ``sqrt(sum var T*) / ||T*||`` for each window and measured
set:

    python benchmarks/gait_information.py --trial DIR --fit 10 30 \
        --measured positions positions+rates positions+rates+torques

Sets: ``positions`` (trunk pose and joint angles, what the probe tracks),
``positions+rates`` (the trial's rate columns too), ``positions+rates+torques`` (and the six
joint torques of inverse dynamics: outputs on the controlled inputs, which the closed loop
turns into ``T*(phi) - K(phi) s``). One JSON record per (window, set), appended to
``benchmarks/results/gait_information.json``, with the build and bound seconds and the peak
RSS. Memory grows with N times the number of parameters (about 5 GB at N = 3001, P = 20).
"""

from __future__ import annotations

import argparse
import resource
import time
from pathlib import Path

import gait_setup
import numpy as np
from results_file import append_record

from colloc import Problem, Tracking, cramer_rao_bound
from colloc.gait.trials import COLUMN_NOISE_GROUP, DEFAULT_NOISE_STD
from colloc.transcription import BackwardEuler, Midpoint

RESULTS = Path(__file__).parent / "results" / "gait_information.json"
SCHEMES = {"midpoint": Midpoint, "backward-euler": BackwardEuler}
SETS = ("positions", "positions+rates", "positions+rates+torques")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--trial", type=Path, required=True, help="noise-free trial directory")
    parser.add_argument("--start-time", type=float, default=10.0, help="window start [s]")
    parser.add_argument("--fit", type=float, nargs="+", default=[10.0, 30.0], help="windows [s]")
    parser.add_argument("--measured", nargs="+", choices=SETS, default=list(SETS))
    parser.add_argument("--scheme", choices=sorted(SCHEMES), default="backward-euler")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args()

    setup = gait_setup.load(args.trial)
    if any(v > 0 for v in setup.trial.metadata["noise"]["std"].values()):
        parser.error("--trial: the bound is taken at the truth, so the trial must be noise-free")
    Tstar, K, gs, columns, names = setup.Tstar, setup.K, setup.gs, setup.columns, setup.names
    dyn, gait, model = setup.dyn, setup.dyn.gait, setup.dyn.model
    truth = gs.parameter_values(Tstar, K)
    sigma = {y: DEFAULT_NOISE_STD[COLUMN_NOISE_GROUP[c]] for y, c in columns.items()}
    for fit in args.fit:
        t, signals = setup.window(args.start_time, fit)
        data = {y: signals[c].to_numpy() for y, c in columns.items()}
        states = {x: data[x] for x in model.states}
        for measured in args.measured:
            tracked = list(model.states[:9])
            if "rates" in measured:
                tracked += list(model.states[9:])
            if "torques" in measured:
                tracked += list(gait.torques)
            t0 = time.perf_counter()
            closed = model.with_outputs(tracked).close_loop(gs)
            problem = Problem(
                closed,
                t,
                scheme=SCHEMES[args.scheme](),
                known_trajectories={
                    gait.belt_speed: signals["belt_speed"].to_numpy(),
                    gs.phase: signals["controller_phase"].to_numpy(),
                },
                known_parameters=dict(dyn.constants),
                objective=Tracking(
                    {y: data[y] for y in tracked}, {y: 1.0 / sigma[y] ** 2 for y in tracked}
                ),
            )
            build = time.perf_counter() - t0
            z = problem.initial_guess(states, truth)
            t0 = time.perf_counter()
            bound = cramer_rao_bound(problem, z)
            seconds = time.perf_counter() - t0
            var_T, var_K = gs.arrays({p: bound.standard_errors[p] ** 2 for p in gs.parameters})
            append_record(
                args.out,
                {
                    "trial": str(args.trial),
                    "start_time": args.start_time,
                    "fit_seconds": fit,
                    "N": int(t.size),
                    "P": int(Tstar.shape[0]),
                    "feedback": names,
                    "parameters": len(gs.parameters),
                    "scheme": args.scheme,
                    "measured": measured,
                    "K_expected_relative_error": float(np.sqrt(var_K.sum()) / np.linalg.norm(K)),
                    "Tstar_expected_relative_error": float(
                        np.sqrt(var_T.sum()) / np.linalg.norm(Tstar)
                    ),
                    "build_seconds": build,
                    "bound_seconds": seconds,
                    "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                },
            )


if __name__ == "__main__":
    main()
