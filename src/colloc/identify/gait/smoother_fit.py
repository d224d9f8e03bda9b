"""The smoother fit: the dynamically consistent smoother in stride windows (on workers when
given), then the schedule's two-stage least squares on its signals, with stride-sandwich
errors and the bound of the design."""

from __future__ import annotations

from typing import Any

import numpy as np

from colloc.control.gain_scheduled import GainScheduled
from colloc.identify.gait.estimate import (
    ControllerEstimate,
)
from colloc.identify.gait.read import (
    state_names,
)
from colloc.identify.gait.stage import Fit, FitContext
from colloc.identify.gait.windows import (
    SOURCES,
    fit_windows,
    prefixed,
    smoothing_source,
    window_facts,
    window_jobs,
)

#: Said of a trial that records no motor noise (a synthetic walk made without it).
ZERO_MOTOR_NOISE_NOTE = (
    "the trial records no motor noise: the walk's excursions from its mean stride come from "
    "the belt alone, the smoother's state errors are a large share of them, and the bound "
    "and standard errors read those errors as information, so both are too narrow (214 s at "
    "1.2 m/s without motor noise: K error 3.0 times the bound, 79 % of entries within 3 SE; "
    "docs/gait-guide.md); simulate with --motor-noise 3 for honest bars"
)


def smoother_fit(c: FitContext) -> Fit:
    """The dynamically consistent smoother (:mod:`colloc.identify.gait.smoother`), then the
    schedule's two-stage least squares on its node signals (or the ordinary least squares at
    the interval midpoints), with stride-sandwich errors and the bound of the design
    (:mod:`colloc.identify.gait.controller_fit`)."""
    from colloc.identify.gait.controller_fit import fit_schedule_with_errors, instruments_pay
    from colloc.identify.gait.trial_noise import recorded_motor_noise, torque_equation_noise
    from colloc.identify.gait.windows import smooth_windows

    settings, data, gs = c.settings, c.data, c.gs
    meta = data.trial.metadata
    windows = fit_windows(settings, data.window.time, data.trial.right_heel_strikes)
    source = smoothing_source(settings.smooth_from, data.trial)
    jobs = window_jobs(
        data.fit,
        data.rows,
        windows,
        meta,
        "stride window",
        source,
        settings.noise_levels,
        settings.fit_places,
    )
    where = "" if c.map_windows is None else " on the workers"
    c.say(
        "smooth",
        f"{len(jobs)} window(s){where} tracking the {SOURCES[source].words}: backward Euler, "
        "midpoint, continuation",
    )
    results = smooth_windows(jobs, prefixed(c.say, "smooth"), c.map_windows)
    c.lap("smooth")
    c.notes.extend(dict.fromkeys(note for r in results for note in r.notes))

    # Ordinary least squares reads the signals where the scheme holds the dynamics (the
    # midpoints' averages cancel the midpoint rule's odd-even mode); the instrumented fit
    # reads the nodes, whose lagged states are the better instruments (on the 120 s motor-
    # noise trial K 30 % at the nodes, 40 % at the midpoints; docs/gait.md).
    nodes = sum(r.times.size for r in results)
    instrumented = bool(settings.instrument_lags) and instruments_pay(gs, nodes)
    # The instruments: each node's states with the speeds as the scheme's interval means, free
    # of the odd-even mode the lagged node speeds share with the regressors (360 s of the
    # seed-71 trial: mid-stance ankle gains -139 N m/rad from the truth with node speeds, -90
    # with the means, -65 from exact states; 88.9 -> 91.5 % of K within 3 SE).
    pieces = [_signals(r, instrumented) for r in results]
    mid_t, mid_states, mid_torques, lag_states = (
        np.concatenate(column) for column in zip(*pieces, strict=True)
    )
    segments = np.concatenate([np.full(p[0].size, k) for k, p in enumerate(pieces)])
    mid_phase = data.phase.between(mid_t, data.window.time, data.window.phase)
    ok = np.isfinite(mid_phase)
    index = {n: i for i, n in enumerate(state_names())}
    columns = [index[n] for n in data.feedback]
    feedback, instrument_feedback = mid_states[:, columns], lag_states[:, columns]
    strides = np.searchsorted(data.trial.right_heel_strikes, mid_t)
    # smoothed from markers, the torques are the smoother's, whose error (several N m) is no
    # measurement noise the trial records: the bound takes the residual's level
    combined = None if SOURCES[source].lab_markers else torque_equation_noise(meta)
    noise = None if combined is None else np.full(6, combined)
    c.say(
        "controller",
        f"schedule fit at {int(ok.sum())} points where the dynamics hold, sandwich over strides",
    )
    est = fit_schedule_with_errors(
        gs,
        mid_phase[ok],
        feedback[ok],
        mid_torques[ok],
        strides[ok],
        noise,
        instrument_lags=settings.instrument_lags,
        segments=segments[ok],
        instrument_feedback=instrument_feedback[ok],
    )
    how = f"{est.method} ({est.reason})"
    if est.method == "two-stage least squares":
        how += "; the instruments' speeds: the scheme's interval means"
    c.notes.append(
        f"schedule: {how}; standard errors: sandwich over {est.blocks} strides; bound: least "
        "squares with the "
        "fed-back states known, torque noise "
        + (
            f"{float(noise[0]):.3g} N m (measurement and motor noise recorded in the trial)"
            if noise is not None
            else "the residual's ("
            + (
                "the torques are the marker smoother's, not measured"
                if SOURCES[source].lab_markers
                else "no motor noise recorded"
            )
            + ")"
        )
    )
    if recorded_motor_noise(meta) == 0.0:
        c.notes.append(ZERO_MOTOR_NOISE_NOTE)
    c.lap("controller")
    full = _full_design_bound(c, results, source, est) if settings.design_bound == "full" else None
    lasts = [r.stages[-1] for r in results]
    failed = [last for last in lasts if not last.success]
    return Fit(
        ControllerEstimate(
            est.Tstar,
            est.K,
            est.Tstar_se,
            est.K_se,
            est.Tstar_bound,
            est.K_bound,
            *(full or (None, None)),
        ),
        {
            "status": (failed or lasts)[-1].status,  # a window's failure, else the last's
            # a failed continuation step is halved, not fatal
            "success": all(last.success for last in lasts),
            "iterations": int(sum(s.iterations for r in results for s in r.stages)),
            "objective": float(sum(last.objective for last in lasts)),
            "constraint_violation": max(last.max_defect for last in lasts),
            "message": " | ".join("; ".join(s.describe() for s in r.stages) for r in results),
            "log": "",
            "windows": [window_facts(r) for r in results],
        },
        _summed_size([r.size for r in results], gs),
        np.concatenate([r.states[:, 3:9] for r in results]),
    )


