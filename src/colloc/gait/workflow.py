"""Synthetic perturbed-walking trials end to end: cycle, controller, closed loop, trial files.

Steps of :func:`simulate_trial` (each timed, reported through ``progress``):

1. ``cycle``: a periodic walking cycle at the belt speed
   (:func:`colloc.gait.cycle.find_walking_cycle`);
2. ``settle``: a full-state controller closes the loop around it on a constant belt until the
   strides repeat; the last stride is the cycle the continuous model really walks
   (:func:`colloc.gait.settle.settle_cycle`);
3. ``orbit``: the trial's ``P``-point controller designed on that cycle walks until its
   strides repeat; its own stride (which a ``P``-point schedule cannot make exactly the
   full-state one) is the cycle from here on;
4. ``design``: the gain-scheduled controller on the chosen feedback that stabilises that
   cycle (:func:`colloc.gait.design.design_controller`);
5. ``simulate``: the closed loop on a perturbed belt
   (:func:`colloc.gait.closed_loop.simulate_walking`);
6. ``trial``: the record as a gait-lab trial with sensor noise and the true controller in its
   metadata (:func:`colloc.gait.trials.record_to_trial`);
7. ``figures`` and ``animation``.

The output directory is laid out as described in :mod:`colloc.gait.outputs`.
Everything is first written into a hidden staging directory inside ``<out>``, then each
item is moved into place by a rename, ``summary.json`` last; a failure before that leaves
the previous outputs untouched, and files of ``<out>`` that this workflow does not write
are never touched.
"""

from __future__ import annotations

import math
import secrets
import shutil
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from colloc.control.periodic_lqr import RiccatiBreakdownError
from colloc.gait.closed_loop import simulate_walking
from colloc.gait.cycle import find_walking_cycle
from colloc.gait.design import FEEDBACK_SETS, REGULATED, design_controller
from colloc.gait.metadata import STATE_SIGNAL_NAMES, controller_metadata, synthetic_metadata
from colloc.gait.orbit import GaitDynamics
from colloc.gait.outputs import (
    ANIMATION_FILE,
    CYCLE_FILE,
    OUTPUT_KEYS,
    SUMMARY_FILE,
    TRIAL_DIR,
    publish,
    summarize,
    write_animation,
    write_figures,
    write_json,
)
from colloc.gait.settings import (
    GaitSimulationSettings,
    belt_input,
)
from colloc.gait.settle import (
    DEFAULT_SETTLE_TOLERANCE,
    CycleNotSettledError,
    WalkerFellError,
    settle_cycle,
)
from colloc.gait.strikes import strike_phase
from colloc.gait.trials import record_to_trial
from colloc.gait.walking_cycle import WalkingCycle
from colloc.models.gait2d_params import load_parameters
from colloc.models.gait2d_points import StickFigureGeometry

Progress = Callable[[str, str], None]

#: How the simulated controller computes its phase (see colloc.gait.closed_loop).
SIMULATION_PHASE = (
    "causal, as a real-time controller: at each right heel strike detected online (upward "
    "crossing of 100 N by the right foot's vertical floor force, known one sample later) phi "
    "is reset to phi_0, the phase at which the same detector fires on the designed cycle, "
    "then rises linearly at the rate of the cycle's stride duration and holds at 1 + phi_0 "
    "until the next strike; schedule point p sits at phi = p / P, T* and K interpolated "
    "linearly and periodically in phi"
)

#: Uniform samples of the stride at which the settling controller is designed on the
#: collocation cycle. Finer than the cycle's nodes so that the gains change gradually
#: through heel strike and toe-off; measured on a 60-node cycle with full-state feedback: at
#: the nodes the closed loop lost a foot at the second heel strike, with 241 samples it
#: walked.
DESIGN_SAMPLES = 241
#: Samples (about 1 ms) at which the simulated controller is designed on the settled cycle.
#: Partial-state gains tuned on a coarser grid exploit its errors (tuned on 301 samples:
#: Floquet radius 0.48 there, 1.14 on 2401 samples).
SETTLED_DESIGN_SAMPLES = 1201
#: Schedule points of the settling controller, independent of the trial's ``P``: settling
#: only needs a controller that holds the stride, and a coarse one cannot (P = 20 and 50
#: fell within 0.3-0.8 s while settling the default cycle; 200 settles it).
SETTLE_POINTS = 200

