"""Probe the gait controller identification NLP: size, build, start, linear algebra, recovery.

gait2d closed by ``GainScheduled`` with the trial's own feedback set and P, the trial's
``controller_phase`` as the phase, all 18 states free, ``T*`` and ``K`` unknown, tracking the
trunk pose and the six joint angles weighted by their noise (1 / sigma^2 / N), and with
``--track rates,torques`` the trial's rate columns and its six joint torques (outputs on the
controlled inputs: the closed loop's ``T*(phi) - K(phi) s``). One fit window per run (each a
fresh process, so the peak RSS is the case's own):

    python benchmarks/gait_identify_probe.py --trial DIR --fit 5 --start truth+20% \
        --max-iter 10 --pivot-order 4 --scheme midpoint

Writes one JSON record per run, appended to ``benchmarks/results/gait_identify_probe.json``:
variables, constraints, Jacobian/Hessian nonzeros, build seconds, the largest defect at the
start, IPOPT iterations and status, seconds in the linear solver vs in function evaluations
(IPOPT's own timing statistics), peak RSS, and the relative errors of ``K`` and ``T*`` against
the trial's true controller.

Starts: ``truth`` (true controller), ``truth+20%`` (each parameter times 1 + U(-0.2, 0.2),
seeded), states from the measured columns (angles, positions and their rates as recorded), or
with ``--smooth SECONDS`` the measured positions smoothed (Savitzky-Golay, cubic, that window)
with their derivatives as the rates.
``--fixed-first`` solves the tracking problem with the start's controller held fixed (no
unknown parameters: a banded KKT system) and starts the identification from its states.
``--residual-forces SIGMA_JOINT,SIGMA_ROOT`` adds a disturbance generalized force to each of
the nine dynamic equations of that fixed-controller solve (``Model.with_disturbances``: motor
noise on the six joints, residual forces on the trunk's x, y, angle), penalised by
``1 / sigma^2`` per unit time, and starts it with the disturbances equal to the residual, so
that the start satisfies every dynamic defect (exactly with backward Euler, whose residual is
evaluated at the nodes). ``--friction-velocity`` overrides the contact's ``v_s`` (a softer
friction law) in every solve.

``--solver gauss-newton`` solves with colloc's constrained Gauss-Newton with condensing
(``Problem.solve_gauss_newton``, ``--segment-nodes`` per condensing segment) instead of IPOPT;
its log replaces IPOPT's and its time split is in ``gauss_newton.timing``.
"""

from __future__ import annotations

import argparse
import re
import time
from pathlib import Path

import gait_setup
import numpy as np
import pandas as pd
from results_file import append_record, peak_rss_mb
from scipy.interpolate import CubicSpline
from sympy.physics.mechanics import dynamicsymbols

from colloc import GaussNewtonOptions, IntegralCost, Problem, Tracking
from colloc.gait.trials import STATE_COLUMNS
from colloc.identify.direct import smooth_with_derivatives
from colloc.model.symbols import name_of
from colloc.solve.ipopt import HESSIAN_CHOICES
from colloc.transcription import BackwardEuler, Midpoint

RESULTS = Path(__file__).parent / "results" / "gait_identify_probe.json"
SCHEMES = {"midpoint": Midpoint, "backward-euler": BackwardEuler}
TIMING = {
    "linear_solver": r"PDSystemSolverTotal\.*:\s*([0-9.]+)",
    "function_evaluations": r"Function Evaluations\.*:\s*([0-9.]+)",
    "ipopt_total": r"OverallAlgorithm\.*:\s*([0-9.]+)",
    "factorization": r"LinearSystemFactorization\.*:\s*([0-9.]+)",
    "symbolic_factorization": r"LinearSystemSymbolicFactorization\.*:\s*([0-9.]+)",
    "back_solve": r"LinearSystemBackSolve\.*:\s*([0-9.]+)",
}