def _full_design_bound(
    c: FitContext, results: list[Any], source: str, est: Any
) -> tuple[np.ndarray, np.ndarray] | None:
    """The whole design's bound at the estimate (``--design-bound full``), or None with the
    reason in the notes."""
    from colloc.identify.gait.design_bound import (
        BoundJob,
        WindowDesign,
        full_design_bound,
        lab_signals,
    )
    from colloc.identify.gait.read import subject, tracked_columns
    from colloc.identify.gait.trial_noise import recorded_motor_noise, trial_noise_std

    data, meta = c.data, c.data.trial.metadata
    lab = SOURCES[source].lab_markers
    std = recorded_motor_noise(meta) or 0.0
    said = ""
    if std <= 0.0 and lab and _positive(meta.get("truth_motor_noise")):
        std, said = float(meta["truth_motor_noise"]), " (the --truth trial's)"
    if std <= 0.0:
        c.notes.append(
            "design bound: the trial records no motor noise, the closed loop's residual the "
            "whole design's bound needs"
            + (" (a lab's: give --truth, the simulated walk's trial)" if lab else "")
            + ": only the states-known bound"
        )
        return None
    where = "" if c.map_windows is None else " on the workers"
    c.say("bound", f"the whole design's information, states unknown, piece by piece{where}")
    observed: list[np.ndarray | None] = [None] * len(results)
    if lab:
        signals, masks = lab_signals(
            data.trial, [r.tracking for r in results], [r.times for r in results]
        )
        observed = list(masks)
        noise: tuple[tuple[str, float], ...] = ()
        scheme: type | None = type(results[0].scheme) if results[0].scheme is not None else None
        tracks = (
            f"{len(signals.segments)} markers"
            + (" and the plates" if signals.plate_std is not None else "")
            + ", no torques"
        )
    else:
        signals, scheme = None, None
        noise = tuple(
            (col, trial_noise_std(meta, col)) for col in tracked_columns(c.settings.track)
        )
        tracks = ", ".join(col for col, _ in noise)
    belt = data.window.signals["belt_speed"].to_numpy(dtype=float)
    index = {x: i for i, x in enumerate(c.dyn.model.states)}
    jobs = [
        BoundJob(
            subject(meta),
            c.gs.num_points,
            tuple(index[x] for x in c.gs.feedback),
            c.gs.mask,
            noise,
            std,
            WindowDesign(
                r.times,
                r.states,
                r.torques,
                np.interp(r.times, data.window.time, belt),
                data.phase.between(r.times, data.window.time, data.window.phase),
                seen,
            ),
            est.Tstar,
            est.K,
            lab=signals,
            scheme=scheme,
        )
        for r, seen in zip(results, observed, strict=True)
    ]
    try:
        Tstar_bound, K_bound, count = full_design_bound(c.gs, jobs, c.map_windows)
    except ValueError as error:
        c.notes.append(f"design bound: the whole design's bound failed: {error}")
        return None
    c.lap("bound")
    c.notes.append(
        f"design bound: the whole design's, states unknown (the closed loop's maximum a "
        f"posteriori problem at the estimate tracking {tracks}, motor noise {std:g} N m"
        f"{said}, {count} pieces of the smoothed windows, colloc.identify.gait.design_bound)"
    )
    return Tstar_bound, K_bound


def _positive(value: Any) -> bool:
    return isinstance(value, int | float) and bool(np.isfinite(value)) and value > 0


def _signals(
    result: Any, instrumented: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A window's times, states, torques and the states its instruments lag: the nodes
    (:meth:`~colloc.identify.gait.smoother_results.SmoothedGait.instrument_states` for the
    instruments) for the instrumented fit, else where the scheme holds the dynamics."""
    if instrumented:
        return result.times, result.states, result.torques, result.instrument_states()
    times, states, torques = result.at_dynamics()
    return times, states, torques, states


def _summed_size(sizes: list[dict[str, int]], gs: GainScheduled) -> dict[str, int]:
    """The windows' problem sizes summed, with the controller's parameters and the count."""
    out = {key: sum(size[key] for size in sizes) for key in sizes[0]}
    return out | {"parameters": len(gs.parameters), "windows": len(sizes)}
