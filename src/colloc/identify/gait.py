"""Identify the gain-scheduled controller of a walking trial by direct collocation.

``T(t) = T*(phi) - K(phi) s(t)`` (:class:`colloc.GainScheduled`) closes gait2d; the states at
every node, ``T*`` and ``K`` at ``P`` schedule points are unknown; the objective tracks the
measured signals weighted by ``1 / (sigma^2 N)`` (``sigma`` the trial's noise level of each
signal, the default lab noise where the trial records none). Steps of :func:`identify_gait`,
each timed and reported through ``progress``:

1. ``read``: the trial, checked; the split at the right heel strike nearest the fit fraction;
   the fit window between right heel strikes; every problem with the data reported at once;
2. ``direct``: direct identification, one least squares of the measured torques on the
   measured feedback per torque (:func:`colloc.identify.direct.fit_gain_schedule`), rates by
   Savitzky-Golay differentiation of the positions: the solver's start and the baseline;
3. the fit, by ``settings.method``: ``smooth`` and ``controller`` — the dynamically
   consistent smoother (:mod:`colloc.identify.gait_smoother`) and the schedule's least
   squares on its signals where the scheme holds the dynamics, with stride-sandwich errors
   and the bound of the design (:mod:`colloc.identify.gait_controller_fit`); or ``build``
   and ``solve`` — the closed-loop collocation problem, solved by constrained Gauss-Newton
   with condensing (:meth:`colloc.Problem.solve_gauss_newton`); with ``process_noise``,
   motor noise on each joint torque and residual forces on the trunk are disturbance
   trajectories penalised by their variance (``docs/process-noise.md``);
4. ``uncertainty`` (closed loop): standard errors of every ``T*`` and ``K`` entry from the
   Fisher information at the estimate with the known noise levels
   (:func:`colloc.cramer_rao_bound` evaluated at the solution), or with ``process_noise`` the
   sandwich over strides (:func:`colloc.parameter_uncertainty`);
5. ``validate``: on the held-out part, each controller's torques on the feedback (smoothed
   like the fit window for the smoother fit; measured beside it) against the measured torques
   (VAF per joint), and a forward simulation of gait2d under
   the identified controller from the measured state at the part's start, on its belt record
   (:func:`colloc.gait.closed_loop.simulate_walking`): does it walk to the end, and how far
   are its joint angles from the measured ones.
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TypeGuard

import numpy as np

from colloc.control.gain_scheduled import GainScheduled
from colloc.data.columns import JOINT_ANGLE_COLUMNS, JOINT_RATE_COLUMNS, TORQUE_COLUMNS
from colloc.data.phase import causal_gait_phase, unwrapped_gait_phase
from colloc.data.split import split, stride_windows, take_rows
from colloc.data.trial import Trial, read_trial
from colloc.identify.direct import fit_gain_schedule, smooth_with_derivatives
from colloc.identify.gait_settings import DEFAULT_POINTS, GaitIdentifySettings
from colloc.identify.gait_walk import WalkJob, walk
from colloc.identify.gait_windows import WindowMap, gait_dynamics
from colloc.identify.validation import variance_accounted_for
from colloc.numeric.memory import peak_rss_mb

Progress = Callable[[str, str], None]
Iterations = Callable[[dict[str, float]], Any]

#: Width [m] added below and above the fit part's hip-height range: leaving it in the
#: validation simulation counts as a fall (as in :func:`simulate_walking`'s default).
HIP_MARGIN = 0.15
#: What the validation keeps of the direct fit's held-out walk.
DIRECT_WALK_KEYS = (
    "walks", "message", "simulated_seconds", "strides", "measured_strides", "angle_rms_deg",
)  # fmt: skip
#: The controller structures' names in :class:`GainScheduled`.
JOINT_NAMES = tuple(c.removesuffix("_torque") for c in TORQUE_COLUMNS)


@dataclass
class ControllerEstimate:
    """One controller ``T*``, ``K`` with optional standard errors and the square roots of the
    Cramer-Rao bound's diagonal (the best standard deviations the design allows)."""

    Tstar: np.ndarray
    K: np.ndarray
    Tstar_se: np.ndarray | None = None
    K_se: np.ndarray | None = None
    Tstar_bound: np.ndarray | None = None
    K_bound: np.ndarray | None = None


