"""The closed-loop fit: gait2d closed by the gain schedule, every state free, solved by
constrained Gauss-Newton from the direct start; standard errors from the Fisher information
(known noise) or the sandwich over strides (with process noise)."""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from colloc.control.gain_scheduled import GainScheduled
from colloc.data.columns import TORQUE_COLUMNS
from colloc.identify.gait.estimate import (
    ControllerEstimate,
)
from colloc.identify.gait.read import (
    state_names,
    tracked_columns,
)
from colloc.identify.gait.settings import GaitIdentifySettings
from colloc.identify.gait.stage import Fit, FitContext


def closed_loop_fit(c: FitContext) -> Fit:
    """The closed-loop collocation problem (all states free, the schedule's parameters in the
    dynamics) solved by constrained Gauss-Newton from the direct start."""
    settings, data, gs, say, lap = c.settings, c.data, c.gs, c.say, c.lap
    window = data.window
    t = window.time
    model = c.dyn.model
    say("build", f"{t.size} nodes, {len(gs.parameters)} controller parameters")
    problem, weights_n = _problem(
        settings, c.dyn, gs, t, window.signals, window.phase, data.trial.metadata
    )
    guess = (
        gs.parameter_values(c.direct.Tstar, c.direct.K)
        if settings.guess == "direct"
        else {p: 0.0 for p in gs.parameters}
    )
    z0 = problem.initial_guess(dict(zip(model.states, window.states.T, strict=True)), guess)
    lap("build")

    from colloc.solve.gauss_newton import GaussNewtonOptions

    say("solve", f"Gauss-Newton, segments of {settings.segment_nodes} nodes")
    solution = problem.solve_gauss_newton(
        z0,
        GaussNewtonOptions(segment_nodes=settings.segment_nodes, max_iter=settings.max_iter),
        progress=c.iterations,
    )
    stats = solution.stats
    Tstar, K = gs.arrays({p: solution.parameters[p] for p in gs.parameters})
    lap("solve")

    strides = None
    if settings.process_noise is None:
        say("uncertainty", "Fisher information at the estimate, known noise levels")
    else:
        # the sandwich's blocks: one per stride (the first from the window's start)
        strikes = data.trial.right_heel_strikes
        inside = np.searchsorted(t, strikes[(strikes > t[0]) & (strikes < t[-1])])
        strides = np.r_[0, inside[inside > 0]]
        say("uncertainty", f"sandwich over {strides.size} strides")
    Tstar_se, K_se = _standard_errors(problem, solution, gs, weights_n, c.notes, strides)
    lap("uncertainty")

    return Fit(
        ControllerEstimate(Tstar, K, Tstar_se, K_se),
        {
            "status": stats["status"],
            "success": bool(stats["success"]),
            "iterations": int(stats["iterations"]),
            "objective": float(stats["objective"]),
            "constraint_violation": float(stats["constraint_violation"]),
            "message": stats.get("message", ""),
            "log": stats.get("ipopt_log", ""),
        },
        _problem_size(problem, gs),
        np.column_stack([solution.trajectories[x] for x in model.states[3:9]]),
    )


def _problem(
    settings: GaitIdentifySettings,
    dyn: Any,
    gs: GainScheduled,
    t: np.ndarray,
    signals: Any,
    phase: np.ndarray,
    meta: dict[str, Any],
) -> tuple[Any, float]:
    """The collocation problem; its tracking weights are ``1 / (sigma^2 N)``."""
    from sympy.physics.mechanics import dynamicsymbols

    from colloc.identify.gait.trial_noise import trial_noise_std
    from colloc.model.symbols import name_of
    from colloc.nlp.objective import Tracking
    from colloc.nlp.problem import Problem
    from colloc.transcription import BackwardEuler, Midpoint

    model, gait = dyn.model, dyn.gait
    by_column = dict(zip(state_names(), model.states, strict=True))
    by_column.update(zip(TORQUE_COLUMNS, gait.torques, strict=True))
    columns = tracked_columns(settings.track)
    tracked = [by_column[c] for c in columns]
    N = t.size
    measured = {y: signals[c].to_numpy(dtype=float) for y, c in zip(tracked, columns, strict=True)}
    weights = {
        y: 1.0 / trial_noise_std(meta, c) ** 2 / N for y, c in zip(tracked, columns, strict=True)
    }
    plant = model.with_outputs(tracked)
    process_noise = None
    if settings.process_noise is not None:
        # motor noise on each joint torque (before the loop is closed: T = law + w) and a
        # residual force on each trunk coordinate's dynamic row; the priors are weighted
        # like the tracking, 1 / (sigma^2 N)
        joint, trunk = settings.process_noise
        motor = {T: dynamicsymbols(f"motor_noise_{name_of(T)}") for T in gait.torques}
        rows = {
            model.num_states // 2 + i: dynamicsymbols(f"residual_{name_of(q)}")
            for i, q in enumerate(model.states[:3])
        }
        plant = plant.with_disturbances({**motor, **rows})
        process_noise = {w: joint * np.sqrt(N) for w in motor.values()}
        process_noise.update({w: trunk * np.sqrt(N) for w in rows.values()})
    closed = plant.close_loop(gs)
    scheme = {"midpoint": Midpoint, "backward-euler": BackwardEuler}[settings.scheme]()
    problem = Problem(
        closed,
        t,
        scheme=scheme,
        known_trajectories={
            gait.belt_speed: signals["belt_speed"].to_numpy(dtype=float),
            gs.phase: phase,
        },
        known_parameters=dict(dyn.constants),
        objective=Tracking(measured, weights),
        process_noise=process_noise,
    )
    return problem, 1.0 / N


def _standard_errors(
    problem: Any,
    solution: Any,
    gs: GainScheduled,
    noise_variance: float,
    notes: list[str],
    strides: np.ndarray | None = None,
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Standard errors of ``T*`` and ``K`` (zero outside the structure), or None: the
    Fisher information at the estimate with the known noise, or with ``strides`` (first
    nodes) the sandwich over them (the process-noise fit)."""
    from colloc.nlp.uncertainty import cramer_rao_bound, parameter_uncertainty

    try:
        if strides is None:
            bound = cramer_rao_bound(problem, solution.z, noise_variance)
        else:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                bound = parameter_uncertainty(
                    problem, solution, method="sandwich", blocks=[int(b) for b in strides]
                )
            notes.append(f"standard errors: sandwich over {len(strides)} strides")
            notes += [str(w.message) for w in caught]  # in the run's notes, not on stderr
    except ValueError as exc:
        notes.append(f"no standard errors: {exc}")
        return None, None
    return gs.arrays(bound.standard_errors)


def _problem_size(problem: Any, gs: GainScheduled) -> dict[str, int]:
    """A solved problem's size with the controller's parameters."""
    return problem.size | {"parameters": len(gs.parameters)}
