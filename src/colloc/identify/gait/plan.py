"""How long to record: the Cramér–Rao bound of the gain schedule against the record's length.

The bound is the one ``colloc gait identify`` reports (:mod:`colloc.identify.gait.controller_fit`):
the least squares of ``T = T*(phi) - K(phi) s`` with the fed-back states known and each
torque equation's noise ``sigma``, ``cov = sigma^2 (D' D)^-1`` per torque, as a relative error
``sqrt(sum of the variances) / |K|`` against a known controller. Its design ``D`` comes from a
pilot trial (a walk of the subject, speed, schedule and noise planned for, e.g. from ``colloc
gait simulate``): the bound is computed on the pilot's first 1/4, 1/2, 3/4 and all of its
record, the law ``bound = c / sqrt(fitted seconds)`` taken from the whole pilot (the shorter
parts say whether the pilot is long enough for the law to hold), and the length a target needs
(or the bound a length reaches) read from it. Measured on the 8-minute trial's fits of 60 to
360 s (docs/gait.md) the bound fell a little faster than the law from 60 s (5-7 % below it
at 120-360 s), so a plan from a one-minute pilot errs long.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from colloc.control.gain_scheduled import GainScheduled
from colloc.data.columns import TORQUE_COLUMNS
from colloc.gait.settings import GaitSimulationSettings
from colloc.identify.direct import schedule_design
from colloc.identify.gait.controller_fit import relative_spread
from colloc.identify.gait.phase_law import gait_phase
from colloc.identify.gait.read import (
    GaitData,
    read_gait_data,
    recorded_controller,
    state_names,
)
from colloc.identify.gait.settings import GaitIdentifySettings
from colloc.identify.gait.trial_noise import torque_equation_noise, trial_noise_std

if TYPE_CHECKING:
    from colloc.gait.workflow import Progress

#: Shares of the pilot record the bound is computed on.
PILOT_SHARES = (0.25, 0.5, 0.75, 1.0)
#: Largest relative departure of a shorter part's bound from the 1/sqrt(length) law taken
#: from the whole pilot before a note says the pilot is too short.
LAW_TOLERANCE = 0.2


@dataclass
class RecordPlan:
    """The bound against the fitted length, and what a target needs.

    Attributes
    ----------
    fitted_seconds : ndarray
        Lengths of the pilot's record the bound was computed on.
    K_bound, Tstar_bound : ndarray
        The relative bounds there.
    K_coefficient, Tstar_coefficient : float
        ``c`` of ``bound = c / sqrt(fitted seconds)``, from the whole pilot.
    noise_std : float
        The torque equations' noise [N m].
    fit_fraction : float
        Share of a record that is fitted (the rest validates).
    target_K, target_Tstar : float or None
        Relative bounds wanted; the length needed meets both.
    needed_fit_seconds, needed_record_seconds : float or None
        For ``target_K``.
    record_seconds : float or None
        A length asked about; ``K_bound_at_length`` its bound.
    K_bound_at_length : float or None
    pilot : dict
        What determined the pilot: its folder and, when simulated for the plan
        (:func:`plan_for_subject`), every setting of its simulation.
    notes : list of str
    """

    fitted_seconds: np.ndarray
    K_bound: np.ndarray
    Tstar_bound: np.ndarray
    K_coefficient: float
    Tstar_coefficient: float
    noise_std: float
    fit_fraction: float
    target_K: float | None = None
    target_Tstar: float | None = None
    needed_fit_seconds: float | None = None
    needed_record_seconds: float | None = None
    record_seconds: float | None = None
    K_bound_at_length: float | None = None
    Tstar_bound_at_length: float | None = None
    pilot: dict[str, Any] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        """Plain values for JSON."""
        out = dict(self.__dict__)
        for key in ("fitted_seconds", "K_bound", "Tstar_bound"):
            out[key] = np.asarray(out[key]).tolist()
        return out


def design_bounds(
    controller: GainScheduled,
    phase: np.ndarray,
    feedback: np.ndarray,
    noise_std: float,
    Tstar: np.ndarray,
    K: np.ndarray,
) -> tuple[float, float]:
    """The relative Cramér–Rao bounds of ``K`` and ``T*`` for this design.

    Parameters
    ----------
    controller : GainScheduled
    phase : ndarray, shape (N,)
    feedback : ndarray, shape (N, n_s)
    noise_std : float
        Each torque equation's noise [N m].
    Tstar, K : ndarray
        The controller the bound is relative to.

    Returns
    -------
    (float, float)
        ``K`` and ``T*`` bounds as relative errors.
    """
    P, m = Tstar.shape
    k_var = np.zeros_like(K)
    t_var = np.zeros_like(Tstar)
    for i in range(m):
        design, allowed = schedule_design(controller, phase, feedback, i)
        # (a rounding-negative diagonal of a nearly singular design counts as zero, as the
        # fit's bound does)
        variance = np.clip(noise_std**2 * np.diag(np.linalg.inv(design.T @ design)), 0, None)
        values = variance.reshape(P, 1 + allowed.size)
        t_var[:, i] = values[:, 0]
        k_var[:, i, allowed] = values[:, 1:]
    return (
        relative_spread(np.sqrt(k_var), K),
        relative_spread(np.sqrt(t_var), Tstar),
    )


def plan_record_problems(
    target_k: float | None,
    record_seconds: float | None,
    noise_std: float | None,
    fit_fraction: float,
    target_tstar: float | None = None,
) -> None:
    """Raise ValueError naming every unusable option of :func:`plan_record`."""
    problems = []
    for name, value in (
        ("target_k", target_k),
        ("target_tstar", target_tstar),
        ("record_seconds", record_seconds),
    ):
        if value is not None and not (
            isinstance(value, int | float) and np.isfinite(value) and value > 0
        ):
            problems.append(f"{name}: expected a positive number, found {value!r}")
    if noise_std is not None and not (
        isinstance(noise_std, int | float) and np.isfinite(noise_std) and noise_std > 0
    ):
        problems.append(f"noise_std: expected N m > 0, found {noise_std!r}")
    if not (isinstance(fit_fraction, int | float) and 0 < fit_fraction < 1):
        problems.append(f"fit_fraction: expected a number in (0, 1), found {fit_fraction!r}")
    if problems:
        raise ValueError("plan_record: " + "; ".join(problems))


def plan_record(
    pilot: str | Path,
    *,
    target_k: float | None = None,
    record_seconds: float | None = None,
    noise_std: float | None = None,
    fit_fraction: float = 0.75,
    states: np.ndarray | None = None,
    progress: Progress | None = None,
    target_tstar: float | None = None,
) -> RecordPlan:
    """The record a target bound on ``K`` (and ``T*``) needs, or the bound a record reaches.

    The design is the pilot's states as the fit sees them: the smoother's (as ``colloc gait
    identify`` smooths a trial), not the measured ones. Measured on a 60 s simulated pilot
    at 1.2 m/s with the default lab noise and 3 N m of motor noise (feedback on all
    states): the K bound on its first 43 s was 17 % from the measured states, 47 % from
    the simulation's noise-free ones and 44 % as the fit reported it. The sensor noise on the
    trunk's and the rates' signals breaks the near collinearity of the fed-back states (a
    loaded foot ties the trunk to the stance leg's joints) and reads as information the
    fit does not have.

    Parameters
    ----------
    pilot : path-like
        A trial whose metadata records its controller (``colloc gait simulate`` writes one):
        its walk is the design, its controller the reference of the relative bound.
    target_k : float, optional
        Relative bound of ``K`` wanted (e.g. 0.2).
    record_seconds : float, optional
        A record length to give the bound of.
    noise_std : float, optional
        Torque equations' noise [N m]; default the pilot's torque noise and motor noise
        combined (as ``colloc gait identify`` uses).
    fit_fraction : float
        Share of a record fitted.
    states : ndarray, shape (N, 18), optional
        The pilot's states ``[q, u]`` at its samples, e.g. a simulated pilot's without
        sensor noise; default the smoother's (minutes for a minute of pilot).
    progress : callable, optional
        ``progress(step, detail)`` of the smoother's stages.
    target_tstar : float, optional
        Relative bound of ``T*`` wanted; the length needed meets this and ``target_k``.

    Returns
    -------
    RecordPlan

    Raises
    ------
    ValueError
        On unusable options or a pilot without a recorded controller (every problem at once).
    """
    plan_record_problems(target_k, record_seconds, noise_std, fit_fraction, target_tstar)
    # read and checked as identify reads a trial (its split does not matter here: the
    # whole pilot is the design)
    settings = GaitIdentifySettings(trial=Path(pilot), fit_fraction=0.5)
    data = read_gait_data(settings)
    meta = data.trial.metadata
    recorded = recorded_controller(meta)
    if recorded is None or not {"Tstar", "K"} <= set(recorded):
        raise ValueError(
            f"pilot: expected a trial whose metadata records its controller (colloc gait "
            f"simulate writes one), found none in {str(pilot)!r}"
        )
    from sympy.physics.mechanics import dynamicsymbols

    Tstar, K = np.asarray(recorded["Tstar"], float), np.asarray(recorded["K"], float)
    controller = GainScheduled(
        data.points,
        dynamicsymbols(list(data.feedback)),
        dynamicsymbols([c.removesuffix("_torque") for c in TORQUE_COLUMNS]),
    )
    trial = data.trial
    notes = []
    if states is None:
        times, full = smoothed_states(data, settings, progress)
        notes.append(
            "design: the pilot's states as the fit's smoother gives them (the measured ones "
            "carry sensor noise that the fit does not see as information)"
        )
    else:
        full = np.asarray(states, dtype=float)
        if full.shape != (trial.time.size, len(state_names())):
            raise ValueError(
                f"states: expected shape ({trial.time.size}, {len(state_names())}) (the "
                f"pilot's samples), found {full.shape}"
            )
        times = trial.time
        notes.append("design: the pilot's states as given")
    phase = gait_phase("causal", trial, times, None)
    index = {n: i for i, n in enumerate(state_names())}
    states = full[:, [index[n] for n in data.feedback]]
    if noise_std is None:
        combined = torque_equation_noise(meta)
        noise_std = trial_noise_std(meta, TORQUE_COLUMNS[0]) if combined is None else combined
        notes.append(
            f"torque noise {noise_std:.3g} N m: the pilot's torque noise and motor noise combined"
        )
    # the causal phase starts at the first right heel strike
    known = np.isfinite(phase)
    first = times[known][0]
    span = float(times[known][-1] - first)

    def bound_at(fitted: float) -> tuple[float, float] | None:
        """K and T* bounds of the pilot's first ``fitted`` seconds; None if undetermined."""
        rows = known & (times <= first + fitted + 1e-9)
        try:
            k, t = design_bounds(controller, phase[rows], states[rows], noise_std, Tstar, K)
        except np.linalg.LinAlgError:
            return None  # too short a part to determine the schedule
        return (k, t) if np.isfinite(k) and np.isfinite(t) else None

    lengths, k_bounds, t_bounds = [], [], []
    for share in PILOT_SHARES:
        bounds = bound_at(share * span)
        if bounds is not None:
            lengths.append(share * span)
            k_bounds.append(bounds[0])
            t_bounds.append(bounds[1])
    if not lengths:
        raise ValueError(
            f"pilot: its {span:.1f} s do not determine the P = {data.points} schedule; "
            "simulate a longer pilot"
        )
    # the law from the whole pilot, whose design is the best determined, for lengths beyond
    # it; within the pilot the bound is computed on its own first seconds. The shorter parts
    # say how far the law is from the bound there.
    k_c = float(k_bounds[-1] * np.sqrt(lengths[-1]))
    t_c = float(t_bounds[-1] * np.sqrt(lengths[-1]))
    ratios = [
        (length, bound / (k_c / np.sqrt(length)))
        for length, bound in zip(lengths[:-1], k_bounds[:-1], strict=True)
    ]
    off = [(length, ratio) for length, ratio in ratios if abs(ratio - 1.0) > LAW_TOLERANCE]
    if off:
        errs = (
            "the bound fell faster than the law over the pilot, so beyond it the law likely "
            "errs long"
            if off[-1][1] > 1.0
            else "the bound fell slower than the law over the pilot, so beyond it a longer "
            "record than planned may be needed"
        )
        notes.append(
            f"the bound on the pilot's first {', '.join(f'{L:.0f}' for L, _ in off)} s is "
            f"{', '.join(f'{r:.3g}' for _, r in off)} times the 1/sqrt(length) law's: {errs}; "
            "plan from a longer pilot"
        )
    plan = RecordPlan(
        np.asarray(lengths), np.asarray(k_bounds), np.asarray(t_bounds), k_c, t_c,
        float(noise_std), float(fit_fraction), pilot={"trial": str(pilot)}, notes=notes,
    )  # fmt: skip
    plan.target_K = None if target_k is None else float(target_k)
    plan.target_Tstar = None if target_tstar is None else float(target_tstar)
    needed = []
    for which, name, target, computed, c in (
        (0, "K", target_k, k_bounds, k_c),
        (1, "T*", target_tstar, t_bounds, t_c),
    ):
        if target is None:
            continue
        if computed[-1] > target:
            needed.append((c / target) ** 2)
            notes.append(
                f"the length for a {name} bound of {target:g} is beyond the pilot's "
                f"{span:.0f} s: from the 1/sqrt(length) law"
            )
        else:
            needed.append(_within_pilot(bound_at, lengths, computed, target, which))
            notes.append(
                f"the length for a {name} bound of {target:g} is within the pilot: computed on "
                "its own first seconds"
            )
    if needed:
        plan.needed_fit_seconds = float(max(needed))
        plan.needed_record_seconds = plan.needed_fit_seconds / fit_fraction
    if record_seconds is not None:
        plan.record_seconds = float(record_seconds)
        fitted = record_seconds * fit_fraction
        inside = bound_at(fitted) if fitted <= span else None
        plan.K_bound_at_length = k_c / np.sqrt(fitted) if inside is None else inside[0]
        plan.Tstar_bound_at_length = t_c / np.sqrt(fitted) if inside is None else inside[1]
    return plan


def smoothed_states(
    data: GaitData, settings: GaitIdentifySettings, progress: Progress | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The whole pilot smoothed as ``colloc gait identify`` smooths a fit window (its default
    windows and source), at the times where the smoother's scheme holds the dynamics.

    Parameters
    ----------
    data : GaitData
    settings : GaitIdentifySettings
        The smoother's windows and source (``window_strides``, ``smooth_from``).
    progress : callable, optional

    Returns
    -------
    times : ndarray, shape (M,)
    states : ndarray, shape (M, 18)
    """
    from colloc.identify.gait.windows import (
        fit_windows,
        smooth_windows,
        smoothing_source,
        window_jobs,
    )

    trial = data.trial
    rows = np.arange(trial.time.size)
    windows = fit_windows(settings, trial.time, trial.right_heel_strikes)
    source = smoothing_source(settings.smooth_from, trial)
    jobs = window_jobs(trial, rows, windows, trial.metadata, "pilot window", source)
    pieces = [result.at_dynamics() for result in smooth_windows(jobs, progress)]
    return np.concatenate([p[0] for p in pieces]), np.concatenate([p[1] for p in pieces])


def _within_pilot(
    bound_at: Any, lengths: list[float], bounds: list[float], target: float, which: int = 0
) -> float:
    """The fitted length within the pilot whose bound (``which``: 0 K, 1 T*) is ``target``,
    by bisection between the computed lengths that bracket it (the bound falls with the
    length)."""
    above = [(L, b) for L, b in zip(lengths, bounds, strict=True) if b > target]
    hi = min(L for L, b in zip(lengths, bounds, strict=True) if b <= target)
    lo = max((L for L, _ in above if L < hi), default=hi / 4)
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        bounds_mid = bound_at(mid)
        if bounds_mid is None or bounds_mid[which] > target:
            lo = mid
        else:
            hi = mid
    return float(hi)


#: Halvings of the bracket of :func:`_within_pilot` (to 1/4096 of the bracket).
BISECTIONS = 12

#: Motor noise [N m] of a simulated pilot unless given: real walking's (2-5 N m). Without it
#: the walk's excursions from its mean stride come from the belt alone, the smoother's state
#: errors are a large share of them, and the fit's reported bound reads them as information:
#: on a 214 s walk at 1.2 m/s without motor noise (seed 101) the fit reported a K bound of
#: 11 % where the plan from the simulation's states gave 20 %, and its error was 3.0 times
#: its bound with 79 % of entries within 3 SE. With 3 N m the plan and the fit's bound agreed
#: within 5 % (46 % and 44 % on 43 s of a 60 s walk).
PILOT_MOTOR_NOISE = 3.0

#: Seconds of the pilot walk :func:`plan_for_subject` simulates by default: long enough for the
#: bound's 1/sqrt(length) law on 1/2 to all of it at P = 20 (docs/gait-guide.md).
PILOT_SECONDS = 60.0


def plan_for_subject(
    simulation: GaitSimulationSettings,
    *,
    target_k: float | None = None,
    record_seconds: float | None = None,
    noise_std: float | None = None,
    fit_fraction: float = 0.75,
    progress: Progress | None = None,
    target_tstar: float | None = None,
) -> RecordPlan:
    """The plan of :func:`plan_record` without a pilot of one's own: a pilot walk of the
    subject, speed, schedule and noise planned for is simulated first.

    Parameters
    ----------
    simulation : GaitSimulationSettings
        The pilot: subject (``body_mass``, ``height``), ``speed``, ``num_points``,
        ``motor_noise``, sensor ``noise``, ``seed``, its ``duration`` (e.g.
        :data:`PILOT_SECONDS`) and the folder ``out`` it is written to (``out/trial`` is
        the pilot a later plan can be given).
    target_k, record_seconds, noise_std, fit_fraction, target_tstar
        As :func:`plan_record`.
    progress : callable, optional
        ``progress(step, detail)`` of the simulation's steps.

    Returns
    -------
    RecordPlan
        With ``pilot`` holding the simulation's settings.

    Raises
    ------
    ValueError
        On bad settings or options (before the simulation), or a pilot that fell (its
        design does not stand for the record planned).
    """
    from colloc.gait.workflow import simulate_trial

    simulation.validate()
    # the plan's own options checked before minutes of simulation
    plan_record_problems(target_k, record_seconds, noise_std, fit_fraction, target_tstar)
    result = simulate_trial(simulation, progress=progress)
    if result.fell:
        raise ValueError(
            f"pilot: the simulated walk fell ({result.summary.get('message')}); its design "
            "does not stand for the record planned: plan at another speed, motor noise or "
            "number of points"
        )
    # the simulation's own states, without the sensor noise the trial carries: the design as
    # the fit's smoother sees it, without minutes of smoothing
    record = result.record
    times = np.asarray(result.trial.time, dtype=float)
    exact = np.column_stack(
        [np.interp(times, record.times, column) for column in np.asarray(record.states).T]
    )
    plan = plan_record(
        result.out / "trial",
        target_k=target_k,
        record_seconds=record_seconds,
        noise_std=noise_std,
        fit_fraction=fit_fraction,
        states=exact,
        target_tstar=target_tstar,
    )
    plan.pilot |= {"simulated": simulation.to_dict()}
    plan.notes.insert(
        0,
        f"pilot simulated: {simulation.duration:g} s at {simulation.speed:g} m/s, "
        f"{simulation.body_mass:g} kg, {simulation.height:g} m, P = {simulation.num_points}, "
        f"motor noise {simulation.motor_noise:g} N m, seed {simulation.seed} "
        f"({result.out / 'trial'}); its states without sensor noise are the design",
    )
    return plan


__all__ = [
    "LAW_TOLERANCE",
    "PILOT_MOTOR_NOISE",
    "PILOT_SECONDS",
    "PILOT_SHARES",
    "RecordPlan",
    "design_bounds",
    "plan_for_subject",
    "plan_record",
    "smoothed_states",
]