#: Largest accepted change between the last two strides of the ``P``-point controller's own
#: stride (:func:`_schedule_orbit`): the settling tolerance. A stride that still changes is
#: not used: at 1.4 m/s the P = 20 walker's strides still differed by 0.013 rad after 19
#: strides, and the controller designed on its last stride fell 1.2 s into the perturbed belt,
#: where the one designed on the full-state stride walked 120 s.
ORBIT_TOLERANCE = DEFAULT_SETTLE_TOLERANCE

#: Schedule points whose walker's stride a coarser schedule is designed on when the coarser
#: one, designed on the full-state stride, falls on a constant belt (:func:`_schedule_orbit`).
#: At 1.6 m/s (160-node cycle) the P = 20 controller designed on the full-state stride fell
#: at 1.24 s; the P = 50 one walked and settled, and P = 20 designed on the P = 50 walker's
#: stride settled too (P = 35 between them had not settled after 16 strides).
ORBIT_LADDER: tuple[int, ...] = (50,)


class UnstableControllerError(ValueError):
    """The designed controller does not stabilise the walking cycle (Floquet radius >= 1)."""


@dataclass
class GaitSimulationResult:
    """What :func:`simulate_trial` produced.

    Attributes
    ----------
    settings : GaitSimulationSettings
    out : Path
        The output directory.
    files : dict
        Output name -> path (``trial``, ``cycle``, ``joint_angles``, ``contact_forces``,
        ``animation``, ``summary``); a figure that could not be drawn is absent.
    summary : dict
        The content of ``summary.json``.
    cycle, controller, Tstar, K, design_info, record, trial
        The intermediate objects, for callers that go on in memory.
    """

    settings: GaitSimulationSettings
    out: Path
    files: dict[str, Path]
    summary: dict[str, Any]
    cycle: Any = None
    controller: Any = None
    Tstar: np.ndarray | None = None
    K: np.ndarray | None = None
    design_info: Any = None
    record: Any = None
    trial: Any = None
    notes: list[str] = field(default_factory=list)

    @property
    def fell(self) -> bool:
        """Whether the walker fell during the simulation."""
        return bool(self.summary["fell"])


class _Clock:
    """Wall time of each step, reported through ``progress``."""

    def __init__(self, progress: Progress | None) -> None:
        self.progress = progress
        self.times: dict[str, float] = {}

    @contextmanager
    def step(self, name: str, detail: str) -> Iterator[None]:
        if self.progress is not None:
            self.progress(name, detail)
        start = time.perf_counter()
        yield
        # a step run again (a cycle refined) adds its time
        self.times[name] = self.times.get(name, 0.0) + time.perf_counter() - start


def motor_seed(seed: int) -> int:
    """Seed of the simulation's motor noise, derived from ``seed``.

    The sensor noise uses ``seed`` itself; an equal seed would make both noises draw the
    same standard-normal numbers, so the motor noise gets a seed spawned from it.
    """
    return int(np.random.SeedSequence([seed, 1]).generate_state(1)[0])


def check_stable(
    spectral_radius: float,
    settings: GaitSimulationSettings,
    feedback: str | None = None,
    num_points: int | None = None,
) -> None:
    """Refuse a controller whose linearised closed loop is not stable.

    Parameters
    ----------
    spectral_radius : float
        Largest Floquet multiplier magnitude of the designed closed loop
        (:attr:`colloc.gait.design.DesignInfo.spectral_radius`).
    settings : GaitSimulationSettings
        Named in the message.
    feedback : str, optional
        The feedback set of the design checked; default ``settings.feedback``.
    num_points : int, optional
        The design's schedule points; default ``settings.num_points``.

    Raises
    ------
    UnstableControllerError
        If ``spectral_radius`` is not finite or is >= 1.
    """
    if not (math.isfinite(spectral_radius) and spectral_radius < 1.0):
        raise UnstableControllerError(
            f"controller: expected a stabilising design (Floquet spectral radius < 1), found "
            f"{spectral_radius:.4g} for structure {settings.structure!r} with P = "
            f"{num_points or settings.num_points} schedule points and feedback "
            f"{feedback or settings.feedback!r}; the closed loop would fall, so nothing was "
            "simulated (try more schedule points, or feedback on more states)"
        )


