"""Settings of a synthetic walking trial and the belt input they select.

:class:`GaitSimulationSettings` holds everything that determines a trial of
:func:`colloc.gait.workflow.simulate_trial` and reports every problem with it before any work
starts; :func:`belt_input` turns its belt options into the samples the simulation follows.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from colloc.data.belt import perturbation_belt_speed, read_belt_perturbation
from colloc.data.trial import replace_refusal
from colloc.gait.cycle import MIN_NUM_NODES
from colloc.gait.design import FEEDBACK_SETS
from colloc.gait.trials import resolve_noise_std

#: Environment variable naming the default belt-speed record.
BELT_RECORD_ENV = "COLLOC_BELT_RECORD"
#: The belt-speed record shipped with colloc (see its SOURCE.md).
SHIPPED_BELT_RECORD = Path(__file__).resolve().parent / "reference" / "RandomSlowSpeed1.txt"

#: Schedule points of the trial's controller by default: the smallest P measured to walk the
#: whole 8-minute perturbation record (feedback "all", settled 1.2 m/s cycle: P = 20 walked
#: 480 s, 408 strides; P = 10 fell after 0.95 s). An identification must estimate
#: P x (6 + 6 x 17) = 2160 parameters for it, against 21 600 at the former P = 200.
DEFAULT_NUM_POINTS = 20
#: Ranges the simulation works in, each checked before any work with its reason (outside
#: them the run failed 15-45 s in, unclearly: issue 32's list).
#: Two complete strides (about 1.1 s each) at least, for heel strikes to phase a trial.
MIN_DURATION = 3.0
#: Walking speeds [m/s]: the cycle search tracks Winter's normal stride, measured at 1.2 and
#: 1.4 m/s; at 1e-9 m/s it ran out of iterations.
SPEED_RANGE = (0.5, 2.0)
#: Collocation nodes of the walking cycle: a million took all the memory.
MAX_NUM_NODES = 400
#: Collocation nodes of the walking cycle tried in turn when none are given, until the
#: cycle settles. Measured (12 s trials, seed 3): the 60-node cycle settles and walks at 0.9,
#: 1.0, 1.1 and 1.2 m/s but its settling loop fell within 0.3-2.2 s at 1.05, 1.15, 1.25,
#: 1.3, 1.35 and 1.4 m/s; the 100-node cycle settled and walked at 1.05-1.3 m/s in 29-49 s.
#: 60 first keeps the trials made before this default unchanged.
AUTO_NUM_NODES: tuple[int, ...] = (60, 100, 160)
#: Below this speed [m/s] the node counts tried start at the second of :data:`AUTO_NUM_NODES`:
#: at 0.8 m/s (a 1.5 s stride, 25 ms per interval of the 60-node cycle) the walker designed on
#: the 60-node cycle tripped and fell in 7 of 20 walks of 480 s with 3-5 N m of motor noise
#: (the swing toe catching the belt where the record slows it to 60-69 % of the speed); on the
#: 100-node cycle all seven that fell walked 480 s, with the same seeds and noise
#: (docs/gait.md). At 0.85 m/s and faster the 60-node walker walked every seed measured.
SLOW_CYCLE_SPEED = 0.85
#: Schedule points: each is one periodic LQR design; 100 000 was still designing after 45 s.
MAX_NUM_POINTS = 200
#: Motor noise [N m]: real walking has 2-5; 1e9 broke the simulation.
MAX_MOTOR_NOISE = 100.0
#: Largest ratio of the plates' rate to the sample rate (20 kHz plates under 1 kHz cameras).
MAX_PLATE_SUBSTEPS = 20

#: Wall seconds per simulated second of walking, and the fixed cost before it (cycle, settle,
#: design, figures). Measured on the 2-core machine at the defaults: 60 s of walking took
#: 23 s of simulation after 20 s of set-up; the whole 480 s record took 4 min 37 s.
SIMULATION_SECONDS_PER_SECOND, SIMULATION_SETUP_SECONDS = 0.5, 30.0

#: Bytes held per trial sample (about 50 float64 columns, a few copies while the trial is
#: written) and the process's own size (330 MB measured for 10 s and for 60 s of walking).
BYTES_PER_SAMPLE, BASE_BYTES = 1600.0, 0.4 * 2**30

#: Runs estimated longer than this are announced before they start [s].
LONG_SIMULATION_SECONDS = 120.0

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
        ``P``: schedule points of the trial's controller over the stride, >= 2 (default
        :data:`DEFAULT_NUM_POINTS`); the settling controller always has
        :data:`colloc.gait.workflow.SETTLE_POINTS`.
    num_nodes : int or None
        Collocation nodes of the walking cycle, >= :data:`colloc.gait.cycle.MIN_NUM_NODES`;
        None (the default): each of :meth:`nodes_to_try` in turn until the cycle settles
        (the summary's ``cycle_nodes`` says which). A given number is used alone.
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
    perturbation_scale : float
        Factor on the record's deviations from its mean speed, >= 0 (1: as measured; e.g.
        0.25 for a controller that cannot take the full perturbation).
    belt_record : Path or None
        The belt-speed record (:func:`colloc.data.belt.read_belt_perturbation` format),
        shifted to mean ``speed`` with its deviations kept and mirrored in time beyond its
        end (:func:`colloc.data.belt.perturbation_belt_speed`); None: see
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
    plate_rate : float or None
        Also keep the walk's ground reactions at this rate [Hz], a whole multiple of
        ``sample_rate`` (force plates sample faster than cameras: 1000 Hz against 100 Hz),
        for a lab export's plates; None: at the sample rate only.
    """

    duration: float = 60.0
    speed: float = 1.2
    seed: int = 0
    out: Path = Path("gait-simulation")
    num_points: int = DEFAULT_NUM_POINTS
    num_nodes: int | None = None
    noise: float | Mapping[str, float] = 1.0
    sample_rate: float = 100.0
    cache: bool | str | os.PathLike[str] = True
    body_mass: float = 75.0
    height: float = 1.80
    perturbed: bool = True
    perturbation_scale: float = 1.0
    belt_record: Path | None = None
    motor_noise: float = 0.0
    structure: str = "full"
    feedback: str = "all"
    animation_seconds: float = 5.0
    plate_rate: float | None = None

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
            elif name == "duration" and value < MIN_DURATION:
                out.append(
                    f"duration: expected at least {MIN_DURATION} s (two complete strides to "
                    f"phase the trial), found {value!r}"
                )
            elif name == "speed" and not SPEED_RANGE[0] <= value <= SPEED_RANGE[1]:
                out.append(
                    f"speed: expected a walking speed from {SPEED_RANGE[0]} to {SPEED_RANGE[1]} "
                    f"m/s (the walking cycle tracks a normal stride), found {value!r}"
                )
        if not (_finite(self.motor_noise) and 0 <= self.motor_noise <= MAX_MOTOR_NOISE):
            out.append(
                f"motor_noise: expected a number from 0 to {MAX_MOTOR_NOISE} [N·m] (real "
                f"walking has 2-5), found {self.motor_noise!r}"
            )
        if not (_finite(self.perturbation_scale) and self.perturbation_scale >= 0):
            out.append(
                "perturbation_scale: expected a finite number >= 0, found "
                f"{self.perturbation_scale!r}"
            )
        if self.plate_rate is not None:
            ratio = self.plate_substeps_exact()
            if ratio is None:
                out.append(
                    f"plate_rate: expected None or a whole multiple (1 to {MAX_PLATE_SUBSTEPS}) "
                    f"of sample_rate {self.sample_rate!r} Hz, found {self.plate_rate!r}"
                )
        if not isinstance(self.perturbed, bool):
            out.append(f"perturbed: expected True or False, found {self.perturbed!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            out.append(f"seed: expected an integer >= 0, found {self.seed!r}")
        points = self.num_points
        if (
            isinstance(points, bool)
            or not isinstance(points, int)
            or not 2 <= points <= MAX_NUM_POINTS
        ):
            out.append(
                f"num_points: expected an integer from 2 to {MAX_NUM_POINTS} (one periodic LQR "
                f"design each), found {points!r}"
            )
        nodes = self.num_nodes
        if nodes is not None and (
            isinstance(nodes, bool)
            or not isinstance(nodes, int)
            or not MIN_NUM_NODES <= nodes <= MAX_NUM_NODES
        ):
            out.append(
                f"num_nodes: expected None (automatic) or an integer from {MIN_NUM_NODES} to "
                f"{MAX_NUM_NODES}, found {nodes!r}"
            )
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
        elif not str(self.out).strip():
            out.append("out: expected a directory path, found an empty one")
        elif Path(self.out).exists() and not Path(self.out).is_dir():
            out.append(f"out: expected a directory, found an existing file {str(self.out)!r}")
        else:
            from colloc.gait.outputs import TRIAL_DIR  # figures' imports: only when checked

            refusal = replace_refusal(Path(self.out) / TRIAL_DIR)
            if refusal is not None:
                out.append(f"out: the trial goes to {TRIAL_DIR}/ inside it, but {refusal}")
        if self.perturbed is True and not self.belt_path.is_file():
            out.append(
                f"belt_record: expected an existing belt-speed record file, found "
                f"{str(self.belt_path)!r}; pass its path (or set ${BELT_RECORD_ENV}), or walk "
                "on a constant-speed belt (perturbed=False)"
            )
        return out

    def estimated_needs(self) -> dict[str, float]:
        """What the simulation will need, from its settings alone (before any work).

        Memory grows with the trial's samples (:data:`BYTES_PER_SAMPLE` each over
        :data:`BASE_BYTES`), time with the simulated seconds
        (:data:`SIMULATION_SECONDS_PER_SECOND` after :data:`SIMULATION_SETUP_SECONDS`):
        rough figures for refusing what cannot fit and announcing what is long.

        Returns
        -------
        dict
            ``samples``, ``memory_bytes`` and ``seconds``.
        """
        samples = float(self.duration) * float(self.sample_rate) + 1.0
        return {
            "samples": samples,
            "memory_bytes": BASE_BYTES + BYTES_PER_SAMPLE * samples,
            "seconds": SIMULATION_SETUP_SECONDS
            + SIMULATION_SECONDS_PER_SECOND * float(self.duration),
        }

    def too_big(self, memory_bytes: float) -> list[str]:
        """Problems for a simulation that cannot fit in ``memory_bytes`` (e.g. the RAM).

        Parameters
        ----------
        memory_bytes : float

        Returns
        -------
        list of str
            Empty when the estimate fits (and when the settings are invalid anyway).
        """
        if self.problems():
            return []
        needs = self.estimated_needs()
        if needs["memory_bytes"] <= memory_bytes:
            return []
        return [
            f"duration {self.duration:g} s at sample_rate {self.sample_rate:g} Hz: "
            f"{needs['samples']:.3g} samples need an estimated "
            f"{needs['memory_bytes'] / 2**30:.3g} GiB, more than the "
            f"{memory_bytes / 2**30:.3g} GiB available (and about "
            f"{needs['seconds'] / 3600:.3g} h); simulate a shorter trial or a lower rate"
        ]

    def plate_substeps_exact(self) -> int | None:
        """``plate_rate / sample_rate`` when it is a whole number from 1 to
        :data:`MAX_PLATE_SUBSTEPS` (1 without a plate rate), else None."""
        if self.plate_rate is None:
            return 1
        if not (_finite(self.plate_rate) and _finite(self.sample_rate) and self.sample_rate > 0):
            return None
        ratio = float(self.plate_rate) / float(self.sample_rate)
        whole = int(round(ratio))
        if abs(ratio - whole) > 1e-9 * max(ratio, 1.0) or not 1 <= whole <= MAX_PLATE_SUBSTEPS:
            return None
        return whole

    @property
    def belt_path(self) -> Path:
        """:attr:`belt_record`, or :func:`default_belt_record` when it is None."""
        return default_belt_record() if self.belt_record is None else Path(self.belt_record)

    def nodes_to_try(self) -> tuple[int, ...]:
        """The walking cycle's node counts tried in turn: :attr:`num_nodes` alone when given,
        else :data:`AUTO_NUM_NODES` (from its second below :data:`SLOW_CYCLE_SPEED`)."""
        if self.num_nodes is not None:
            return (self.num_nodes,)
        return AUTO_NUM_NODES[1:] if self.speed < SLOW_CYCLE_SPEED else AUTO_NUM_NODES

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


def default_belt_record() -> Path:
    """The belt-speed record used by default.

    ``$COLLOC_BELT_RECORD`` if set, else the copy shipped in ``colloc/gait/reference``: a
    measured pseudo-random belt perturbation of the CSU R-Mill, 1.2 m/s nominal, 100 Hz
    (see its SOURCE.md).
    """
    if os.environ.get(BELT_RECORD_ENV):
        return Path(os.environ[BELT_RECORD_ENV])
    return SHIPPED_BELT_RECORD


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
    scale = float(settings.perturbation_scale)
    samples = perturbation_belt_speed(
        path,
        settings.speed,
        settings.duration,
        sample_rate=settings.sample_rate,
        deviation_scale=scale,
    )
    description = {
        "source": os.fspath(path),
        "rescaling": (
            "v = mean_speed + deviation_scale (v_record - mean(v_record)) "
            "(colloc.data.rescale_belt_speed), mirrored in time beyond the end of the record"
        ),
        "mean_speed": float(settings.speed),
        "deviation_scale": scale,
        "record_mean_speed": float(np.mean(recorded)),
        "record_std_speed": float(np.std(recorded)),
    }
    return samples, description


__all__ = [
    "BELT_RECORD_ENV",
    "DEFAULT_NUM_POINTS",
    "STRUCTURES",
    "GaitSimulationSettings",
    "belt_input",
    "default_belt_record",
]
