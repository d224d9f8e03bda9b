"""The held-out part of a trial walked under an identified controller, as a job any map runs.

A :class:`WalkJob` holds the numbers the forward simulation needs (the controller, the
record's belt speed, start state and phase law, the measured angles to compare with) and no
CasADi object, so the identified and the direct controllers' walks can run side by side on
the Dask workers that smoothed the windows (:func:`walk`; the model is built once per process,
:func:`colloc.identify.gait.windows.gait_dynamics`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from colloc.data.phase import phase_normalised
from colloc.identify.gait.windows import gait_dynamics
from colloc.identify.validation import rms, variance_accounted_for


@dataclass(frozen=True)
class WalkJob:
    """One forward simulation of a held-out record.

    Attributes
    ----------
    Tstar, K : ndarray
        The controller, shapes (P, 6) and (P, 6, n_s).
    feedback : ndarray of int
        State indices of the fed-back signals.
    times : ndarray, shape (N,)
        The record's sample times [s].
    belt_speed : ndarray, shape (N,)
    initial_state : ndarray, shape (18,)
        The measured state at the record's start.
    measured_angles : ndarray, shape (N, 6)
        Joint angles [rad] to compare with.
    measured_strikes : ndarray
        The record's right heel strikes [s from its start].
    stride, strike_phase, start_phase : float
        The phase law: seconds per cycle, the phase at a right heel strike, the phase at the
        start.
    hip_height_range : (float, float)
        Leaving it counts as a fall [m].
    sample_rate : float
        [Hz].
    body_mass, height : float
        The subject [kg], [m].
    joint_names : tuple of str
    """

    Tstar: np.ndarray
    K: np.ndarray
    feedback: np.ndarray
    times: np.ndarray
    belt_speed: np.ndarray
    initial_state: np.ndarray
    measured_angles: np.ndarray
    measured_strikes: np.ndarray
    stride: float
    strike_phase: float
    start_phase: float
    hip_height_range: tuple[float, float]
    sample_rate: float
    body_mass: float
    height: float
    joint_names: tuple[str, ...]


def walk(job: WalkJob) -> dict[str, object]:
    """Simulate gait2d under the job's controller over the record; compare with it.

    Parameters
    ----------
    job : WalkJob

    Returns
    -------
    dict
        ``walks``, ``message``, ``simulated_seconds``, ``strides`` (the simulation's right
        heel strikes: the strides to a fall if it falls) and ``measured_strides`` (the
        whole record's), ``angle_rms_deg`` and ``angle_vaf`` (joint -> value, sample by
        sample), ``angle_rms_phase_deg`` (joint -> RMS over the gait cycle between the
        simulation's and the record's mean strides, :func:`phase_difference`; empty before a
        whole stride of each), ``times``, ``measured_angles``, ``simulated_angles`` and
        ``simulated_strikes`` (seconds from the start).
    """
    from colloc.gait.closed_loop import simulate_walking

    t = job.times - job.times[0]
    record = simulate_walking(
        None,
        job.Tstar,
        job.K,
        float(t[-1]),
        (t, job.belt_speed),
        dynamics=gait_dynamics(job.body_mass, job.height),
        sample_rate=job.sample_rate,
        hip_height_range=job.hip_height_range,
        initial_state=job.initial_state,
        feedback=job.feedback,
        stride_duration=job.stride,
        phase_at_strike=job.strike_phase,
        initial_phase=job.start_phase,
    )
    n = record.times.size
    measured = job.measured_angles[:n]
    simulated = record.states[:, 3:9]
    names = job.joint_names
    by_phase = phase_difference(
        (t[:n], simulated, record.right_heel_strikes), (t[:n], measured, job.measured_strikes)
    )
    return {
        "walks": not record.fell,
        "message": record.message,
        "simulated_seconds": float(record.times[-1]),
        "strides": int(record.right_heel_strikes.size),
        "measured_strides": int(np.count_nonzero(job.measured_strikes <= t[-1])),
        "angle_rms_deg": dict(
            zip(names, map(float, np.degrees(rms(simulated - measured))), strict=True)
        ),
        "angle_vaf": dict(
            zip(names, map(float, variance_accounted_for(measured, simulated)), strict=True)
        )
        if n >= 2
        else {},
        "angle_rms_phase_deg": {}
        if by_phase is None
        else dict(zip(names, map(float, np.degrees(by_phase)), strict=True)),
        "times": job.times[:n],
        "measured_angles": measured,
        "simulated_angles": simulated,
        "simulated_strikes": np.asarray(record.right_heel_strikes, dtype=float),
    }


#: A walk's signals for :func:`phase_difference`: times, values (N, m) and right heel strikes.
Walked = tuple[np.ndarray, np.ndarray, np.ndarray]


def phase_difference(a: Walked, b: Walked) -> np.ndarray | None:
    """RMS over the gait cycle of the difference between two walks' mean strides.

    Each walk's complete strides are normalised to the gait cycle
    (:func:`colloc.data.phase.phase_normalised`) and averaged; a walk that drifts in phase
    from the other, stride for stride alike, differs by nothing here where it differs by the
    whole swing sample by sample.

    Parameters
    ----------
    a, b : (times, values, right heel strikes)

    Returns
    -------
    ndarray, shape (m,) or None
        None when either walk has no complete stride.
    """
    means = [phase_normalised(*walked)[2] for walked in (a, b)]
    if any(np.isnan(m).all() for m in means):
        return None
    return rms(means[0] - means[1])