def _settled_cycle(
    settings: GaitSimulationSettings,
    params: Any,
    dynamics: GaitDynamics,
    clock: _Clock,
    notes: list[str],
) -> WalkingCycle:
    """The walking cycle at ``settings.speed`` settled by a full-state controller, from the
    coarsest of the node counts to try that settles
    (:meth:`GaitSimulationSettings.nodes_to_try`)."""
    tries = settings.nodes_to_try()
    failures: list[str] = []
    schedule_fell = False
    last: Exception | None = None
    # the first node count whose full-state stride settled but whose P-point walker's did
    # not: its full-state stride, for when no finer cycle's walker settles either
    unsettled: tuple[int, WalkingCycle, str, int] | None = None
    for nodes in tries:
        with clock.step("cycle", f"periodic walking cycle at {settings.speed} m/s, {nodes} nodes"):
            try:
                cycle = find_walking_cycle(
                    settings.speed, num_nodes=nodes, params=params, cache=settings.cache
                )
            except RuntimeError as error:
                # a node count whose cycle the solver does not find is one more failed try,
                # not the end: at 1.17 m/s the 60-node cycle fell in its second stride and
                # the 100-node cycle's solve stopped at its 1000 iterations
                if len(tries) == 1:
                    raise
                failures.append(f"{nodes} nodes: the walking cycle: {error}")
                last = error
                continue
        with clock.step("settle", "the stride the continuous model walks, full-state feedback"):
            try:
                # Every state but the hip's place on the treadmill. With it (Q weight 0.5 m)
                # the default 1.2 m/s stride had not settled after 16 strides (multiplier
                # 0.81), with a stronger weight the walker fell; without it the stride drifts
                # 4.2 cm a stride.
                _, settle_tstar, settle_k, settle_info = design_controller(
                    cycle,
                    SETTLE_POINTS,
                    dynamics=dynamics,
                    num_samples=DESIGN_SAMPLES,
                    feedback=REGULATED,
                    fit_tstar=False,
                )
            except RiccatiBreakdownError as error:
                # a cycle whose linearisation the sampled LQR cannot stabilise (its Riccati
                # recursion overflowed on a 60-node 1.25 m/s cycle): try the finer one
                failures.append(f"{nodes} nodes: the settling controller's design: {error}")
                last = error
                continue
            try:
                check_stable(settle_info.spectral_radius, settings, "all", SETTLE_POINTS)
                settled = settle_cycle(cycle, settle_tstar, settle_k, REGULATED, dynamics=dynamics)
            except (CycleNotSettledError, UnstableControllerError) as error:
                failures.append(f"{nodes} nodes: {error}")
                last = error
                continue
        with clock.step("orbit", f"the stride the P = {settings.num_points} controller walks"):
            try:
                settled = _schedule_orbit(settled, settings, dynamics)
                if settled.stats.get("via_points"):
                    notes.append(
                        f"the P = {settings.num_points} controller designed on the full-state "
                        "stride fell on a constant belt; it was designed on the stride of the "
                        f"P = {settled.stats['via_points'][-1]} controller's walker instead "
                        "(a continuation in the number of schedule points)"
                    )
            except WalkerFellError as error:
                # a trial under this controller falls at once: say so before the perturbed walk
                failures.append(
                    f"{nodes} nodes: the P = {settings.num_points} controller designed on the "
                    f"settled stride does not walk a constant belt ({error})"
                )
                last = UnstableControllerError(failures[-1])
                schedule_fell = True
                continue
            except (CycleNotSettledError, UnstableControllerError) as error:
                # A P-point walker whose strides do not repeat is a poor cycle to design on,
                # and the full-state stride is not where that walker goes: at 1.35 and 1.5
                # m/s (60 nodes) the controller designed on the full-state stride fell 5-8 s
                # into the perturbed belt with or without motor noise, where at 1.35 m/s the
                # 100-node cycle's walker settled and walked. Try the finer cycle first.
                failures.append(
                    f"{nodes} nodes: the P = {settings.num_points} controller's own stride "
                    f"did not settle ({error})"
                )
                if unsettled is None:
                    unsettled = (nodes, settled, str(error), len(failures))
                last = error
                continue
        if failures:
            notes.append(f"the walking cycle was refined to {nodes} nodes: " + "; ".join(failures))
        settled.stats = {**settled.stats, "cycle_nodes": nodes}
        return settled
    if unsettled is not None:
        # no finer cycle did better: the trial's controller is designed on the full-state
        # stride of the first cycle that settled (before this rule, how 1.4 m/s walked)
        nodes, settled, why, count = unsettled
        notes.append(f"the P = {settings.num_points} controller's own stride was not used: {why}")
        if count > 1:
            notes.append(
                f"the walking cycle was refined to {nodes} nodes: "
                + "; ".join(failures[: count - 1])
            )
        if failures[count:]:
            notes.append("no finer cycle did better: " + "; ".join(failures[count:]))
        settled.stats = {**settled.stats, "cycle_nodes": nodes}
        return settled
    hint = (
        "the collocation cycle may be too coarse for this speed: try more nodes (num_nodes, "
        "--nodes)"
        if settings.num_nodes is not None
        else f"no cycle of {', '.join(map(str, tries))} nodes settled at this speed"
    )
    if schedule_fell:
        hint += (
            f"; a P = {settings.num_points} schedule cannot hold this speed's stride, so "
            "nothing was simulated: try more schedule points (--points) or a slower speed "
            "(docs/gait.md: synthetic walks lasted 480 s at 0.8-1.6 m/s with 3 N m)"
        )
    # the kind of the last failure (an unstable design stays a ValueError for the CLI)
    assert last is not None  # every node count tried failed, each setting last
    raise type(last)(f"{'; '.join(failures)}; {hint}") from last