@dataclass
class GaitIdentification:
    """What :func:`identify_gait` found.

    Attributes
    ----------
    settings : GaitIdentifySettings
    feedback : list of str
        Names of the fed-back signals ``s`` (trial columns).
    mask : ndarray of bool, shape (6, n_s)
        The gains the structure allows.
    points : int
    collocation, direct : ControllerEstimate
        The collocation estimate (with standard errors) and the direct identification.
    truth : ControllerEstimate or None
        The trial's true controller when its metadata records one of this class (same
        ``P``, feedback and structure).
    window : (float, float)
        Fit window [s]; ``split_time`` the first held-out sample's time.
    times, measured, fitted : ndarray
        Fit-window times, measured and identified joint angles (N, 6).
    solver : dict
        ``status``, ``success``, ``iterations``, ``objective``, ``constraint_violation``,
        ``message``, ``log``; the smoother's also ``windows`` (per stride window: ``start``,
        ``stop`` [s], ``nodes``, ``iterations``, wall ``seconds`` and the ``process`` that
        smoothed it).
    validation : dict
        ``torque_vaf`` (``collocation`` / ``direct`` / ``truth`` when the trial records its
        controller -> joint -> VAF), ``walks``, ``direct_walk`` (the direct fit's
        ``walks``, ``message``, ``simulated_seconds``, ``strides``, ``angle_rms_deg``),
        ``simulated_seconds``, ``message``, ``strides`` (the simulation's right heel strikes:
        the strides to a fall if it falls) against ``measured_strides`` (the record's),
        ``angle_rms_deg`` and ``angle_vaf`` (joint -> value), ``times``,
        ``measured_angles``, ``simulated_angles`` (arrays).
    metrics : dict
        ``K_relative_error``, ``Tstar_relative_error`` and their ``direct_`` twins,
        ``fraction_within_3se`` (None without a truth).
    problem_size : dict
        ``nodes``, ``variables``, ``constraints``, ``parameters``, nonzeros.
    data_digest : str
        Hash of the trial's samples and events (:func:`colloc.store.digest_arrays`).
    timings : dict
        Step -> seconds.
    peak_rss_mb : float
        The larger of this process's peak resident memory and its largest child's (each
        IPOPT solve runs in a forked child, :mod:`colloc.solve.watchdog`, whose factors this
        process never holds).
    notes : list of str
    """

    settings: GaitIdentifySettings
    feedback: list[str]
    mask: np.ndarray
    points: int
    collocation: ControllerEstimate
    direct: ControllerEstimate
    truth: ControllerEstimate | None
    window: tuple[float, float]
    split_time: float
    times: np.ndarray
    measured: np.ndarray
    fitted: np.ndarray
    solver: dict[str, Any]
    validation: dict[str, Any]
    metrics: dict[str, float | None]
    problem_size: dict[str, int]
    data_digest: str = ""
    timings: dict[str, float] = field(default_factory=dict)
    peak_rss_mb: float = 0.0
    notes: list[str] = field(default_factory=list)


@dataclass
class _Data:
    """The checked trial, its two parts and the fit window."""

    trial: Trial
    fit: Trial
    held_out: Trial
    rows: np.ndarray  # fit-part rows of the window
    feedback: list[str]
    points: int
    mask_metadata: np.ndarray | None


