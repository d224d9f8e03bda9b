"""The Gauss-Newton iteration: the damped condensed step (Levenberg-Marquardt on the reduced
Hessian until the step has positive curvature), a backtracking line search on the l1 merit in
state units, the damping's update from the merit's actual against predicted decrease, and
the stops (wall time, Ctrl-C, a caller's ``False``)."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from colloc.solve.gauss_newton.condensing import (
    Step,
    WallTime,
    defect_multipliers,
    segment_bounds,
)
from colloc.solve.gauss_newton.structure import Blocks, Chain, ChainStructure
from colloc.solve.result import NLP, SolveResult
from colloc.solve.status import status_from_code

SUCCEEDED, STALLED, USER_STOP, MAX_ITER, WALL_TIME, INVALID_NUMBER = 0, 3, 5, -1, -5, -13

#: Times the damping may be raised within one iteration to reach a positive-curvature step.
MAX_DAMPING_RAISES = 12


@dataclass(frozen=True)
class GaussNewtonOptions:
    """Settings of :func:`solve_gauss_newton`.

    Attributes
    ----------
    segment_nodes : int
        Nodes per condensing segment (about one stride keeps the propagated sensitivities
        bounded on a stable closed loop; fewer is more robust, more is cheaper).
    max_iter : int
    tol : float
        Converged when the Gauss-Newton model's predicted decrease is below
        ``tol * max(1, |f|)`` and the largest defect below ``constraint_tol``.
    constraint_tol : float
    damping : float
        Initial Levenberg-Marquardt factor on the reduced Hessian's diagonal.
    max_wall_time : float
        Seconds; checked after every segment, so a long iteration stops too.
    max_backtracks : int
        Halvings of the step before the line search gives up.
    """

    segment_nodes: int = 100
    max_iter: int = 100
    tol: float = 1e-10
    constraint_tol: float = 1e-8
    damping: float = 1e-6
    max_wall_time: float = float("inf")
    max_backtracks: int = 30

    def __post_init__(self) -> None:
        problems = []
        if not (isinstance(self.segment_nodes, int) and self.segment_nodes >= 2):
            problems.append(
                f"segment_nodes: expected an integer >= 2, found {self.segment_nodes!r}"
            )
        if not (isinstance(self.max_iter, int) and self.max_iter >= 0):
            problems.append(f"max_iter: expected an integer >= 0, found {self.max_iter!r}")
        for name in ("tol", "constraint_tol", "damping", "max_wall_time"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and value > 0):
                problems.append(f"{name}: expected a positive number, found {value!r}")
        if not (isinstance(self.max_backtracks, int) and self.max_backtracks >= 1):
            problems.append(
                f"max_backtracks: expected an integer >= 1, found {self.max_backtracks!r}"
            )
        if problems:
            raise ValueError("; ".join(problems))


def solve_gauss_newton(
    nlp: NLP,
    x0: np.ndarray,
    structure: ChainStructure,
    options: GaussNewtonOptions | None = None,
    progress: Callable[[dict[str, float]], Any] | None = None,
) -> SolveResult:
    """Solve ``min f(z) s.t. c(z) = 0`` on a one-step chain by constrained Gauss-Newton.

    Parameters
    ----------
    nlp : NLP
        Objective, gradient, defects, their sparse Jacobian and the objective's
        Gauss-Newton Hessian (``gauss_newton_hessian``).
    x0 : ndarray
        Start.
    structure : ChainStructure
        Where the states, parameters and defects sit.
    options : GaussNewtonOptions, optional
    progress : callable, optional
        Called after every iteration with ``iteration``, ``objective``, ``infeasibility``,
        ``dual_infeasibility`` (the Gauss-Newton model's predicted decrease of ``f``, which
        vanishes at a stationary point), ``step``, ``alpha``, ``ratio`` and ``damping``;
        returning ``False`` stops the solve.

    Returns
    -------
    SolveResult
        The last accepted iterate (also after a stop, a wall-time limit or Ctrl-C), its
        status, the defect multipliers from the adjoint recursion, the iteration history
        and a text log of it.

    Raises
    ------
    ValueError
        When the NLP is not a one-step chain (a defect depends on a non-adjacent node,
        a variable is neither a state nor a parameter, a constraint is not a defect) or the
        objective couples nodes.
    """
    opts = options or GaussNewtonOptions()
    t_start = time.perf_counter()
    deadline = t_start + opts.max_wall_time
    chain = Chain(nlp, structure)
    stepper = Step(chain, segment_bounds(chain.N, opts.segment_nodes))
    z = np.asarray(x0, dtype=float).copy()
    if z.shape != (nlp.n,):
        raise ValueError(f"x0: expected shape ({nlp.n},), found {z.shape}")
    history: list[dict[str, float]] = []
    lines = [
        f"Gauss-Newton with condensing: N={chain.N}, states={chain.n}, parameters={chain.q}, "
        f"segments={len(stepper.segments)}",
        f"{'iter':>4} {'objective':>14} {'inf_pr':>9} {'decrease':>10} {'|dz|':>9} "
        f"{'alpha':>8} {'ratio':>8} {'damping':>8} {'merit_mu':>8}",
    ]
    timing = {"evaluations": 0.0, "condensing": 0.0, "line_search": 0.0}
    mu, damping = 0.0, opts.damping
    status, iterations = MAX_ITER, 0
    blocks: Blocks | None = None
    f = nlp.objective(z)
    c = nlp.constraints(z)
    try:
        for it in range(opts.max_iter + 1):
            if not (np.isfinite(f) and np.all(np.isfinite(c))):
                status = INVALID_NUMBER
                break
            t0 = time.perf_counter()
            blocks = chain.blocks(nlp, z)
            t1 = time.perf_counter()
            timing["evaluations"] += t1 - t0
            if it == opts.max_iter:
                break
            # The node-parameter and parameter blocks are the objective's exact Hessian, which
            # a tracked controller output makes indefinite far from the data; more damping
            # until the step has positive curvature (a Levenberg-Marquardt safeguard).
            reduced = stepper.condense(blocks, deadline, damping)
            for _ in range(MAX_DAMPING_RAISES):
                dz = stepper.solve(blocks, reduced, damping)
                curvature = chain.curvature(blocks, dz)
                if curvature > 0 or not np.any(dz):
                    break
                damping = min(max(10.0 * damping, 1e-4), 1e6)
            t2 = time.perf_counter()
            timing["condensing"] += t2 - t1
            slope = float(blocks.gradient @ dz)
            # defects in state units, E_k^{-1} c_k with E_k frozen at this iterate: how far
            # each next state is from where the dynamics put it (a stiff contact's large
            # force defects are small state corrections)
            c_norm = float(np.abs(blocks.a).sum())
            if c_norm > 0:
                mu = max(mu, (slope + 0.5 * curvature) / (0.9 * c_norm) + 1e-12)
            merit = f + mu * c_norm
            derivative = slope - mu * c_norm
            predicted = -(slope + 0.5 * curvature)
            infeasibility = float(np.abs(c).max(initial=0.0))
            if infeasibility <= opts.constraint_tol and predicted <= opts.tol * max(1.0, abs(f)):
                status = SUCCEEDED
                break
            alpha, accepted = 1.0, False
            for _ in range(opts.max_backtracks):
                trial = z + alpha * dz
                f_t = nlp.objective(trial)
                c_t = nlp.constraints(trial)
                merit_t = f_t + mu * chain.state_defect_norm(blocks, c_t)
                if np.isfinite(merit_t) and merit_t <= merit + 1e-4 * alpha * derivative:
                    accepted = True
                    break
                alpha *= 0.5
            timing["line_search"] += time.perf_counter() - t2
            if not accepted:
                status = STALLED
                break
            # trust in the model: the merit's actual against its predicted decrease
            ratio = (merit - merit_t) / max(alpha * (predicted + mu * c_norm), 1e-300)
            z, f, c = trial, f_t, c_t
            iterations = it + 1
            if ratio > 0.5 and alpha == 1.0:
                damping = max(damping / 3.0, 1e-12)
            elif ratio < 0.25:
                damping = min(damping * 4.0, 1e6)
            row = {
                "iteration": float(iterations),
                "objective": float(f),
                "infeasibility": float(np.abs(c).max(initial=0.0)),
                "dual_infeasibility": predicted,
                "step": float(np.abs(dz).max(initial=0.0)),
                "alpha": alpha,
                "ratio": ratio,
                "damping": damping,
            }
            history.append(row)
            lines.append(
                f"{iterations:4d} {f:14.7e} {row['infeasibility']:9.2e} {predicted:10.2e} "
                f"{row['step']:9.2e} {alpha:8.2e} {ratio:8.2f} {damping:8.1e} {mu:8.1e}"
            )
            if progress is not None and progress(row) is False:
                status = USER_STOP
                break
            if time.perf_counter() > deadline:
                status = WALL_TIME
                break
    except WallTime:
        status = WALL_TIME
    except KeyboardInterrupt:
        status = USER_STOP
        lines.append("interrupted (Ctrl-C): returning the last accepted iterate")
    elapsed = time.perf_counter() - t_start
    multipliers = np.full(nlp.m, np.nan)
    if blocks is not None:
        multipliers = defect_multipliers(chain, blocks, nlp.m)
    lines.append(
        "seconds: "
        + ", ".join(f"{k} {v:.3f}" for k, v in timing.items())
        + f", total {elapsed:.3f}"
    )
    result_status = status_from_code(status)
    lines.append(f"status: {result_status}")
    return SolveResult(
        x=z,
        status=result_status,
        objective=float(f),
        constraint_violation=float(np.abs(c).max(initial=0.0)),
        iterations=iterations,
        solve_time=elapsed,
        multipliers=multipliers,
        log="\n".join(lines),
        history=history,
        options={
            "solver": "gauss-newton",
            **{k: getattr(opts, k) for k in opts.__dataclass_fields__},
            "timing": timing,
        },
    )