def _trial_design(
    cycle: WalkingCycle, settings: GaitSimulationSettings, dynamics: GaitDynamics
) -> tuple[Any, np.ndarray, np.ndarray, Any]:
    """The trial's controller (``P``, structure and feedback of ``settings``) on ``cycle``."""
    return design_controller(
        cycle,
        settings.num_points,
        structure=settings.structure,
        dynamics=dynamics,
        num_samples=SETTLED_DESIGN_SAMPLES,
        feedback=FEEDBACK_SETS[settings.feedback],
    )


def _schedule_orbit(
    settled: WalkingCycle, settings: GaitSimulationSettings, dynamics: GaitDynamics
) -> WalkingCycle:
    """The stride the trial's own ``P``-point controller walks, designed on ``settled``.

    A ``P``-point schedule cannot reproduce the settled stride's torques exactly (between
    its points ``K(phi) s(phi)`` is not linear), so the walker under it follows a stride of
    its own, a little off the one it was designed on; the trial's controller is then
    designed on that stride, where the linearisation is where the walker goes. Measured
    with P = 20 and 3 N m of motor noise on the perturbed belt: designed on the full-state
    settled stride, 1.25 m/s seed 47 fell at 13.3 s and 0.8 m/s seed 1 at 7.7 s; designed
    on this stride, both walked 480 s.

    Where the ``P``-point controller designed on the full-state stride falls on the constant
    belt, that stride is too far from its own: the finer schedules of :data:`ORBIT_LADDER`
    walk first, each designed on the stride of the one before, and ``P`` on the last one's
    (a continuation in the number of points). When that fails too the first fall is raised.
    """
    try:
        return _orbit_under(settled, settings, dynamics, "the full-state settled stride")
    except WalkerFellError as fell:
        first = fell
    current, via = settled, []
    try:
        for points in (p for p in ORBIT_LADDER if p > settings.num_points):
            finer = replace(settings, num_points=points)
            current = _orbit_under(current, finer, dynamics, "the stride before")
            via.append(points)
        if not via:
            raise first
        orbit = _orbit_under(
            current, settings, dynamics, f"the stride of the P = {via[-1]} controller's walker"
        )
    except (CycleNotSettledError, UnstableControllerError):
        raise first from None
    orbit.stats = {**orbit.stats, "via_points": via}
    return orbit


def _orbit_under(
    cycle: WalkingCycle, settings: GaitSimulationSettings, dynamics: GaitDynamics, on: str
) -> WalkingCycle:
    """The stride ``settings``' ``P``-point controller, designed on ``cycle``, settles to."""
    _, tstar, gains, info = _trial_design(cycle, settings, dynamics)
    check_stable(info.spectral_radius, settings)
    orbit = settle_cycle(
        cycle,
        tstar,
        gains,
        FEEDBACK_SETS[settings.feedback],
        dynamics=dynamics,
        tol=ORBIT_TOLERANCE,
    )
    orbit.stats = {
        **orbit.stats,
        "source": (
            f"closed-loop simulation settled on a constant belt under the P = "
            f"{settings.num_points} controller designed on {on}"
        ),
    }
    return orbit


