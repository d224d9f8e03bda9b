"""Synthetic perturbed-walking trials end to end: cycle, controller, closed loop, trial files.

Steps of :func:`simulate_trial` (each timed, reported through ``progress``):

1. ``cycle``: a periodic walking cycle at the belt speed
   (:func:`colloc.gait.cycle.find_walking_cycle`);
2. ``settle``: a full-state controller closes the loop around it on a constant belt until the
   strides repeat; the last stride is the cycle the continuous model really walks
   (:func:`colloc.gait.settle.settle_cycle`);
3. ``design``: the gain-scheduled controller on the chosen feedback that stabilises the
   settled cycle (:func:`colloc.gait.design.design_controller`);
4. ``simulate``: the closed loop on a perturbed belt
   (:func:`colloc.gait.closed_loop.simulate_walking`);
5. ``trial``: the record as a gait-lab trial with sensor noise and the true controller in its
   metadata (:func:`colloc.gait.trials.record_to_trial`);
6. ``figures`` and ``animation``.

The output directory is laid out as described in :mod:`colloc.gait.outputs`.
Everything is first written into a hidden staging directory inside ``<out>``, then each
item is moved into place by a rename, ``summary.json`` last; a failure before that leaves
the previous outputs untouched, and files of ``<out>`` that this workflow does not write
are never touched.
"""

from __future__ import annotations

import math
import os
import secrets
import shutil
import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from colloc.data.belt import read_belt_perturbation
from colloc.gait.closed_loop import perturbation_belt_speed, simulate_walking
from colloc.gait.cycle import find_walking_cycle
from colloc.gait.design import FEEDBACK_SETS, REGULATED, design_controller
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
from colloc.gait.settle import settle_cycle
from colloc.gait.trials import (
    STATE_SIGNAL_NAMES,
    controller_metadata,
    record_to_trial,
    resolve_noise_std,
    synthetic_metadata,
)
from colloc.models.gait2d_params import load_parameters
from colloc.plot.gait_animation import StickFigureGeometry

Progress = Callable[[str, str], None]

#: Environment variable naming the default belt-speed record.
BELT_RECORD_ENV = "COLLOC_BELT_RECORD"

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


class UnstableControllerError(ValueError):
    """The designed controller does not stabilise the walking cycle (Floquet radius >= 1)."""


#: Gait-controller structures accepted by :attr:`GaitSimulationSettings.structure`.
STRUCTURES: tuple[str, ...] = ("full", "joint-isolated")


