"""Validation on the held-out part: each controller's torque VAF (on smoothed and on measured
states), and the held-out walk under the identified and the direct controllers."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from colloc.control.gain_scheduled import GainScheduled
from colloc.data.columns import JOINT_ANGLE_COLUMNS, TORQUE_COLUMNS
from colloc.identify.gait_estimate import (
    JOINT_NAMES,
    ControllerEstimate,
)
from colloc.identify.gait_read import (
    GaitData,
    causal_phase_parameters,
    gait_phase,
    measured_states,
    state_names,
    subject,
)
from colloc.identify.gait_settings import GaitIdentifySettings
from colloc.identify.gait_stage import Progress
from colloc.identify.gait_walk import WalkJob, walk
from colloc.identify.gait_windows import (
    WindowMap,
    fit_windows,
    prefixed,
    smoothing_source,
    window_jobs,
)
from colloc.identify.validation import variance_accounted_for

#: Width [m] added below and above the fit part's hip-height range: leaving it in the
#: validation simulation counts as a fall (as in :func:`simulate_walking`'s default).
HIP_MARGIN = 0.15


#: What the validation keeps of the direct fit's held-out walk.
DIRECT_WALK_KEYS = (
    "walks", "message", "simulated_seconds", "strides", "measured_strides", "angle_rms_deg",
)  # fmt: skip


def validate(
    settings: GaitIdentifySettings,
    data: GaitData,
    gs: GainScheduled,
    controllers: dict[str, ControllerEstimate],
    say: Progress,
    map_windows: WindowMap | None = None,
) -> dict[str, Any]:
    """Torque VAF of each controller, and the forward simulations of the held-out part
    under the identified and the direct controllers (through ``map_windows`` when given)."""
    part = data.held_out
    t, signals = part.time, part.signals
    phase_all = gait_phase(settings.phase, data.trial, t, signals)
    # outside the strikes the phase may be unknown (after the last, linear between strikes;
    # before the first, causal): the torque check keeps the samples that have one
    rows = np.flatnonzero(np.isfinite(phase_all))
    states = measured_states(t, signals, settings.smoothing_window)
    index = {n: i for i, n in enumerate(state_names())}
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
    data: GaitData,
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
    windows = fit_windows(settings, part.time, part.right_heel_strikes)
    source = smoothing_source(settings.smooth_from, data.trial)
    jobs = window_jobs(
        part, rows, windows, data.trial.metadata, "held-out window", source, settings.noise_levels
    )
    results = smooth_windows(jobs, prefixed(say, "validate"), map_windows)
    pieces = [result.at_dynamics() for result in results]
    at_t, at_states = (np.concatenate([p[i] for p in pieces]) for i in (0, 1))
    at_phase = np.interp(at_t, part.time, phase, left=np.nan, right=np.nan)
    measured = part.signals[list(TORQUE_COLUMNS)].to_numpy(dtype=float)
    at_torques = np.column_stack([np.interp(at_t, part.time, m) for m in measured.T])
    ok = np.isfinite(at_phase)
    return at_phase[ok], at_states[ok], at_torques[ok]


def _walk_job(
    settings: GaitIdentifySettings,
    data: GaitData,
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
    index = {n: i for i, n in enumerate(state_names())}
    body_mass, height = subject(data.trial.metadata)
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
