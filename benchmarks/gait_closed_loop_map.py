"""Measure estimator (a) of issue 49 before building it: the closed loop's maximum a
posteriori problem over pieces of the smoothed windows that share ``T*`` and ``K``, solved by
constrained Gauss-Newton with each piece's states eliminated (its Schur complement), started
from today's estimate (the smoother, then the two-stage least squares).

Each iteration, per piece of 50 nodes (the pieces of :mod:`colloc.identify.gait.design_bound`,
the tracked values now the trial's): the Gauss-Newton KKT system
``[[H, C^T], [C, 0]] [dz; lambda] = -[grad f; c]`` with the states, motor noise and
multipliers eliminated by one banded factorisation, ``S = H_pp - B^T K_s^-1 B`` and
``b = B^T K_s^-1 r_s - grad_p f``; the pieces' ``S`` and ``b`` are summed, the shared step is
``dp = (sum S)^-1 (sum b)`` and each piece's states take ``-K_s^-1 (r_s + B dp)``. It prints,
per iteration, the objective, the step, K's and T*'s errors from the trial's controller and the
bound ``(sum S / 2)^-1`` at the iterate.

    python benchmarks/gait_closed_loop_map.py TRIAL --duration 120 --iterations 3 --out DIR

One process (a prototype: nothing goes to workers); appends its record to
``benchmarks/results/gait_closed_loop_map.json``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from results_file import append_record, peak_rss_mb

RESULTS = Path(__file__).parent / "results" / "gait_closed_loop_map.json"


class _Smoothed(BaseException):
    """Raised from inside ``colloc gait identify`` once its estimate exists (not an error)."""


def smoothed_fit(trial: str, duration: float, out: str) -> dict[str, Any]:
    """Run ``colloc gait identify`` up to its estimate; return what it had then."""
    import colloc.identify.gait.smoother_fit as smoother_fit
    from colloc.cli import main

    captured: dict[str, Any] = {}

    def capture(c: Any, results: Any, source: Any, est: Any) -> None:
        captured.update(c=c, results=results, est=est)
        raise _Smoothed

    smoother_fit._full_design_bound = capture  # the step after the estimate
    try:
        main(["gait", "identify", trial, "--duration", str(duration), "--window-strides", "10"]
             + ["--design-bound", "full", "--out", out])  # fmt: skip
    except _Smoothed:
        return captured
    raise RuntimeError("colloc gait identify ended before its estimate")


def piece_step(problem: Any, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, Any]:
    """A piece's ``S`` and ``b`` at ``z``, and what its states' step needs."""
    from colloc.nlp.kkt import constraint_jacobian, hessian_matrix, states_kkt
    from colloc.nlp.trials import as_trials

    design = as_trials(problem)
    nlp, p0 = design.nlp, design.parameter_offset
    H = hessian_matrix(design, nlp.gauss_newton_hessian(z))
    C = constraint_jacobian(design, z)
    gradient = nlp.gradient(z)
    B = sp.vstack([H[:p0, p0:], C[:, p0:]]).tocsc()
    lu = spla.splu(states_kkt(H, C, p0))
    y = lu.solve(np.concatenate([gradient[:p0], nlp.constraints(z)]))
    seen = np.flatnonzero(np.diff(B.indptr) > 0)
    X = lu.solve(B[:, seen].toarray())
    S = H[p0:, p0:].toarray()
    S[np.ix_(seen, seen)] -= B[:, seen].T @ X
    return S, B.T @ y - gradient[p0:], (y, X, seen, p0, nlp.objective(z))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("trial")
    parser.add_argument("--duration", type=float, default=120.0)
    parser.add_argument("--iterations", type=int, default=3)
    parser.add_argument("--out", required=True)
    args = parser.parse_args()

    from colloc.data.columns import TORQUE_COLUMNS
    from colloc.identify.gait.design_bound import ClosedLoopInformation, WindowDesign, pieces
    from colloc.identify.gait.estimate import true_controller
    from colloc.identify.gait.read import state_names, tracked_columns
    from colloc.identify.gait.trial_noise import recorded_motor_noise, trial_noise_std
    from colloc.nlp.objective import Tracking

    clock = time.perf_counter()
    fit = smoothed_fit(args.trial, args.duration, args.out)
    smooth_seconds = time.perf_counter() - clock
    c, results, est = fit["c"], fit["results"], fit["est"]
    data, gs, meta = c.data, c.gs, c.data.trial.metadata
    truth = true_controller(data, gs, [])
    if truth is None:
        raise SystemExit("the trial records no controller of the identified class")

    def relative(a: np.ndarray, b: np.ndarray) -> float:
        return float(np.linalg.norm(a - b) / np.linalg.norm(b))

    columns = tracked_columns(c.settings.track)
    noise = {col: trial_noise_std(meta, col) for col in columns}
    information = ClosedLoopInformation(c.dyn, gs, noise, recorded_motor_noise(meta))
    symbol = dict(zip(state_names(), c.dyn.model.states, strict=True))
    symbol.update(zip(TORQUE_COLUMNS, c.dyn.gait.torques, strict=True))
    belt = data.window.signals["belt_speed"].to_numpy(dtype=float)
    work = []
    for r in results:
        window = WindowDesign(
            r.times,
            r.states,
            r.torques,
            np.interp(r.times, data.window.time, belt),
            data.phase.between(r.times, data.window.time, data.window.phase),
        )
        measured = {
            col: np.interp(r.times, data.window.time, data.window.signals[col].to_numpy(float))
            for col in columns
        }
        for k, piece in enumerate(pieces(window)):
            rows = slice(k * piece.times.size, (k + 1) * piece.times.size)
            work.append((piece, {col: v[rows] for col, v in measured.items()}))

    record: dict[str, Any] = {
        "trial": args.trial,
        "duration": args.duration,
        "pieces": len(work),
        "smooth_seconds": smooth_seconds,
        "start": {"K_error": relative(est.K, truth.K), "Tstar_error": relative(est.Tstar, truth.Tstar)},
        "iterations": [],
    }  # fmt: skip
    print(f"start (two-stage least squares): K {record['start']['K_error']:.4f}", flush=True)
    Tstar, K = est.Tstar, est.K
    states: list[np.ndarray | None] = [None] * len(work)
    order: list[int] | None = None
    for iteration in range(args.iterations):
        clock = time.perf_counter()
        S_sum: np.ndarray | None = None
        b_sum: np.ndarray | None = None
        objective, kept = 0.0, []
        values = gs.parameter_values(Tstar, K)
        for i, (piece, measured) in enumerate(work):
            problem = information._problem(piece)
            problem.replace_data(
                objective=Tracking(
                    {symbol[col]: v for col, v in measured.items()},
                    {symbol[col]: 1.0 / noise[col] ** 2 for col in columns},
                )
            )
            if order is None:
                index = {n: j for j, n in enumerate(problem.layout.parameter_names)}
                order = [index[str(p)] for p in gs.parameters]
            z = states[i]
            if z is None:
                law = gs.torque(piece.phase, piece.states[:, information.feedback], Tstar, K)
                guess = dict(zip(c.dyn.model.states, piece.states.T, strict=True))
                guess.update(
                    {w: (piece.torques - law)[:, j] for j, w in enumerate(information.motor.values())}
                )  # fmt: skip
                z = problem.initial_guess(guess, values)
            z = z.copy()
            theta = np.zeros(len(order))
            theta[order] = [values[p] for p in gs.parameters]
            z[-theta.size :] = theta
            S, b, rest = piece_step(problem, z)
            S_sum = S if S_sum is None else S_sum + S
            b_sum = b if b_sum is None else b_sum + b
            objective += rest[-1]
            kept.append((z, rest))
        assert S_sum is not None and b_sum is not None and order is not None
        S_sum = 0.5 * (S_sum + S_sum.T)
        step = np.linalg.solve(S_sum, b_sum)
        for i, (z, (y, X, seen, p0, _)) in enumerate(kept):
            z[:p0] += (-y - X @ step[seen])[:p0]
            states[i] = z
        theta = theta + step
        Tstar, K = gs.arrays(dict(zip(gs.parameters, theta[order], strict=True)))
        bound = np.sqrt(np.clip(np.diag(np.linalg.inv(0.5 * S_sum)), 0.0, None))[order]
        Tstar_bound, K_bound = gs.arrays(dict(zip(gs.parameters, bound, strict=True)))
        within = np.abs(K - truth.K)[:, gs.mask] <= 3.0 * K_bound[:, gs.mask]
        row = {
            "objective": objective,
            "step_norm": float(np.linalg.norm(step)),
            "K_error": relative(K, truth.K),
            "Tstar_error": relative(Tstar, truth.Tstar),
            "K_relative_bound": float(np.linalg.norm(K_bound) / np.linalg.norm(truth.K)),
            "fraction_within_3_bound": float(np.mean(within)),
            "seconds": time.perf_counter() - clock,
        }
        record["iterations"].append(row)
        print(f"iteration {iteration}: " + ", ".join(f"{k} {v:.4g}" for k, v in row.items()))
    record["peak_rss_mb"] = peak_rss_mb()
    append_record(RESULTS, record)


if __name__ == "__main__":
    main()