def simulate_trial(
    settings: GaitSimulationSettings, progress: Progress | None = None
) -> GaitSimulationResult:
    """Make one synthetic perturbed-walking trial and write it with figures and a summary.

    Parameters
    ----------
    settings : GaitSimulationSettings
        Validated before any work.
    progress : callable, optional
        ``progress(step, detail)`` at the start of each step.

    Returns
    -------
    GaitSimulationResult

    Raises
    ------
    ValueError
        If the settings are invalid (nothing is computed or written).
    UnstableControllerError
        If the designed controller's closed-loop Floquet spectral radius is >= 1 (the
        simulation would fall; nothing is simulated or written).
    RuntimeError
        If the cycle cannot be found (from :func:`find_walking_cycle`).
    """
    settings.validate()
    clock = _Clock(progress)
    params = load_parameters(settings.body_mass, settings.height)
    belt, belt_description = belt_input(settings)
    dynamics = GaitDynamics.build(params)
    notes: list[str] = []
    cycle = _settled_cycle(settings, params, dynamics, clock, notes)
    feedback = FEEDBACK_SETS[settings.feedback]
    with clock.step(
        "design", f"gain-scheduled controller on {settings.feedback!r}, P = {settings.num_points}"
    ):
        controller, Tstar, K, info = _trial_design(cycle, settings, dynamics)
    check_stable(info.spectral_radius, settings)
    with clock.step("simulate", f"{settings.duration} s of closed-loop walking"):
        record = simulate_walking(
            cycle,
            Tstar,
            K,
            settings.duration,
            belt,
            dynamics=dynamics,
            seed=motor_seed(settings.seed),
            sample_rate=settings.sample_rate,
            torque_noise=settings.motor_noise,
            feedback=feedback,
            substeps=settings.plate_substeps_exact() or 1,
        )
    with clock.step("trial", f"trial with sensor noise at {settings.sample_rate} Hz"):
        metadata = synthetic_metadata(
            controller=controller_metadata(
                Tstar,
                K,
                controller.mask,
                structure=settings.structure,
                phase_convention=SIMULATION_PHASE,
                feedback=[STATE_SIGNAL_NAMES[i] for i in feedback],
                phase_at_strike=strike_phase(cycle),
                stride_duration=cycle.duration,
            ),
            cycle_speed=cycle.belt_speed,
            cycle_duration=cycle.duration,
            body_mass=settings.body_mass,
            height=settings.height,
            belt=belt_description,
            fell=record.fell,
            message=record.message,
            extra={
                "settings": settings.to_dict(),
                "motor_noise": {"std": settings.motor_noise, "seed": motor_seed(settings.seed)},
                "cycle_nodes": cycle.stats["cycle_nodes"],
            },
        )
        trial = record_to_trial(
            record,
            noise_std=settings.noise,
            seed=settings.seed,
            metadata=metadata,
            sample_rate=settings.sample_rate,
        )

    out = Path(settings.out)
    out.mkdir(parents=True, exist_ok=True)
    staging = out / f".staging-{secrets.token_hex(8)}"
    try:
        staging.mkdir()
        trial.write(staging / TRIAL_DIR)
        cycle.to_npz(staging / CYCLE_FILE)
        names = [TRIAL_DIR, CYCLE_FILE]
        with clock.step("figures", "joint angles by gait cycle, contact forces"):
            names += write_figures(trial, record, staging, settings.animation_seconds, notes)
        with clock.step("animation", f"stick figure, first {settings.animation_seconds} s"):
            geometry = StickFigureGeometry.from_parameters(params)
            write_animation(record, geometry, staging / ANIMATION_FILE, settings.animation_seconds)
            names.append(ANIMATION_FILE)
        files = {OUTPUT_KEYS[name]: name for name in [*names, SUMMARY_FILE]}
        summary = summarize(settings.to_dict(), record, cycle, info, clock.times, files, notes)
        write_json(summary, staging / SUMMARY_FILE)
        moved = publish(staging, out, [*names, SUMMARY_FILE])
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    paths = {key: moved[name] for key, name in files.items()}
    return GaitSimulationResult(
        settings, out, paths, summary, cycle, controller, Tstar, K, info, record, trial, notes
    )
