"""What determines a gait controller identification, checked before any work starts.

Kept apart from the workflow (:mod:`colloc.identify.gait.workflow`) so that the command line can show
its defaults without importing SymPy, CasADi or SciPy.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

#: ``--phase``: causal (reset at each right heel strike, rising at the stride rate, held at
#: the stride's end: what a real-time controller can know; colloc.data.causal_gait_phase),
#: linear between right heel strikes (needs the next strike), or the trial's own
#: ``controller_phase`` column (a synthetic trial's true phase).
PHASES = ("causal", "heel-strikes", "controller")
#: ``--feedback``: the trial's recorded set, or a named set of fed-back states.
FEEDBACK_CHOICES = ("metadata", "joints", "joints+trunk", "all")
#: ``--track``: the measured signals the objective tracks.
TRACK_CHOICES = ("angles", "trunk", "rates", "torques")
#: Default tracked signals: what a gait lab measures, the joint torques from inverse dynamics
#: included. Without the torques the data cannot identify the default controller: the
#: Cramer-Rao bound of K over 30 s of the default trial is 36 % with them and 310 % from
#: positions and rates alone (benchmarks/gait_information.py).
DEFAULT_TRACK = ("angles", "trunk", "torques")
#: Controller parameter guesses: direct identification (least squares of the measured
#: torques on the measured feedback), or all zero.
GUESSES = ("direct", "zero")
SCHEMES = ("midpoint", "backward-euler")
#: ``--method``: the dynamically consistent smoother then the schedule's least squares on its
#: signals (converges on noisy trials), or the closed-loop collocation problem solved by
#: constrained Gauss-Newton (exact on noise-free trials; diverges on noisy ones).
METHODS = ("smoother", "closed-loop")
STRUCTURES = ("full", "joint-isolated")
#: ``--smooth-from``: what the smoother tracks. ``markers``: the lab's raw markers and plates
#: (a lab trial's ``markers.csv`` and ``plates.csv``; colloc.identify.gait.markers);
#: ``markers-only``: the markers without the plates; ``angles``: the trial's angles, trunk
#: pose and torques (a simulated trial's, or a lab's through its 6 Hz filter, inverse
#: kinematics and dynamics); ``auto``: markers and plates when the trial has markers. The
#: sources are colloc.identify.gait.windows.SOURCES.
SMOOTH_SOURCES = ("auto", "markers", "markers-only", "angles")
#: ``--design-bound``: which Cramer-Rao bound the run computes beside the schedule's own
#: (states known): ``full``, the whole design's with the states unknown
#: (colloc.identify.gait.design_bound; method smoother on a trial's angles).
DESIGN_BOUNDS = ("states-known", "full")
#: ``--noise-levels``: what the marker smoother's noise levels may replace.
NOISE_LEVEL_NAMES = ("marker", "force", "moment", "torque_prior")
#: Schedule points when neither ``points`` nor the trial's metadata give them.
DEFAULT_POINTS = 20
#: The smoother fit's instruments: the fed-back states one and two samples earlier. Measured
#: on 120 s of a trial with 3 N m motor noise (``docs/gait.md``): the least squares' K error
#: 52 % on exact states (the noise reaches the ankle rates within a sample), 21 % with these
#: instruments; on the smoothed states 51 % and 31 % (bound 21 %).
DEFAULT_INSTRUMENT_LAGS = (1, 2)


@dataclass(frozen=True)
class GaitIdentifySettings:
    """Everything that determines a gait controller identification.

    Attributes
    ----------
    trial : Path
        Trial directory (:func:`colloc.data.read_trial`).
    fit_fraction : float
        Share of the trial before the split (at the right heel strike nearest to it).
    points : int or None
        Schedule points ``P``; None: the trial's controller's when its metadata records one,
        else :data:`DEFAULT_POINTS`.
    feedback : str
        One of :data:`FEEDBACK_CHOICES`; ``metadata``: the set the trial's metadata records,
        else the six joint angles and six joint rates.
    structure : str
        ``full`` or ``joint-isolated`` (each torque from its own joint's angle and rate).
    scheme : str
        ``midpoint`` or ``backward-euler``.
    phase : str
        One of :data:`PHASES`.
    guess : str
        One of :data:`GUESSES`.
    track : tuple of str
        Signals tracked by the objective, from :data:`TRACK_CHOICES`.
    start : float
        Seconds from the trial's start to the fit window (snapped to the next right heel
        strike).
    duration : float or None
        Seconds of the fit window (ending at the last right heel strike inside it); None: up
        to the split.
    segment_nodes : int
        Nodes per condensing segment of the Gauss-Newton solver.
    max_iter : int
        Solver iterations.
    smoothing_window : float
        Seconds of the Savitzky-Golay window that differentiates measured positions into rates
        (start and direct identification) for a trial without rate columns.
    simulate_validation : bool
        Walk the identified controller through the held-out part (forward simulation).
    seed : int
        Seeds any random draw (none in the default settings; recorded with the run).
    method : str
        One of :data:`METHODS`.
    process_noise : tuple of float or None
        ``(joint, trunk)``: standard deviations of the motor noise on each joint torque [N m]
        and of a residual force on each trunk coordinate [N, N, N m] per sample, estimated as
        disturbance trajectories (the maximum a posteriori fit; standard errors by the
        sandwich over strides). None: the dynamics hold exactly.
    instrument_lags : tuple of int
        Method ``smoother``: the schedule is fitted by two-stage least squares with the
        fed-back states this many samples earlier as instruments
        (:func:`colloc.identify.gait.controller_fit.fit_schedule_with_errors`); empty:
        ordinary least squares.
    smooth_from : str
        One of :data:`SMOOTH_SOURCES` (method ``smoother``).
    noise_levels : tuple of (str, float)
        Smoothing from markers: noise levels replacing the trial's estimates, as
        ``(name, value)`` pairs with names from :data:`NOISE_LEVEL_NAMES` (``marker`` [m],
        ``force`` [N], ``moment`` [N m], ``torque_prior`` [N m]); empty: the trial's.
    fit_places : bool
        Smoothing from markers: estimate each marker's place in its segment with the motion
        (:func:`colloc.identify.gait.markers.marker_smoother`), each window its own.
    design_bound : str
        One of :data:`DESIGN_BOUNDS`: ``full`` also computes the whole design's bound, the
        states unknown (method ``smoother`` on a trial's angles, trunk and torques).
    truth : Path or None
        A trial whose metadata records the controller that made this walk (the simulated
        trial a lab export was written from): its controller is taken as this trial's, for
        the errors against the truth and for what the trial's own controller decides (the
        feedback set with ``feedback="metadata"``, ``P``, the causal phase law). None
        (default): this trial's own metadata.
    window_strides : int or None
        Method ``smoother``: smooth the fit window in windows of this many whole strides
        (:func:`colloc.data.split.stride_windows`), each with its own states and start,
        sharing the controller: the schedule's fit sums their information, its lags stay
        inside each. Memory then follows the window, not the record; windows are independent
        (the episodes a cluster distributes). None (default): one window.
    """

    trial: Path
    fit_fraction: float = 0.75
    points: int | None = None
    feedback: str = "metadata"
    structure: str = "full"
    scheme: str = "midpoint"
    phase: str = "causal"
    guess: str = "direct"
    track: tuple[str, ...] = DEFAULT_TRACK
    start: float = 0.0
    duration: float | None = None
    segment_nodes: int = 50
    max_iter: int = 100
    smoothing_window: float = 0.05
    simulate_validation: bool = True
    seed: int = 0
    process_noise: tuple[float, float] | None = None
    method: str = "smoother"
    instrument_lags: tuple[int, ...] = DEFAULT_INSTRUMENT_LAGS
    window_strides: int | None = None
    truth: Path | None = None
    smooth_from: str = "auto"
    noise_levels: tuple[tuple[str, float], ...] = ()
    fit_places: bool = False
    design_bound: str = "states-known"

    def problems(self, *, require_trial: bool = True) -> list[str]:
        """Every problem with the settings (empty when valid); the trial is not read.

        Parameters
        ----------
        require_trial : bool, optional
            False: a trial folder that does not exist yet is no problem (a batch makes it
            before this run starts).
        """
        out = []
        if not isinstance(self.trial, str | Path):
            out.append(f"trial: expected a directory path, found {self.trial!r}")
        elif require_trial and not Path(self.trial).is_dir():
            out.append(f"trial: expected an existing directory, found {str(self.trial)!r}")
        if not (_number(self.fit_fraction) and 0 < self.fit_fraction < 1):
            out.append(f"fit_fraction: expected a number in (0, 1), found {self.fit_fraction!r}")
        if self.points is not None and not (_integer(self.points) and self.points >= 2):
            out.append(f"points: expected an integer >= 2, found {self.points!r}")
        for name, choices in (
            ("feedback", FEEDBACK_CHOICES),
            ("structure", STRUCTURES),
            ("scheme", SCHEMES),
            ("phase", PHASES),
            ("guess", GUESSES),
            ("method", METHODS),
            ("smooth_from", SMOOTH_SOURCES),
            ("design_bound", DESIGN_BOUNDS),
        ):
            if getattr(self, name) not in choices:
                out.append(
                    f"{name}: expected one of {list(choices)}, found {getattr(self, name)!r}"
                )
        track = self.track
        if (
            not isinstance(track, tuple)
            or not track
            or any(t not in TRACK_CHOICES for t in track)
            or len(set(track)) != len(track)
        ):
            out.append(
                f"track: expected distinct names from {list(TRACK_CHOICES)}, found {track!r}"
            )
        elif not {"angles", "trunk"} & set(track):
            out.append(
                f"track: expected 'angles' or 'trunk' among the tracked signals, found {track}"
            )
        if not (_number(self.start) and self.start >= 0):
            out.append(f"start: expected a number >= 0, found {self.start!r}")
        if self.duration is not None and not (_number(self.duration) and self.duration > 0):
            out.append(f"duration: expected a number > 0 or None, found {self.duration!r}")
        if not (_integer(self.segment_nodes) and self.segment_nodes >= 2):
            out.append(f"segment_nodes: expected an integer >= 2, found {self.segment_nodes!r}")
        if not (_integer(self.max_iter) and self.max_iter >= 0):
            out.append(f"max_iter: expected an integer >= 0, found {self.max_iter!r}")
        if not (_number(self.smoothing_window) and self.smoothing_window > 0):
            out.append(f"smoothing_window: expected seconds > 0, found {self.smoothing_window!r}")
        if not (_integer(self.seed) and self.seed >= 0):
            out.append(f"seed: expected an integer >= 0, found {self.seed!r}")
        lags = self.instrument_lags
        if not isinstance(lags, tuple) or any(not (_integer(g) and 1 <= g <= 50) for g in lags):
            out.append(
                f"instrument_lags: expected a tuple of whole numbers of samples in [1, 50], "
                f"found {lags!r}"
            )
        elif len(set(lags)) != len(lags):
            out.append(f"instrument_lags: expected distinct lags, found {lags!r}")
        windows = self.window_strides
        if windows is not None and not (_integer(windows) and windows >= 2):
            out.append(
                f"window_strides: expected None or whole strides >= 2 per window, found {windows!r}"
            )
        elif windows is not None and self.method != "smoother":
            out.append(
                f"window_strides: an option of method 'smoother', found method {self.method!r}"
            )
        if self.truth is not None and not (
            isinstance(self.truth, str | Path) and Path(self.truth).is_dir()
        ):
            out.append(
                f"truth: expected the directory of the simulated trial whose controller made "
                f"this walk, found {self.truth!r}"
            )
        levels = self.noise_levels
        if not (
            isinstance(levels, tuple)
            and all(
                isinstance(pair, tuple)
                and len(pair) == 2
                and pair[0] in NOISE_LEVEL_NAMES
                and _number(pair[1])
                and 0 < pair[1] < float("inf")
                for pair in levels
            )
        ):
            out.append(
                f"noise_levels: expected (name, value > 0) pairs with names from "
                f"{list(NOISE_LEVEL_NAMES)}, found {levels!r}"
            )
        if not isinstance(self.fit_places, bool):
            out.append(f"fit_places: expected True or False, found {self.fit_places!r}")
        elif self.fit_places and (self.method != "smoother" or self.smooth_from == "angles"):
            out.append(
                "fit_places: estimates the markers' places in the smoother that tracks them "
                f"(method 'smoother', smooth_from 'auto' or 'markers'), found method "
                f"{self.method!r}, smooth_from {self.smooth_from!r}"
            )
        noise = self.process_noise
        if noise is not None and self.method != "closed-loop":
            out.append(
                f"process_noise: an option of method 'closed-loop' (the smoother's torques are "
                f"free already), found method {self.method!r}"
            )
        if noise is not None and not (
            isinstance(noise, tuple)
            and len(noise) == 2
            and all(_number(v) and 0 < v < float("inf") for v in noise)
        ):
            out.append(
                "process_noise: expected None or (joint, trunk) standard deviations > 0, "
                f"found {noise!r}"
            )
        return out

    def validate(self) -> None:
        """Raise ``ValueError`` listing every problem of :meth:`problems`."""
        found = self.problems()
        if found:
            raise ValueError("gait identification settings: " + "; ".join(found))

    def to_dict(self) -> dict[str, Any]:
        """Plain values (paths as strings, tuples as lists), for JSON and the run id."""
        out = asdict(self)
        out["trial"] = str(self.trial)
        out["truth"] = None if self.truth is None else str(self.truth)
        out["track"] = list(self.track)
        out["instrument_lags"] = list(self.instrument_lags)
        out["noise_levels"] = dict(self.noise_levels)
        if self.process_noise is not None:
            out["process_noise"] = list(self.process_noise)
        return out


def _number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and value == value


def _integer(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)
