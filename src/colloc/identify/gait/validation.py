"""Validation on the held-out part: each controller's torque VAF (on smoothed and on measured
states), and the held-out walk under the identified and the direct controllers."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from colloc.control.gain_scheduled import GainScheduled
from colloc.data.columns import JOINT_ANGLE_COLUMNS, TORQUE_COLUMNS
from colloc.identify.gait.estimate import (
    JOINT_NAMES,
    ControllerEstimate,
)
from colloc.identify.gait.read import (
    GaitData,
    state_names,
    subject,
)
from colloc.identify.gait.settings import GaitIdentifySettings
from colloc.identify.gait.stage import Progress
from colloc.identify.gait.walk import WalkJob, phase_difference, walk
from colloc.identify.gait.windows import (
    WindowMap,
    fit_windows,
    prefixed,
    smoothing_source,
    window_jobs,
)
from colloc.identify.validation import rms, variance_accounted_for

#: Width [m] added below and above the fit part's hip-height range: leaving it in the
#: validation simulation counts as a fall (as in :func:`simulate_walking`'s default).
HIP_MARGIN = 0.15


#: What the validation keeps of the direct fit's and the true controller's held-out walks.
WALK_KEYS = (
    "walks", "message", "simulated_seconds", "strides", "measured_strides", "angle_rms_deg",
    "angle_rms_phase_deg",
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
    part = data.held_out_part
    signals, phase_all, states = part.signals, part.phase, part.states
    # outside the strikes the phase may be unknown (after the last, linear between strikes;
    # before the first, causal): the torque check keeps the samples that have one
    rows = np.flatnonzero(np.isfinite(phase_all))
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
    # its attenuated gains predict noisy states' torques as well (torque_vaf); the true
    # controller, when known, walks the same belt from the same start: the yardstick of the
    # identified walk (a held-out part walked without noise drifts from the noisy record
    # under any controller); the walks run side by side on the workers when there are some
    identified_job = _walk_job(settings, data, controllers["collocation"], states, phase_all)
    others = {name: controllers[name] for name in ("direct", "truth") if name in controllers}
    jobs = [identified_job] + [
        dataclasses.replace(identified_job, Tstar=c.Tstar, K=c.K) for c in others.values()
    ]
    say("validate", f"forward simulations of the held-out part (identified, {', '.join(others)})")
    walks = list((walk(job) for job in jobs) if map_windows is None else map_windows(walk, jobs))
    identified = walks[0]
    out.update(identified)
    out["walk_signals"] = {"collocation": identified} | dict(zip(others, walks[1:], strict=True))
    out["held_out"] = {
        "times": identified_job.times - identified_job.times[0],
        "angles": identified_job.measured_angles,
        "strikes": identified_job.measured_strikes,
    }
    for name, other in zip(others, walks[1:], strict=True):
        out[f"{name}_walk"] = {k: other[k] for k in WALK_KEYS}
    if "truth" in others:
        out["against_truth_walk"] = against_walk(identified, out["walk_signals"]["truth"])
    return out


def against_walk(walked: dict[str, Any], reference: dict[str, Any]) -> dict[str, Any]:
    """A held-out walk against another under the same belt from the same start (the true
    controller's): joint angles' RMS sample by sample and between their mean strides, over
    the time both walked.

    Parameters
    ----------
    walked, reference : dict
        :func:`colloc.identify.gait.walk.walk`'s results.

    Returns
    -------
    dict
        ``seconds`` compared, ``angle_rms_deg`` and ``angle_rms_phase_deg`` (joint -> value;
        the latter empty before a whole stride of each).
    """
    n = min(walked["times"].size, reference["times"].size)
    t = walked["times"][:n] - walked["times"][0]
    a, b = walked["simulated_angles"][:n], reference["simulated_angles"][:n]
    by_phase = phase_difference(
        (t, a, walked["simulated_strikes"]), (t, b, reference["simulated_strikes"])
    )
    return {
        "seconds": float(t[-1]) if n else 0.0,
        "angle_rms_deg": dict(zip(JOINT_NAMES, map(float, np.degrees(rms(a - b))), strict=True)),
        "angle_rms_phase_deg": {}
        if by_phase is None
        else dict(zip(JOINT_NAMES, map(float, np.degrees(by_phase)), strict=True)),
    }


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
    from colloc.identify.gait.windows import smooth_windows

    part = data.held_out
    rows = np.arange(part.time.size)
    windows = fit_windows(settings, part.time, part.right_heel_strikes)
    source = smoothing_source(settings.smooth_from, data.trial)
    jobs = window_jobs(
        part,
        rows,
        windows,
        data.trial.metadata,
        "held-out window",
        source,
        settings.noise_levels,
        settings.fit_places,
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
    with the trial's phase law (:meth:`colloc.identify.gait.phase_law.PhaseLaw.walk_clock`)."""
    part, fit = data.held_out, data.fit
    stride, strike_phase = data.phase.walk_clock(fit)
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
