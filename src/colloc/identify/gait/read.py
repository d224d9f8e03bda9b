"""Read a gait trial for identification: checked, split at a right heel strike, a fit window
of whole strides; the phase, the measured states, the subject and the trial's recorded
controller (a synthetic trial's truth)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from colloc.data.columns import JOINT_ANGLE_COLUMNS, JOINT_RATE_COLUMNS, TORQUE_COLUMNS
from colloc.data.split import split
from colloc.data.trial import Trial, read_trial, read_trial_metadata
from colloc.identify.direct import smooth_with_derivatives
from colloc.identify.gait.phase_law import PhaseLaw, phase_law
from colloc.identify.gait.settings import DEFAULT_POINTS, GaitIdentifySettings


@dataclass(frozen=True)
class TrialPart:
    """A stretch of the trial as the fits read it, phased and with its states measured once.

    Attributes
    ----------
    time : ndarray, shape (N,)
    signals : DataFrame
        The trial's rows, indexed from 0.
    phase : ndarray, shape (N,)
        The phase law's unwrapped phase (NaN where it has none).
    states : ndarray, shape (N, 18)
        ``[q, u]`` measured (:func:`measured_states`).
    """

    time: np.ndarray
    signals: Any
    phase: np.ndarray
    states: np.ndarray


@dataclass
class GaitData:
    """The checked trial read once: its two parts, the fit window and the held-out part
    phased and measured, the phase law, and the controller the trial records.

    Attributes
    ----------
    trial, fit, held_out : Trial
        The whole trial and its two parts.
    rows : ndarray of int
        The fit part's rows of the window.
    feedback : list of str
        The controller's feedback signals.
    points : int
        The schedule's points ``P``.
    mask_metadata : ndarray or None
        The recorded controller's gain mask.
    phase : PhaseLaw
        The law ``--phase`` names, of the whole trial.
    recorded : dict or None
        The trial's recorded controller (a synthetic trial's truth).
    window, held_out_part : TrialPart
        The fit window and the held-out part.
    """

    trial: Trial
    fit: Trial
    held_out: Trial
    rows: np.ndarray  # fit-part rows of the window
    feedback: list[str]
    points: int
    mask_metadata: np.ndarray | None
    phase: PhaseLaw
    recorded: dict[str, Any] | None
    window: TrialPart
    held_out_part: TrialPart


def state_names() -> tuple[str, ...]:
    from colloc.gait.metadata import STATE_SIGNAL_NAMES

    return STATE_SIGNAL_NAMES


def recorded_controller(meta: dict[str, Any]) -> dict[str, Any] | None:
    """The controller entry of a trial's metadata (a synthetic trial's truth), or None."""
    recorded = meta.get("controller")
    return recorded if isinstance(recorded, dict) else None


def take_truth(trial: Trial, source: Any) -> list[str]:
    """Give ``trial`` the controller recorded in another trial's metadata.

    For a lab export of a simulated walk: the export's trial records no controller, the
    simulated trial does. The controller entry replaces ``trial``'s (in memory),
    ``truth_source`` names where it came from, and the motor noise that walk was simulated
    with becomes ``truth_motor_noise`` (the lab design's bound needs it; the trial's own
    ``motor_noise`` entry, which its torques' bound reads, is left as it is).

    Parameters
    ----------
    trial : Trial
    source : path-like
        The simulated trial's directory.

    Returns
    -------
    list of str
        Problems (empty when the controller was taken).
    """
    try:
        other = read_trial_metadata(source)
    except (FileNotFoundError, ValueError) as error:
        return [f"truth: {error}"]
    recorded = recorded_controller(other)
    if recorded is None:
        return [
            f"truth: expected a trial whose metadata records the controller that made the walk "
            f"(a colloc gait simulate trial), found none in {str(source)!r}"
        ]
    trial.metadata["controller"] = recorded
    trial.metadata["truth_source"] = str(source)
    motor = other.get("motor_noise")
    if isinstance(motor, dict) and isinstance(motor.get("std"), int | float):
        trial.metadata["truth_motor_noise"] = float(motor["std"])
    return []


def _feedback_names(choice: str, meta: dict[str, Any]) -> list[str]:
    from colloc.gait.design import FEEDBACK_SETS

    if choice == "metadata":
        recorded = recorded_controller(meta) or {}
        if "feedback" in recorded:
            return list(recorded["feedback"])
        return list(JOINT_ANGLE_COLUMNS + JOINT_RATE_COLUMNS)
    names = state_names()
    return [names[i] for i in FEEDBACK_SETS[choice]]


def tracked_columns(track: tuple[str, ...]) -> list[str]:
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


def read_gait_data(settings: GaitIdentifySettings) -> GaitData:
    """Read and check the trial; split it; choose the fit window. All problems at once."""
    trial = read_trial(settings.trial)
    problems: list[str] = []
    if settings.truth is not None:
        problems += take_truth(trial, settings.truth)
    meta = trial.metadata
    feedback = _feedback_names(settings.feedback, meta)
    unknown = [n for n in feedback if n not in state_names()]
    if unknown:
        problems.append(f"metadata: controller feedback names {unknown} are not state signals")
    needed = set(feedback) - set(unknown)
    needed |= {"belt_speed", *TORQUE_COLUMNS, *tracked_columns(settings.track)}
    needed |= set(JOINT_ANGLE_COLUMNS) | {"trunk_x", "trunk_y", "trunk_angle"}
    if settings.phase == "controller":
        needed.add("controller_phase")
    missing = sorted(needed - set(trial.signals.columns))
    if missing:
        problems.append(
            f"trial: missing columns {missing} (needed by the feedback, the tracked signals, "
            f"the belt or --phase {settings.phase})"
        )
    recorded = recorded_controller(meta)
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
    if strikes.size < MIN_RIGHT_STRIKES:
        problems.append(_too_short(trial, settings, points, len(feedback)))
    else:
        problems += _missed_strikes(strikes)
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
    law = phase_law(settings.phase, trial)

    def part(time: np.ndarray, signals: Any) -> TrialPart:
        states = measured_states(time, signals, settings.smoothing_window)
        return TrialPart(time, signals, law.at(time, signals), states)

    return GaitData(
        trial,
        fit,
        held_out,
        rows,
        feedback,
        points,
        mask_metadata,
        law,
        recorded,
        part(fit.time[rows], fit.signals.iloc[rows].reset_index(drop=True)),
        part(held_out.time, held_out.signals),
    )


#: Right heel strikes a trial needs: three whole strides, two to fit and one held out.
MIN_RIGHT_STRIKES = 4
#: A walking stride [s] assumed when a trial has too few strikes to measure its own.
TYPICAL_STRIDE = 1.1


#: A stride this many times the median is one with a heel strike missed.
MISSED_STRIKE_RATIO = 1.6


def _missed_strikes(strikes: np.ndarray) -> list[str]:
    """Strides so long that a right heel strike between them was missed: the phase, reset at
    each strike, would run through two strides as one."""
    strides = np.diff(strikes)
    median = float(np.median(strides))
    long = np.flatnonzero(strides > MISSED_STRIKE_RATIO * median)
    if long.size == 0:
        return []
    shown = ", ".join(
        f"{strikes[k]:.2f}-{strikes[k + 1]:.2f} s ({strides[k]:.2f} s)" for k in long[:3]
    )
    more = f" and {long.size - 3} more" if long.size > 3 else ""
    return [
        f"events: {long.size} stride(s) between right heel strikes last more than "
        f"{MISSED_STRIKE_RATIO:g} times the median {median:.2f} s: {shown}{more}; a strike was "
        "missed there (add it to events.csv, or cut the trial)"
    ]


def _too_short(trial: Trial, settings: GaitIdentifySettings, points: int, states: int) -> str:
    """How long a record identification needs, against what the trial holds."""
    strikes = trial.right_heel_strikes
    stride = float(np.median(np.diff(strikes))) if strikes.size >= 2 else TYPICAL_STRIDE
    rate = float(1.0 / np.median(np.diff(trial.time)))
    width = 1 + (states if settings.structure == "full" else 2)
    fit_seconds = max(2 * stride, width * points / rate)
    needed = max(fit_seconds / settings.fit_fraction, (MIN_RIGHT_STRIKES - 1) * stride)
    return (
        f"trial: {trial.time[-1] - trial.time[0]:.1f} s with {strikes.size} right heel strikes; "
        f"identification needs at least {MIN_RIGHT_STRIKES} (two strides to fit, one held out) "
        f"and {width * points} samples in the fit for P = {points}: at least {needed:.0f} s of "
        f"walking at {stride:.2f} s a stride and {rate:g} Hz. That only runs; errors near "
        "the Cramér-Rao bound take minutes (docs/gait.md)"
    )


def trial_digest(trial: Trial) -> str:
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


def measured_states(t: np.ndarray, signals: Any, window: float) -> np.ndarray:
    """``[q, u]`` from the measured signals: the trial's rate columns where it has them (a gait
    lab's marker velocities), else Savitzky-Golay derivatives of the positions.

    Measured on the noise-free 60 s default trial: direct identification from the rate
    columns recovers K exactly, from Savitzky-Golay rates (0.05 s) with 14 % error.
    """
    names = state_names()
    positions = signals[list(names[:9])].to_numpy(dtype=float)
    if all(c in signals.columns for c in names[9:]):
        return np.hstack([positions, signals[list(names[9:])].to_numpy(dtype=float)])
    _, rates, _ = smooth_with_derivatives(t, positions, window)
    return np.hstack([positions, rates])


#: The subject assumed when a trial's metadata does not say: body mass [kg], height [m].
DEFAULT_SUBJECT = (75.0, 1.8)


def subject(meta: dict[str, Any]) -> tuple[float, float]:
    """Body mass [kg] and height [m] a trial's metadata records (:data:`DEFAULT_SUBJECT` if
    not)."""
    return (
        float(meta.get("body_mass", DEFAULT_SUBJECT[0])),
        float(meta.get("height", DEFAULT_SUBJECT[1])),
    )


def subject_note(meta: dict[str, Any]) -> str:
    """The sentence that says which subject the model was scaled to, and from where.

    Parameters
    ----------
    meta : dict
        The trial's metadata.

    Returns
    -------
    str
    """
    mass, height = subject(meta)
    missing = [key for key in ("body_mass", "height") if key not in meta]
    if not missing:
        return f"subject: {mass:g} kg, {height:g} m (the trial's metadata)"
    return (
        f"subject: {mass:g} kg, {height:g} m; metadata.yaml gives no {' or '.join(missing)}, so "
        "colloc's defaults are used: give the subject's there, the model's segments scale "
        "with both"
    )