@dataclass(frozen=True)
class GaitSimulationSettings:
    """Everything that determines a synthetic walking trial.

    Attributes
    ----------
    duration : float
        Seconds of walking to simulate, > 0.
    speed : float
        Mean belt speed [m/s], > 0 (the cycle is found at this speed).
    seed : int
        Seeds the sensor noise (and, through the simulation, any random belt signal), >= 0.
    out : Path
        Output directory (created if missing).
    num_points : int
        ``P``: controller schedule points over the stride, >= 2.
    noise : float or mapping
        Sensor noise: a multiple of :data:`colloc.gait.trials.DEFAULT_NOISE_STD` (0 for none)
        or group -> standard deviation (see :func:`colloc.gait.trials.resolve_noise_std`).
    sample_rate : float
        Trial sample rate [Hz], > 0.
    cache : bool or path
        Build cache for the collocation problem of the cycle (True: default location).
    body_mass, height : float
        The simulated subject [kg], [m].
    perturbed : bool
        Drive the belt with the measured perturbation record; False: constant ``speed``.
    belt_record : Path or None
        The belt-speed record (:func:`colloc.data.belt.read_belt_perturbation` format),
        shifted to mean ``speed`` with its deviations kept and mirrored in time beyond its
        end (:func:`colloc.gait.closed_loop.perturbation_belt_speed`); None: see
        :func:`default_belt_record`.
    motor_noise : float
        Standard deviation [N·m] of Gaussian noise added to each joint torque in the
        simulation (seeded by ``seed``); 0 for none.
    structure : str
        Controller structure, one of :data:`STRUCTURES`.
    feedback : str
        The states the controller feeds back, a key of
        :data:`colloc.gait.design.FEEDBACK_SETS`: ``"joints"`` (the six joint angles and
        rates), ``"joints+trunk"`` or ``"all"`` (every state but the hip's forward position).
    animation_seconds : float
        Length of the animation and of the contact-force window [s], > 0.
    """

    duration: float = 60.0
    speed: float = 1.2
    seed: int = 0
    out: Path = Path("gait-simulation")
    num_points: int = 200
    noise: float | Mapping[str, float] = 1.0
    sample_rate: float = 100.0
    cache: bool | str | os.PathLike[str] = True
    body_mass: float = 75.0
    height: float = 1.80
    perturbed: bool = True
    belt_record: Path | None = None
    motor_noise: float = 0.0
    structure: str = "full"
    feedback: str = "all"
    animation_seconds: float = 5.0

    def problems(self) -> list[str]:
        """Every problem with these settings (empty when they are usable)."""
        out = []
        positive = {
            "duration": "seconds",
            "speed": "m/s",
            "sample_rate": "Hz",
            "body_mass": "kg",
            "height": "m",
            "animation_seconds": "seconds",
        }
        for name, unit in positive.items():
            value = getattr(self, name)
            if not (_finite(value) and value > 0):
                out.append(f"{name}: expected a positive finite number [{unit}], found {value!r}")
        if not (_finite(self.motor_noise) and self.motor_noise >= 0):
            out.append(
                f"motor_noise: expected a finite number >= 0 [N·m], found {self.motor_noise!r}"
            )
        if not isinstance(self.perturbed, bool):
            out.append(f"perturbed: expected True or False, found {self.perturbed!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            out.append(f"seed: expected an integer >= 0, found {self.seed!r}")
        points = self.num_points
        if isinstance(points, bool) or not isinstance(points, int) or points < 2:
            out.append(f"num_points: expected an integer >= 2, found {points!r}")
        try:
            resolve_noise_std(self.noise)
        except (TypeError, ValueError) as error:
            out.append(f"noise: {error}")
        if not isinstance(self.cache, bool | str | os.PathLike):
            out.append(f"cache: expected a bool or a directory path, found {self.cache!r}")
        if self.structure not in STRUCTURES:
            out.append(f"structure: expected one of {list(STRUCTURES)}, found {self.structure!r}")
        if self.feedback not in FEEDBACK_SETS:
            out.append(f"feedback: expected one of {list(FEEDBACK_SETS)}, found {self.feedback!r}")
        elif self.structure == "joint-isolated" and self.feedback != "joints":
            out.append(
                "structure: 'joint-isolated' needs feedback 'joints' (each torque from its own "
                f"joint's angle and rate), found feedback {self.feedback!r}"
            )
        if not isinstance(self.out, str | os.PathLike):
            out.append(f"out: expected a directory path, found {type(self.out).__name__}")
        elif Path(self.out).exists() and not Path(self.out).is_dir():
            out.append(f"out: expected a directory, found an existing file {str(self.out)!r}")
        if self.perturbed is True and not self.belt_path.is_file():
            out.append(
                f"belt_record: expected an existing belt-speed record file, found "
                f"{str(self.belt_path)!r}; pass its path (or set ${BELT_RECORD_ENV}), or walk "
                "on a constant-speed belt (perturbed=False)"
            )
        return out

    @property
    def belt_path(self) -> Path:
        """:attr:`belt_record`, or :func:`default_belt_record` when it is None."""
        return default_belt_record() if self.belt_record is None else Path(self.belt_record)

    def validate(self) -> None:
        """Raise ``ValueError`` listing every problem (before any work starts)."""
        found = self.problems()
        if found:
            lines = "\n".join(f"  - {p}" for p in found)
            raise ValueError(f"invalid gait simulation settings:\n{lines}")

    def to_dict(self) -> dict[str, Any]:
        """Plain (JSON-ready) settings."""
        plain = asdict(self)
        for key in ("out", "belt_record", "cache"):
            if isinstance(plain[key], os.PathLike):
                plain[key] = os.fspath(plain[key])
        plain["noise"] = dict(self.noise) if isinstance(self.noise, Mapping) else float(self.noise)
        return plain


def _finite(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


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
        self.times[name] = time.perf_counter() - start


def motor_seed(seed: int) -> int:
    """Seed of the simulation's motor noise, derived from ``seed``.

    The sensor noise uses ``seed`` itself; an equal seed would make both noises draw the
    same standard-normal numbers, so the motor noise gets a seed spawned from it.
    """
    return int(np.random.SeedSequence([seed, 1]).generate_state(1)[0])


def default_belt_record() -> Path:
    """The belt-speed record used by default.

    ``$COLLOC_BELT_RECORD`` if set, else the copy shipped in ``colloc/gait/reference``: a
    measured pseudo-random belt perturbation of the CSU R-Mill, 1.2 m/s nominal, 100 Hz
    (see its SOURCE.md).
    """
    if os.environ.get(BELT_RECORD_ENV):
        return Path(os.environ[BELT_RECORD_ENV])
    return Path(__file__).resolve().parent / "reference" / "RandomSlowSpeed1.txt"


def belt_input(
    settings: GaitSimulationSettings,
) -> tuple[tuple[np.ndarray, np.ndarray] | None, dict[str, Any]]:
    """The belt-speed samples for the simulation and their description for the metadata.

    Parameters
    ----------
    settings : GaitSimulationSettings

    Returns
    -------
    belt_speed : (times, speed) or None
        None for a constant belt at ``settings.speed``.
    description : dict
        ``source``, ``mean_speed`` and, for a record, ``rescaling`` and the record's mean
        and standard deviation.
    """
    if not settings.perturbed:
        return None, {"source": "constant", "mean_speed": float(settings.speed)}
    path = settings.belt_path
    _, recorded = read_belt_perturbation(path)
    samples = perturbation_belt_speed(
        path, settings.speed, settings.duration, sample_rate=settings.sample_rate
    )
    description = {
        "source": os.fspath(path),
        "rescaling": (
            "v = mean_speed + (v_record - mean(v_record)) (colloc.data.rescale_belt_speed, "
            "deviation_scale 1), mirrored in time beyond the end of the record"
        ),
        "mean_speed": float(settings.speed),
        "deviation_scale": 1.0,
        "record_mean_speed": float(np.mean(recorded)),
        "record_std_speed": float(np.std(recorded)),
    }
    return samples, description


def check_stable(
    spectral_radius: float, settings: GaitSimulationSettings, feedback: str | None = None
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

    Raises
    ------
    UnstableControllerError
        If ``spectral_radius`` is not finite or is >= 1.
    """
    if not (math.isfinite(spectral_radius) and spectral_radius < 1.0):
        raise UnstableControllerError(
            f"controller: expected a stabilising design (Floquet spectral radius < 1), found "
            f"{spectral_radius:.4g} for structure {settings.structure!r} with P = "
            f"{settings.num_points} schedule points and feedback "
            f"{feedback or settings.feedback!r}; the closed loop would fall, so nothing was "
            "simulated (try more schedule points, or feedback on more states)"
        )


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
    with clock.step("cycle", f"periodic walking cycle at {settings.speed} m/s"):
        cycle = find_walking_cycle(settings.speed, params=params, cache=settings.cache)
    dynamics = GaitDynamics.build(params)
    with clock.step("settle", "the stride the continuous model walks, full-state feedback"):
        _, settle_tstar, settle_k, settle_info = design_controller(
            cycle,
            settings.num_points,
            dynamics=dynamics,
            num_samples=DESIGN_SAMPLES,
            feedback=REGULATED,
        )
        check_stable(settle_info.spectral_radius, settings, "all")
        cycle = settle_cycle(cycle, settle_tstar, settle_k, REGULATED, dynamics=dynamics)
    feedback = FEEDBACK_SETS[settings.feedback]
    with clock.step(
        "design", f"gain-scheduled controller on {settings.feedback!r}, P = {settings.num_points}"
    ):
        controller, Tstar, K, info = design_controller(
            cycle,
            settings.num_points,
            structure=settings.structure,
            dynamics=dynamics,
            num_samples=SETTLED_DESIGN_SAMPLES,
            feedback=feedback,
        )
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
    notes: list[str] = []
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