def identify_gait(
    settings: GaitIdentifySettings,
    progress: Progress | None = None,
    iterations: Iterations | None = None,
    map_windows: WindowMap | None = None,
) -> GaitIdentification:
    """Identify ``T*(phi)`` and ``K(phi)`` from a trial; validate on its held-out part.

    Parameters
    ----------
    settings : GaitIdentifySettings
    progress : callable, optional
        ``progress(step, detail)`` at the start of each step.
    iterations : callable, optional
        Called after each solver iteration with ``iteration``, ``objective``,
        ``infeasibility``.
    map_windows : callable, optional
        ``map_windows(function, jobs) -> results`` runs the independent pieces elsewhere,
        e.g. on Dask workers: the stride windows of method ``smoother``
        (``settings.window_strides``, :mod:`colloc.identify.gait_windows`) and the
        held-out part's two forward simulations (:mod:`colloc.identify.gait_walk`); default
        one after another here.

    Returns
    -------
    GaitIdentification

    Raises
    ------
    ValueError
        On bad settings, or a trial the identification cannot use (every problem named at
        once, before any heavy work): no right heel strikes in a part, too few strides for
        ``P``, missing columns for the feedback, the phase or the tracked signals, metadata
        that disagree with the columns.
    """
    settings.validate()
    say = progress or (lambda step, detail: None)
    timings: dict[str, float] = {}
    notes: list[str] = []
    clock = time.perf_counter()

    def lap(step: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        timings[step] = now - clock
        clock = now

    say("read", f"trial {settings.trial}")
    data = _read(settings)
    lap("read")

    # heavy imports only once the data are known to be usable

    meta = data.trial.metadata
    dyn = gait_dynamics(*_subject(meta))
    model, torques = dyn.model, dyn.gait.torques
    state_index = {name: i for i, name in enumerate(_state_names())}
    feedback_states = [model.states[state_index[n]] for n in data.feedback]
    gs = GainScheduled(data.points, feedback_states, torques, structure=settings.structure)
    fit = data.fit
    t = fit.time[data.rows]
    signals = fit.signals.iloc[data.rows].reset_index(drop=True)
    phase = _phase(settings.phase, data.trial, t, signals)
    if settings.phase == "causal":
        stride, phi0, source = causal_phase_parameters(meta, data.trial.right_heel_strikes)
        notes.append(
            f"phase: causal, reset to {phi0:.4g} at each right heel strike, one cycle per "
            f"{stride:.4g} s ({source})"
        )
    states = _measured_states(t, signals, settings.smoothing_window)
    fb_columns = [state_index[n] for n in data.feedback]
    measured_torques = signals[list(TORQUE_COLUMNS)].to_numpy()

    say(
        "direct", f"least squares of the torques on {len(data.feedback)} signals, P = {data.points}"
    )
    direct_fit = fit_gain_schedule(gs, phase, states[:, fb_columns], measured_torques)
    direct = ControllerEstimate(direct_fit.Tstar, direct_fit.K)
    lap("direct")

    context = _FitContext(
        settings,
        data,
        dyn,
        gs,
        t,
        signals,
        phase,
        states,
        direct,
        say,
        iterations,
        notes,
        lap,
        map_windows,
    )
    outcome = _FITS[settings.method](context)
    collocation = outcome.estimate

    truth = _truth(meta, data, gs, notes)
    say("validate", f"held-out {data.held_out.time[-1] - data.held_out.time[0]:.1f} s")
    # the trial's own controller, when it records one, beside them: the VAF a consistent
    # estimate approaches (the direct fit's attenuated gains can predict noisy states better)
    compared = {"collocation": collocation, "direct": direct} | ({"truth": truth} if truth else {})
    validation = _validate(settings, data, gs, compared, say, map_windows)
    lap("validate")

    return GaitIdentification(
        settings=settings,
        feedback=list(data.feedback),
        mask=gs.mask.copy(),
        points=data.points,
        collocation=collocation,
        direct=direct,
        truth=truth,
        window=(float(t[0]), float(t[-1])),
        split_time=float(data.held_out.time[0]),
        times=t,
        measured=signals[list(JOINT_ANGLE_COLUMNS)].to_numpy(),
        fitted=outcome.fitted,
        solver=outcome.solver,
        validation=validation,
        metrics=_metrics(collocation, direct, truth, gs.mask),
        problem_size=outcome.problem_size,
        data_digest=_digest(data.trial),
        timings=timings,
        peak_rss_mb=peak_rss_mb(),
        notes=notes,
    )


# ----------------------------------------------------------------------------- the fits


@dataclass
class _FitContext:
    """What both fits read: the settings, the data and the direct start."""

    settings: GaitIdentifySettings
    data: _Data
    dyn: Any
    gs: GainScheduled
    t: np.ndarray
    signals: Any
    phase: np.ndarray
    states: np.ndarray
    direct: ControllerEstimate
    say: Progress
    iterations: Iterations | None
    notes: list[str]
    lap: Callable[[str], None]
    map_windows: WindowMap | None = None


@dataclass
class _Fit:
    """A fit's estimate, solver record, problem size and fitted joint angles."""

    estimate: ControllerEstimate
    solver: dict[str, Any]
    problem_size: dict[str, int]
    fitted: np.ndarray


def _closed_loop_fit(c: _FitContext) -> _Fit:
    """The closed-loop collocation problem (all states free, the schedule's parameters in the
    dynamics) solved by constrained Gauss-Newton from the direct start."""
    settings, data, gs, t, say, lap = c.settings, c.data, c.gs, c.t, c.say, c.lap
    model = c.dyn.model
    say("build", f"{t.size} nodes, {len(gs.parameters)} controller parameters")
    problem, weights_n = _problem(settings, c.dyn, gs, t, c.signals, c.phase, data.trial.metadata)
    guess = (
        gs.parameter_values(c.direct.Tstar, c.direct.K)
        if settings.guess == "direct"
        else {p: 0.0 for p in gs.parameters}
    )
    z0 = problem.initial_guess(dict(zip(model.states, c.states.T, strict=True)), guess)
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

    return _Fit(
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


def _smoother_fit(c: _FitContext) -> _Fit:
    """The dynamically consistent smoother (:mod:`colloc.identify.gait_smoother`), then the
    schedule's two-stage least squares on its node signals (or the ordinary least squares at
    the interval midpoints), with stride-sandwich errors and the bound of the design
    (:mod:`colloc.identify.gait_controller_fit`)."""
    from colloc.identify.gait_controller_fit import fit_schedule_with_errors, instruments_pay
    from colloc.identify.gait_smoother import trial_noise_std
    from colloc.identify.gait_windows import smooth_windows

    settings, data, gs = c.settings, c.data, c.gs
    meta = data.trial.metadata
    windows = _windows(settings, c.t, data.trial.right_heel_strikes)
    jobs = _window_jobs(data.fit, data.rows, windows, meta, "stride window")
    where = "" if c.map_windows is None else " on the workers"
    c.say("smooth", f"{len(jobs)} window(s){where}: backward Euler, midpoint, continuation")
    results = smooth_windows(jobs, _prefixed(c.say, "smooth"), c.map_windows)
    c.lap("smooth")

    # Ordinary least squares reads the signals where the scheme holds the dynamics (the
    # midpoints' averages cancel the midpoint rule's odd-even mode); the instrumented fit
    # reads the nodes, whose lagged states are the better instruments (on the 120 s motor-
    # noise trial K 30 % at the nodes, 40 % at the midpoints; docs/gait.md).
    nodes = sum(r.times.size for r in results)
    instrumented = bool(settings.instrument_lags) and instruments_pay(gs, nodes)
    pieces = [(r.times, r.states, r.torques) if instrumented else r.at_dynamics() for r in results]
    mid_t, mid_states, mid_torques = (
        np.concatenate(column) for column in zip(*pieces, strict=True)
    )
    segments = np.concatenate([np.full(p[0].size, k) for k, p in enumerate(pieces)])
    if settings.phase == "controller":
        mid_phase = np.interp(mid_t, c.t, c.phase)
    else:
        mid_phase = _phase(settings.phase, data.trial, mid_t, None)
    ok = np.isfinite(mid_phase)
    index = {n: i for i, n in enumerate(_state_names())}
    feedback = mid_states[:, [index[n] for n in data.feedback]]
    strides = np.searchsorted(data.trial.right_heel_strikes, mid_t)
    torque_std = trial_noise_std(meta, TORQUE_COLUMNS[0])
    motor = meta.get("motor_noise")
    motor_std = float(motor.get("std", 0.0)) if isinstance(motor, dict) else None
    noise = None if motor_std is None else np.full(6, np.hypot(torque_std, motor_std))
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
    )
    how = f"{est.method} ({est.reason})"
    c.notes.append(
        f"schedule: {how}; standard errors: sandwich over {est.blocks} strides; bound: least "
        "squares with the "
        "fed-back states known, torque noise "
        + (
            f"{float(noise[0]):.3g} N m (measurement and motor noise recorded in the trial)"
            if noise is not None
            else "the residual's (no motor noise recorded)"
        )
    )
    c.lap("controller")
    lasts = [r.stages[-1] for r in results]
    failed = [last for last in lasts if not last.success]
    return _Fit(
        ControllerEstimate(est.Tstar, est.K, est.Tstar_se, est.K_se, est.Tstar_bound, est.K_bound),
        {
            "status": (failed or lasts)[-1].status,  # a window's failure, else the last's
            # a failed continuation step is halved, not fatal
            "success": all(last.success for last in lasts),
            "iterations": int(sum(s.iterations for r in results for s in r.stages)),
            "objective": float(sum(last.objective for last in lasts)),
            "constraint_violation": max(last.max_defect for last in lasts),
            "message": " | ".join("; ".join(s.describe() for s in r.stages) for r in results),
            "log": "",
            "windows": [_window_facts(r) for r in results],
        },
        _summed_size([r.size for r in results], gs),
        np.concatenate([r.states[:, 3:9] for r in results]),
    )


def _subject(meta: dict[str, Any]) -> tuple[float, float]:
    """Body mass [kg] and height [m] a trial's metadata records (75 kg, 1.8 m if not)."""
    return float(meta.get("body_mass", 75.0)), float(meta.get("height", 1.8))


def _window_facts(result: Any) -> dict[str, Any]:
    """What one smoothed window cost and where it ran (the summary's ``windows``)."""
    return {
        "start": float(result.times[0]),
        "stop": float(result.times[-1]),
        "nodes": int(result.times.size),
        "iterations": int(sum(s.iterations for s in result.stages)),
        "seconds": float(result.seconds),
        "process": result.process,
    }


def _windows(
    settings: GaitIdentifySettings, times: np.ndarray, strikes: np.ndarray
) -> list[tuple[int, int]]:
    """The smoother's windows of a record: all of it, or ``settings.window_strides``."""
    if settings.window_strides is None:
        return [(0, times.size)]
    return stride_windows(times, strikes, settings.window_strides)


def _window_jobs(
    part: Trial,
    rows: np.ndarray,
    windows: list[tuple[int, int]],
    meta: dict[str, Any],
    name: str,
) -> list[Any]:
    """One smoothing job per window of ``part``'s samples ``rows`` (each its own samples
    alone: what travels to a worker)."""
    from colloc.identify.gait_windows import WindowJob

    body = _subject(meta)
    return [
        WindowJob(
            take_rows(part, rows[first:stop]),
            np.arange(stop - first),
            "" if len(windows) == 1 else f"{name} {k + 1}/{len(windows)}, ",
            *body,
        )
        for k, (first, stop) in enumerate(windows)
    ]


def _prefixed(say: Progress, step: str) -> Progress:
    """``say`` under ``step``, each stage's name leading its report."""

    def report(stage: str, detail: str) -> None:
        say(step, f"{stage}: {detail}")

    return report


def _problem_size(problem: Any, gs: GainScheduled) -> dict[str, int]:
    """A solved problem's size with the controller's parameters."""
    return problem.size | {"parameters": len(gs.parameters)}


def _summed_size(sizes: list[dict[str, int]], gs: GainScheduled) -> dict[str, int]:
    """The windows' problem sizes summed, with the controller's parameters and the count."""
    out = {key: sum(size[key] for size in sizes) for key in sizes[0]}
    return out | {"parameters": len(gs.parameters), "windows": len(sizes)}


#: ``GaitIdentifySettings.method`` -> the fit.
_FITS: dict[str, Callable[[_FitContext], _Fit]] = {
    "smoother": _smoother_fit,
    "closed-loop": _closed_loop_fit,
}


# ----------------------------------------------------------------------------- reading


def _state_names() -> tuple[str, ...]:
    from colloc.gait.metadata import STATE_SIGNAL_NAMES

    return STATE_SIGNAL_NAMES


def _recorded_controller(meta: dict[str, Any]) -> dict[str, Any] | None:
    """The controller entry of a trial's metadata (a synthetic trial's truth), or None."""
    recorded = meta.get("controller")
    return recorded if isinstance(recorded, dict) else None


def _feedback_names(choice: str, meta: dict[str, Any]) -> list[str]:
    from colloc.gait.design import FEEDBACK_SETS

    if choice == "metadata":
        recorded = _recorded_controller(meta) or {}
        if "feedback" in recorded:
            return list(recorded["feedback"])
        return list(JOINT_ANGLE_COLUMNS + JOINT_RATE_COLUMNS)
    names = _state_names()
    return [names[i] for i in FEEDBACK_SETS[choice]]


def _tracked_columns(track: tuple[str, ...]) -> list[str]:
    from colloc.data.columns import TRUNK_COLUMNS, TRUNK_RATE_COLUMNS

    groups = {
        "trunk": list(TRUNK_COLUMNS),
        "angles": list(JOINT_ANGLE_COLUMNS),
        "rates": list(TRUNK_RATE_COLUMNS + JOINT_RATE_COLUMNS),
        "torques": list(TORQUE_COLUMNS),
    }
    return [
        c for name in ("trunk", "angles", "rates", "torques") if name in track for c in groups[name]
    ]


def _read(settings: GaitIdentifySettings) -> _Data:
    """Read and check the trial; split it; choose the fit window. All problems at once."""
    trial = read_trial(settings.trial)
    meta = trial.metadata
    problems: list[str] = []
    feedback = _feedback_names(settings.feedback, meta)
    unknown = [n for n in feedback if n not in _state_names()]
    if unknown:
        problems.append(f"metadata: controller feedback names {unknown} are not state signals")
    needed = set(feedback) - set(unknown)
    needed |= {"belt_speed", *TORQUE_COLUMNS, *_tracked_columns(settings.track)}
    needed |= set(JOINT_ANGLE_COLUMNS) | {"trunk_x", "trunk_y", "trunk_angle"}
    if settings.phase == "controller":
        needed.add("controller_phase")
    missing = sorted(needed - set(trial.signals.columns))
    if missing:
        problems.append(
            f"trial: missing columns {missing} (needed by the feedback, the tracked signals, "
            f"the belt or --phase {settings.phase})"
        )
    recorded = _recorded_controller(meta)
    mask_metadata = None
    points = settings.points
    if recorded is not None:
        problems += _metadata_problems(recorded)
        if not problems and "mask" in recorded:
            mask_metadata = np.asarray(recorded["mask"], dtype=bool)
        if points is None and isinstance(recorded.get("num_points"), int):
            points = int(recorded["num_points"])
    points = DEFAULT_POINTS if points is None else points
    strikes = trial.right_heel_strikes
    if strikes.size < 4:
        problems.append(
            f"trial: expected right heel strikes to split and phase the trial, found "
            f"{strikes.size} (events file)"
        )
    if problems:
        raise ValueError("colloc gait identify: " + "; ".join(problems))

    t0, t1 = float(trial.time[0]), float(trial.time[-1])
    target = t0 + settings.fit_fraction * (t1 - t0)
    split_strike = float(strikes[np.argmin(np.abs(strikes - target))])
    index = int(np.searchsorted(trial.time, split_strike - 1e-9))
    fit, held_out = split(trial, index / trial.time.size)
    first = fit.time[0] + settings.start
    window_strikes = fit.right_heel_strikes[fit.right_heel_strikes >= first - 1e-9]
    if settings.duration is not None:
        window_strikes = window_strikes[window_strikes <= first + settings.duration + 1e-9]
    strides = window_strikes.size - 1
    width = 1 + (len(feedback) if settings.structure == "full" else 2)
    if strides < 2:
        problems.append(
            f"fit window: from {first:.2f} s{'' if settings.duration is None else f' for {settings.duration} s'}"
            f" holds {max(strides, 0)} complete strides between right heel strikes; expected "
            f"at least 2 (lengthen --duration or lower --start)"
        )
    else:
        rows = np.flatnonzero(
            (fit.time >= window_strikes[0] - 1e-9) & (fit.time <= window_strikes[-1] + 1e-9)
        )
        # each schedule point's least squares needs more samples nearby than unknowns; about
        # 2 h-spaced samples per point per stride reach it after width / 2 strides
        samples_per_point = rows.size / points
        if samples_per_point < width:
            problems.append(
                f"fit window: {rows.size} samples for P = {points} points of {width} unknowns "
                f"per torque; expected at least {width * points} (record more strides, or "
                f"lower --points)"
            )
    if problems:
        raise ValueError("colloc gait identify: " + "; ".join(problems))
    return _Data(trial, fit, held_out, rows, feedback, points, mask_metadata)


def _digest(trial: Trial) -> str:
    from colloc.store.ids import digest_arrays

    return digest_arrays(
        {
            "time": trial.time,
            "signals": trial.signals.select_dtypes("number").to_numpy(),
            "right_heel_strikes": trial.right_heel_strikes,
            "left_heel_strikes": trial.left_heel_strikes,
        }
    )


def _metadata_problems(recorded: dict[str, Any]) -> list[str]:
    out = []
    names = recorded.get("feedback")
    if names is not None and not isinstance(names, list):
        return [f"metadata: controller feedback: expected a list of names, found {names!r}"]
    if {"Tstar", "K", "mask"} <= set(recorded):
        arrays = {}
        for key, kind in (("Tstar", float), ("K", float), ("mask", bool)):
            try:
                arrays[key] = np.asarray(recorded[key], dtype=kind)
            except (TypeError, ValueError) as error:
                out.append(
                    f"metadata: controller {key}: expected a rectangular array of numbers, "
                    f"found one that is not ({error})"
                )
        if out:
            return out
        Tstar, K, mask = arrays["Tstar"], arrays["K"], arrays["mask"]
        ns = len(names) if names is not None else 2 * len(TORQUE_COLUMNS)
        m = len(TORQUE_COLUMNS)
        P = Tstar.shape[0] if Tstar.ndim == 2 else -1
        if Tstar.shape != (P, m) or K.shape != (P, m, ns) or mask.shape != (m, ns):
            out.append(
                f"metadata: controller Tstar {Tstar.shape}, K {K.shape} and mask {mask.shape} "
                f"disagree with {m} torques and {ns} feedback signals; expected (P, {m}), "
                f"(P, {m}, {ns}) and ({m}, {ns})"
            )
        num_points = recorded.get("num_points")
        if num_points is not None and num_points != P:
            out.append(f"metadata: controller num_points {num_points} but Tstar has {P} rows")
    return out


def _phase(convention: str, trial: Any, t: np.ndarray, signals: Any) -> np.ndarray:
    """Unwrapped phase in cycles at times ``t``: causal from the right heel strikes (the
    default), linear between them, or the trial's ``controller_phase`` column (``signals``,
    rows at ``t``)."""
    if convention == "controller":
        return signals["controller_phase"].to_numpy(dtype=float)
    strikes = trial.right_heel_strikes
    if convention == "heel-strikes":
        return unwrapped_gait_phase(t, strikes)
    stride, phi0, _ = causal_phase_parameters(trial.metadata, strikes)
    return causal_gait_phase(t, strikes, stride, phi0)


def causal_phase_parameters(
    metadata: dict[str, Any], strikes: np.ndarray
) -> tuple[float, float, str]:
    """``D``, ``phi_0`` and where they came from, for :func:`colloc.data.causal_gait_phase`.

    A synthetic trial records its controller's (``controller.stride_duration``,
    ``controller.phase_at_strike``); otherwise ``D`` is the designed cycle's duration
    (``cycle.duration``) or the median stride, and ``phi_0`` is 0 (the schedule starts at the
    heel strike).

    Parameters
    ----------
    metadata : dict
        The trial's metadata.
    strikes : ndarray
        Right heel-strike times.

    Returns
    -------
    stride_duration : float
    phase_at_strike : float
    source : str
    """
    controller = metadata.get("controller") if isinstance(metadata, dict) else None
    controller = controller if isinstance(controller, dict) else {}
    cycle = metadata.get("cycle") if isinstance(metadata, dict) else None
    cycle = cycle if isinstance(cycle, dict) else {}
    recorded, designed = controller.get("stride_duration"), cycle.get("duration")
    if _positive(recorded):
        stride, source = float(recorded), "the trial's controller"
    elif _positive(designed):
        stride, source = float(designed), "the trial's designed cycle"
    else:
        stride, source = float(np.median(np.diff(strikes))), "the median stride"
    given = controller.get("phase_at_strike")
    phi0 = float(given) if isinstance(given, int | float) and 0 <= given < 1 else 0.0
    return stride, phi0, source


def _positive(value: object) -> TypeGuard[float]:
    return isinstance(value, int | float) and not isinstance(value, bool) and 0 < value < np.inf


def _measured_states(t: np.ndarray, signals: Any, window: float) -> np.ndarray:
    """``[q, u]`` from the measured signals: the trial's rate columns where it has them (a gait
    lab's marker velocities), else Savitzky-Golay derivatives of the positions.

    Measured on the noise-free 60 s default trial: direct identification from the rate
    columns recovers K exactly, from Savitzky-Golay rates (0.05 s) with 14 % error.
    """
    names = _state_names()
    positions = signals[list(names[:9])].to_numpy(dtype=float)
    if all(c in signals.columns for c in names[9:]):
        return np.hstack([positions, signals[list(names[9:])].to_numpy(dtype=float)])
    _, rates, _ = smooth_with_derivatives(t, positions, window)
    return np.hstack([positions, rates])


# ----------------------------------------------------------------------------- the problem


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

    from colloc.identify.gait_smoother import trial_noise_std
    from colloc.model.symbols import name_of
    from colloc.nlp.objective import Tracking
    from colloc.nlp.problem import Problem
    from colloc.transcription import BackwardEuler, Midpoint

    model, gait = dyn.model, dyn.gait
    by_column = dict(zip(_state_names(), model.states, strict=True))
    by_column.update(zip(TORQUE_COLUMNS, gait.torques, strict=True))
    columns = _tracked_columns(settings.track)
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


# ----------------------------------------------------------------------------- estimates


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


def _truth(
    meta: dict[str, Any], data: _Data, gs: GainScheduled, notes: list[str]
) -> ControllerEstimate | None:
    """The trial's true controller when it lies in the identified class."""
    recorded = _recorded_controller(meta)
    if recorded is None or not {"Tstar", "K", "mask"} <= set(recorded):
        return None
    Tstar = np.asarray(recorded["Tstar"], dtype=float)
    K = np.asarray(recorded["K"], dtype=float)
    names = list(recorded.get("feedback", JOINT_ANGLE_COLUMNS + JOINT_RATE_COLUMNS))
    if Tstar.shape[0] != data.points or names != data.feedback:
        notes.append(
            f"the trial's controller (P = {Tstar.shape[0]}, feedback {names}) is not of the "
            f"identified class (P = {data.points}, feedback {data.feedback}): no errors "
            "against the truth"
        )
        return None
    if np.any(K[:, ~gs.mask] != 0):
        notes.append(
            "the trial's controller has gains outside the identified structure; its errors "
            "count those gains as missed"
        )
    return ControllerEstimate(Tstar, K)


def _metrics(
    collocation: ControllerEstimate,
    direct: ControllerEstimate,
    truth: ControllerEstimate | None,
    mask: np.ndarray,
) -> dict[str, float | None]:
    out: dict[str, float | None] = dict.fromkeys(
        (
            "K_relative_error",
            "Tstar_relative_error",
            "direct_K_relative_error",
            "direct_Tstar_relative_error",
            "fraction_within_3se",
            "K_relative_bound",
            "Tstar_relative_bound",
        )
    )
    if collocation.K_bound is not None and collocation.Tstar_bound is not None:
        from colloc.identify.gait_controller_fit import relative_spread

        # relative to the truth when there is one, else to the estimate
        reference = truth or collocation
        out["K_relative_bound"] = relative_spread(collocation.K_bound, reference.K)
        out["Tstar_relative_bound"] = relative_spread(collocation.Tstar_bound, reference.Tstar)
    if truth is None:
        return out
    for prefix, est in (("", collocation), ("direct_", direct)):
        out[f"{prefix}K_relative_error"] = _relative(est.K, truth.K)
        out[f"{prefix}Tstar_relative_error"] = _relative(est.Tstar, truth.Tstar)
    if collocation.K_se is not None and collocation.Tstar_se is not None:
        error = np.r_[
            (collocation.Tstar - truth.Tstar).ravel(), (collocation.K - truth.K)[:, mask].ravel()
        ]
        se = np.r_[collocation.Tstar_se.ravel(), collocation.K_se[:, mask].ravel()]
        out["fraction_within_3se"] = float(np.mean(np.abs(error) <= 3.0 * se))
    return out


def _relative(estimate: np.ndarray, truth: np.ndarray) -> float:
    return float(np.linalg.norm(estimate - truth) / np.linalg.norm(truth))


# ----------------------------------------------------------------------------- validation


def _validate(
    settings: GaitIdentifySettings,
    data: _Data,
    gs: GainScheduled,
    controllers: dict[str, ControllerEstimate],
    say: Progress,
    map_windows: WindowMap | None = None,
) -> dict[str, Any]:
    """Torque VAF of each controller, and the forward simulations of the held-out part
    under the identified and the direct controllers (through ``map_windows`` when given)."""
    part = data.held_out
    t, signals = part.time, part.signals
    phase_all = _phase(settings.phase, data.trial, t, signals)
    # outside the strikes the phase may be unknown (after the last, linear between strikes;
    # before the first, causal): the torque check keeps the samples that have one
    rows = np.flatnonzero(np.isfinite(phase_all))
    states = _measured_states(t, signals, settings.smoothing_window)
    index = {n: i for i, n in enumerate(_state_names())}
    feedback = [index[n] for n in data.feedback]
    measured = signals[list(TORQUE_COLUMNS)].to_numpy(dtype=float)
    out: dict[str, Any] = {"torque_vaf": {}, "torque_vaf_measured_states": {}}
    bases = {"torque_vaf_measured_states": (phase_all[rows], states[rows], measured[rows])}
    if settings.method == "smoother":
        # the held-out states as the fit saw its own: the smoother's (the controller's
        # prediction from noisy measured states carries K times their noise, which favours
        # the attenuated gains of a least squares on noisy data)
        bases["torque_vaf"] = _smoothed_held_out(settings, data, phase_all, say, map_windows)
    else:
        bases["torque_vaf"] = bases["torque_vaf_measured_states"]
    for key, (phase, x, torque) in bases.items():
        for name, est in controllers.items():
            predicted = gs.torque(phase, x[:, feedback], est.Tstar, est.K)
            vaf = variance_accounted_for(torque, predicted)
            out[key][name] = dict(zip(JOINT_NAMES, map(float, vaf), strict=True))
    if not settings.simulate_validation:
        out.update(walks=None, message="not simulated (simulate_validation=False)")
        return out
    # the baseline walked too: whether its gains hold the gait is what tells them apart when
    # its attenuated gains predict noisy states' torques as well (torque_vaf); the two walks
    # run side by side on the workers when there are some
    identified_job = _walk_job(settings, data, controllers["collocation"], states, phase_all)
    direct = controllers["direct"]
    jobs = [identified_job, dataclasses.replace(identified_job, Tstar=direct.Tstar, K=direct.K)]
    say("validate", "forward simulations of the held-out part (identified, direct)")
    identified, baseline = (
        (walk(job) for job in jobs) if map_windows is None else map_windows(walk, jobs)
    )
    out.update(identified)
    out["direct_walk"] = {k: baseline[k] for k in DIRECT_WALK_KEYS}
    return out


def _smoothed_held_out(
    settings: GaitIdentifySettings,
    data: _Data,
    phase: np.ndarray,
    say: Progress,
    map_windows: WindowMap | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Phase, smoothed states and measured torques of the held-out part where the smoother's
    scheme holds the dynamics (the held-out part smoothed like the fit window, in the same
    windows and on the same workers)."""
    from colloc.identify.gait_windows import smooth_windows

    part = data.held_out
    rows = np.arange(part.time.size)
    windows = _windows(settings, part.time, part.right_heel_strikes)
    jobs = _window_jobs(part, rows, windows, data.trial.metadata, "held-out window")
    results = smooth_windows(jobs, _prefixed(say, "validate"), map_windows)
    pieces = [result.at_dynamics() for result in results]
    at_t, at_states = (np.concatenate([p[i] for p in pieces]) for i in (0, 1))
    at_phase = np.interp(at_t, part.time, phase, left=np.nan, right=np.nan)
    measured = part.signals[list(TORQUE_COLUMNS)].to_numpy(dtype=float)
    at_torques = np.column_stack([np.interp(at_t, part.time, m) for m in measured.T])
    ok = np.isfinite(at_phase)
    return at_phase[ok], at_states[ok], at_torques[ok]


def _walk_job(
    settings: GaitIdentifySettings,
    data: _Data,
    est: ControllerEstimate,
    states: np.ndarray,
    phase: np.ndarray,
) -> WalkJob:
    """The forward simulation of the held-out part under ``est`` from its measured start,
    with the phase law of ``settings.phase``."""
    part, fit = data.held_out, data.fit
    if settings.phase == "controller":
        column = fit.signals["controller_phase"].to_numpy(dtype=float)
        steps = np.diff(column)
        rate = float(np.median(steps[steps > 0]) / np.median(np.diff(fit.time)))
        stride = 1.0 / rate
        after = np.searchsorted(fit.time, fit.right_heel_strikes[1:])
        after = after[after < fit.time.size]
        phi0 = np.mod(
            column[after] - (fit.time[after] - fit.right_heel_strikes[1 : 1 + after.size]) * rate,
            1.0,
        )
        strike_phase = float(np.median(phi0))
    elif settings.phase == "causal":
        stride, strike_phase, _ = causal_phase_parameters(
            data.trial.metadata, data.trial.right_heel_strikes
        )
    else:
        stride = float(np.median(np.diff(fit.right_heel_strikes)))
        strike_phase = 0.0
    hip = fit.signals["trunk_y"].to_numpy(dtype=float)
    index = {n: i for i, n in enumerate(_state_names())}
    body_mass, height = _subject(data.trial.metadata)
    return WalkJob(
        Tstar=est.Tstar,
        K=est.K,
        feedback=np.array([index[n] for n in data.feedback]),
        times=part.time,
        belt_speed=part.signals["belt_speed"].to_numpy(dtype=float),
        initial_state=states[0],
        measured_angles=part.signals[list(JOINT_ANGLE_COLUMNS)].to_numpy(dtype=float),
        measured_strikes=part.right_heel_strikes - part.time[0],
        stride=stride,
        strike_phase=strike_phase,
        start_phase=float(np.mod(phase[0], 1.0)),
        hip_height_range=(float(hip.min()) - HIP_MARGIN, float(hip.max()) + HIP_MARGIN),
        sample_rate=float(1.0 / np.median(np.diff(part.time))),
        body_mass=body_mass,
        height=height,
        joint_names=JOINT_NAMES,
    )