def option_value(text: str) -> int | float | str:
    """An IPOPT option's value from the command line: int, else float, else the string."""
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def timing(log: str) -> dict[str, float | None]:
    """CPU seconds per part from IPOPT's ``print_timing_statistics`` block."""
    out: dict[str, float | None] = {}
    for key, pattern in TIMING.items():
        found = re.search(pattern, log)
        out[key] = float(found.group(1)) if found else None
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--trial", type=Path, required=True, help="trial directory")
    parser.add_argument("--start-time", type=float, default=10.0, help="window start [s]")
    parser.add_argument("--fit", type=float, default=5.0, help="window length [s]")
    parser.add_argument("--start", choices=["truth", "truth+20%"], default="truth+20%")
    parser.add_argument("--fixed-first", action="store_true")
    parser.add_argument("--scheme", choices=sorted(SCHEMES), default="midpoint")
    parser.add_argument("--max-iter", type=int, default=10)
    parser.add_argument("--hessian", choices=HESSIAN_CHOICES, default="exact")
    parser.add_argument(
        "--solver",
        choices=["ipopt", "gauss-newton"],
        default="ipopt",
        help="IPOPT (MUMPS) or colloc's Gauss-Newton with condensing",
    )
    parser.add_argument("--segment-nodes", type=int, default=100, help="Gauss-Newton segment")
    parser.add_argument("--pivot-order", type=int, default=None, help="mumps_pivot_order")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--option", action="append", default=[], metavar="KEY=VALUE", help="IPOPT option"
    )
    parser.add_argument("--residual-forces", default=None, metavar="SIGMA_JOINT,SIGMA_ROOT")
    parser.add_argument(
        "--smooth", type=float, default=None, metavar="SECONDS", help="Savitzky-Golay start"
    )
    parser.add_argument(
        "--nodes-per-sample", type=int, default=1, help="collocation nodes per sample interval"
    )
    parser.add_argument(
        "--track",
        default="",
        help="also track: comma-separated from 'rates' and 'torques' (default positions only)",
    )
    parser.add_argument("--friction-velocity", type=float, default=None, help="v_s [m/s]")
    parser.add_argument("--log", type=Path, default=None, help="keep IPOPT's log here")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args()

    setup = gait_setup.load(args.trial)
    Tstar, K, gs, columns = setup.Tstar, setup.K, setup.gs, setup.columns
    dyn, gait, model = setup.dyn, setup.dyn.gait, setup.dyn.model
    constants = dict(dyn.constants)
    if args.friction_velocity is not None:
        constants[next(c for c in constants if str(c) == "v_s")] = args.friction_velocity
    names = setup.names
    extra = {e for e in args.track.split(",") if e}
    if extra - {"rates", "torques"}:
        parser.error(f"--track: expected 'rates' and/or 'torques', found {sorted(extra)}")
    tracked = list(model.states[:9]) + (list(model.states[9:]) if "rates" in extra else [])
    tracked += list(gait.torques) if "torques" in extra else []
    closed = model.with_outputs(tracked).close_loop(gs)
    t, signals = setup.window(args.start_time, args.fit)
    if args.nodes_per_sample > 1:
        # a finer grid than the samples: every column interpolated onto it (cubic splines;
        # the phase linearly, it has kinks at heel strikes), tracking weights spread over it
        fine = np.linspace(t[0], t[-1], (t.size - 1) * args.nodes_per_sample + 1)
        spline = CubicSpline(t, signals.to_numpy(), axis=0)(fine)
        phase = signals["controller_phase"].to_numpy()
        signals = pd.DataFrame(spline, columns=signals.columns)
        signals["controller_phase"] = np.interp(fine, t, phase)
        t = fine
    N = t.size
    known = setup.known(signals)
    coordinates = model.states[:9]
    measured = {y: signals[columns[y]].to_numpy() for y in tracked}
    # a noise-free trial is weighted as if it had the default sensor noise
    weights = {y: 1.0 / setup.sigma(y) ** 2 / N for y in tracked}
    objective = Tracking(measured, weights)
    truth = gs.parameter_values(Tstar, K)
    rng = np.random.default_rng(args.seed)
    guess = (
        truth
        if args.start == "truth"
        else {p: v * (1 + rng.uniform(-0.2, 0.2)) for p, v in truth.items()}
    )
    states = {x: signals[c].to_numpy() for x, c in zip(model.states, STATE_COLUMNS, strict=True)}
    if args.smooth is not None:
        # a start on smooth positions with their own derivatives as the rates
        raw = np.column_stack([measured[q] for q in coordinates])
        position, rate, _ = smooth_with_derivatives(t, raw, args.smooth)
        states = {q: position[:, j] for j, q in enumerate(coordinates)}
        states.update({u: rate[:, j] for j, u in enumerate(model.states[9:])})
    scheme = SCHEMES[args.scheme]()
    options = {"max_iter": args.max_iter, "print_timing_statistics": "yes", "tol": 1e-6}
    if args.pivot_order is not None:
        options["mumps_pivot_order"] = args.pivot_order
    for item in args.option:
        key, _, value = item.partition("=")
        options[key] = option_value(value)
    record: dict = {
        "trial": str(args.trial),
        "fit_seconds": args.fit,
        "N": N,
        "P": int(Tstar.shape[0]),
        "feedback": names,
        "scheme": args.scheme,
        "start": args.start,
        "fixed_first": args.fixed_first,
        "smooth_seconds": args.smooth,
        "nodes_per_sample": args.nodes_per_sample,
        "hessian": args.hessian,
        "solver": args.solver,
        "tracked": [name_of(y) for y in tracked],
        "ipopt_options": options,
    }
    if args.fixed_first:
        t0 = time.perf_counter()
        fixed_model, fixed_objective, residual_forces = closed, [objective], {}
        if args.residual_forces:
            sigma_joint, sigma_root = (float(v) for v in args.residual_forces.split(","))
            residual_forces = {
                9 + i: dynamicsymbols(f"residual_{name_of(q)}") for i, q in enumerate(coordinates)
            }
            fixed_model = closed.with_disturbances(residual_forces)
            level = [sigma_root] * 3 + [sigma_joint] * 6
            penalty = sum(w**2 / s**2 for w, s in zip(residual_forces.values(), level, strict=True))
            fixed_objective.append(IntegralCost(penalty / (t[-1] - t[0])))
            record["residual_forces"] = {"sigma_joint": sigma_joint, "sigma_root": sigma_root}
        fixed = Problem(
            fixed_model,
            t,
            scheme=scheme,
            known_trajectories=known,
            known_parameters={**constants, **guess},
            objective=fixed_objective,
        )
        z = fixed.initial_guess(states)
        if residual_forces:
            rows = fixed.defects(z).reshape(N - 1, -1)
            start_forces = {w: np.r_[0.0, rows[:, r]] for r, w in residual_forces.items()}
            z = fixed.initial_guess({**states, **start_forces})
        record["fixed_start_max_defect"] = float(np.abs(fixed.defects(z)).max())
        if args.solver == "gauss-newton":
            gn = GaussNewtonOptions(segment_nodes=args.segment_nodes, max_iter=200)
            solved = fixed.solve_gauss_newton(z, gn)
        else:
            solved = fixed.solve(z, **{**options, "max_iter": 500})
        record["fixed"] = {
            "seconds": time.perf_counter() - t0,
            "iterations": solved.stats["iterations"],
            "status": solved.stats["status"],
            "constraint_violation": solved.stats["constraint_violation"],
            "log_tail": solved.stats["ipopt_log"][-600:],
            **timing(solved.stats["ipopt_log"]),
        }
        states = {x: solved.trajectories[x] for x in model.states}
    t0 = time.perf_counter()
    problem = Problem(
        closed,
        t,
        scheme=scheme,
        known_trajectories=known,
        known_parameters=constants,
        objective=objective,
    )
    record["build_seconds"] = time.perf_counter() - t0
    z0 = problem.initial_guess(states, guess)
    record.update(
        variables=problem.layout.num_variables,
        constraints=problem.layout.num_constraints,
        parameters=len(gs.parameters),
        nnz_jacobian=int(problem.nlp.nnz_jacobian),
        nnz_hessian=int(problem.nlp.nnz_hessian),
        start_max_defect=float(np.abs(problem.defects(z0)).max()),
    )
    t0 = time.perf_counter()
    if args.solver == "gauss-newton":
        gn = GaussNewtonOptions(
            segment_nodes=args.segment_nodes,
            max_iter=args.max_iter,
            max_wall_time=float(options.get("max_wall_time", float("inf"))),
        )
        solution = problem.solve_gauss_newton(z0, gn)
        record["gauss_newton"] = dict(solution.stats["ipopt_options"])
        if args.log:
            args.log.write_text(solution.stats["ipopt_log"])
    else:
        solution = problem.solve(
            z0, hessian=args.hessian, log_path=str(args.log) if args.log else None, **options
        )
    record["solve_seconds"] = time.perf_counter() - t0
    record.update(
        iterations=solution.stats["iterations"],
        status=solution.stats["status"],
        constraint_violation=solution.stats["constraint_violation"],
        **timing(solution.stats["ipopt_log"]),
    )
    iterations = max(solution.stats["iterations"], 1)
    record["seconds_per_iteration"] = record["solve_seconds"] / iterations
    record["peak_rss_mb"] = peak_rss_mb()
    Ts, Ks = gs.arrays({p: solution.parameters[p] for p in gs.parameters})
    T0, K0 = gs.arrays(guess)
    record["K_relative_error"] = float(np.linalg.norm(Ks - K) / np.linalg.norm(K))
    record["Tstar_relative_error"] = float(np.linalg.norm(Ts - Tstar) / np.linalg.norm(Tstar))
    record["start_K_relative_error"] = float(np.linalg.norm(K0 - K) / np.linalg.norm(K))
    append_record(args.out, record)


if __name__ == "__main__":
    main()
