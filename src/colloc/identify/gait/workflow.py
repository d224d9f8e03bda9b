"""Identify the gain-scheduled controller of a walking trial by direct collocation.

``T(t) = T*(phi) - K(phi) s(t)`` (:class:`colloc.GainScheduled`) closes gait2d; the states at
every node, ``T*`` and ``K`` at ``P`` schedule points are unknown; the objective tracks the
measured signals weighted by ``1 / (sigma^2 N)`` (``sigma`` the trial's noise level of each
signal, the default lab noise where the trial records none). Steps of :func:`identify_gait`,
each timed and reported through ``progress``:

1. ``read`` (:mod:`~colloc.identify.gait.read`): the trial, checked; the split at the right
   heel strike nearest the fit fraction; the fit window between right heel strikes; every
   problem with the data reported at once;
2. ``direct``: direct identification, one least squares of the measured torques on the
   measured feedback per torque (:func:`colloc.identify.direct.fit_gain_schedule`), rates by
   Savitzky-Golay differentiation of the positions: the solver's start and the baseline;
3. the fit, by ``settings.method`` (:mod:`~colloc.identify.gait.smoother_fit`,
   :mod:`~colloc.identify.gait.closed_loop`): ``smooth`` and ``controller`` — the dynamically
   consistent smoother (:mod:`colloc.identify.gait.smoother`) and the schedule's least
   squares on its signals where the scheme holds the dynamics, with stride-sandwich errors
   and the bound of the design (:mod:`colloc.identify.gait.controller_fit`); or ``build``
   and ``solve`` — the closed-loop collocation problem, solved by constrained Gauss-Newton
   with condensing (:meth:`colloc.Problem.solve_gauss_newton`); with ``process_noise``,
   motor noise on each joint torque and residual forces on the trunk are disturbance
   trajectories penalised by their variance (``docs/process-noise.md``);
4. ``uncertainty`` (closed loop; against the truth when the trial records it:
   :mod:`~colloc.identify.gait.estimate`): standard errors of every ``T*`` and ``K`` entry from the
   Fisher information at the estimate with the known noise levels
   (:func:`colloc.cramer_rao_bound` evaluated at the solution), or with ``process_noise`` the
   sandwich over strides (:func:`colloc.parameter_uncertainty`);
5. ``validate`` (:mod:`~colloc.identify.gait.validation`): on the held-out part, each controller's torques on the feedback (smoothed
   like the fit window for the smoother fit; measured beside it) against the measured torques
   (VAF per joint), and a forward simulation of gait2d under
   the identified controller from the measured state at the part's start, on its belt record
   (:func:`colloc.gait.closed_loop.simulate_walking`): does it walk to the end, and how far
   are its joint angles from the measured ones.

Figures, the stored record and the summary: :mod:`~colloc.identify.gait.outputs`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from colloc.control.gain_scheduled import GainScheduled
from colloc.data.columns import JOINT_ANGLE_COLUMNS, TORQUE_COLUMNS
from colloc.identify.direct import fit_gain_schedule
from colloc.identify.gait.closed_loop import closed_loop_fit
from colloc.identify.gait.estimate import (
    JOINT_NAMES,
    ControllerEstimate,
    estimate_metrics,
    mean_signals_by_phase,
    true_controller,
)
from colloc.identify.gait.read import (
    read_gait_data,
    state_names,
    subject,
    subject_note,
    trial_digest,
)
from colloc.identify.gait.settings import GaitIdentifySettings
from colloc.identify.gait.smoother_fit import smoother_fit
from colloc.identify.gait.stage import Fit, FitContext, Iterations, Progress
from colloc.identify.gait.validation import validate
from colloc.identify.gait.windows import WindowMap, gait_dynamics
from colloc.numeric.memory import peak_rss_mb

__all__ = ["JOINT_NAMES", "ControllerEstimate", "GaitIdentification", "identify_gait"]


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
        controller -> joint -> VAF), ``walks``, ``direct_walk`` and, when the truth is
        known, ``truth_walk`` (that controller's ``walks``, ``message``,
        ``simulated_seconds``, ``strides``, ``angle_rms_deg``, ``angle_rms_phase_deg``),
        ``simulated_seconds``, ``message``, ``strides`` (the simulation's right heel strikes:
        the strides to a fall if it falls) against ``measured_strides`` (the record's),
        ``angle_rms_deg``, ``angle_vaf`` and ``angle_rms_phase_deg`` (joint -> value; the
        last between mean strides), ``against_truth_walk``
        (:func:`colloc.identify.gait.validation.against_walk`), ``times``,
        ``measured_angles``, ``simulated_angles`` (arrays) and ``walk_signals`` (each
        walk's whole result).
    metrics : dict
        ``K_relative_error``, ``Tstar_relative_error`` and their ``direct_`` twins,
        ``fraction_within_3se`` (None without a truth).
    problem_size : dict
        ``nodes``, ``variables``, ``constraints``, ``parameters``, nonzeros.
    data_digest : str
        Hash of the trial's samples and events (:func:`colloc.store.digest_arrays`).
    timings : dict
        Step -> seconds.
    mean_signals : ndarray, shape (P, n_s)
        The fed-back signals averaged per schedule point over the fit window
        (:func:`colloc.identify.gait.estimate.mean_signals_by_phase`): the mean gait cycle
        on which ``T0 = T* - K s_mean`` is the controller's joint-moment profile.
    model : dict
        ``subject`` (mass and height and where they came from) and ``constants``: every
        number of the gait2d model the fit used (:class:`colloc.models.gait2d_params.
        Gait2DParameters`: segments, contact, gravity).
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
    mean_signals: np.ndarray | None = None
    model: dict[str, Any] = field(default_factory=dict)
    timings: dict[str, float] = field(default_factory=dict)
    peak_rss_mb: float = 0.0
    notes: list[str] = field(default_factory=list)


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
        (``settings.window_strides``, :mod:`colloc.identify.gait.windows`) and the
        held-out part's two forward simulations (:mod:`colloc.identify.gait.walk`); default
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
    data = read_gait_data(settings)
    lap("read")

    # heavy imports only once the data are known to be usable

    meta = data.trial.metadata
    dyn = gait_dynamics(*subject(meta))
    notes.append(subject_note(meta))
    from colloc.models.gait2d_params import load_parameters

    model_facts = {
        "subject": subject_note(meta).removeprefix("subject: "),
        "constants": asdict(load_parameters(*subject(meta))),
    }
    if settings.truth is not None:
        notes.append(
            f"true controller: {settings.truth}'s (its P, feedback and phase law used as this "
            "trial's own)"
        )
    model, torques = dyn.model, dyn.gait.torques
    state_index = {name: i for i, name in enumerate(state_names())}
    feedback_states = [model.states[state_index[n]] for n in data.feedback]
    gs = GainScheduled(data.points, feedback_states, torques, structure=settings.structure)
    window = data.window
    t, signals, phase, states = window.time, window.signals, window.phase, window.states
    law_note = data.phase.note()
    if law_note:
        notes.append(law_note)
    fb_columns = [state_index[n] for n in data.feedback]
    measured_torques = signals[list(TORQUE_COLUMNS)].to_numpy()

    say(
        "direct", f"least squares of the torques on {len(data.feedback)} signals, P = {data.points}"
    )
    direct_fit = fit_gain_schedule(gs, phase, states[:, fb_columns], measured_torques)
    direct = ControllerEstimate(direct_fit.Tstar, direct_fit.K)
    lap("direct")

    context = FitContext(
        settings=settings,
        data=data,
        dyn=dyn,
        gs=gs,
        direct=direct,
        say=say,
        iterations=iterations,
        notes=notes,
        lap=lap,
        map_windows=map_windows,
    )
    outcome = _FITS[settings.method](context)
    collocation = outcome.estimate

    truth = true_controller(data, gs, notes)
    say("validate", f"held-out {data.held_out.time[-1] - data.held_out.time[0]:.1f} s")
    # the trial's own controller, when it records one, beside them: the VAF a consistent
    # estimate approaches (the direct fit's attenuated gains can predict noisy states better)
    compared = {"collocation": collocation, "direct": direct} | ({"truth": truth} if truth else {})
    validation = validate(settings, data, gs, compared, say, map_windows)
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
        metrics=estimate_metrics(collocation, direct, truth, gs.mask),
        problem_size=outcome.problem_size,
        data_digest=trial_digest(data.trial),
        mean_signals=mean_signals_by_phase(gs, phase, states[:, fb_columns]),
        model=model_facts,
        timings=timings,
        peak_rss_mb=peak_rss_mb(),
        notes=notes,
    )


#: ``GaitIdentifySettings.method`` -> the fit.
_FITS: dict[str, Callable[[FitContext], Fit]] = {
    "smoother": smoother_fit,
    "closed-loop": closed_loop_fit,
}
