"""What determines a pendulum identification run, checked before any work starts.

Kept apart from the workflow (:mod:`colloc.identify.pendulum.workflow`) so that the command line can
show its defaults without importing SymPy, CasADi or SciPy.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from colloc.identify.guesses import GAIN_GUESSES

#: The standard-error methods of :func:`colloc.parameter_uncertainty`, honest one first.
UNCERTAINTY_METHODS = ("sandwich", "autoregressive", "kkt")

SCHEME_NAMES = ("midpoint", "backward-euler", "trapezoidal", "hermite-simpson")
"""Command-line names of the collocation schemes, in the order ``--help`` lists them."""

#: Kane's derivation of the n-link cart pendulum took 40 s at n = 32 and grows as n^2.9
#: (measured 2026-11-23: 0.9 s at 8, 5.7 s at 16, 17 s at 24, 40 s at 32 links).
DERIVE_SECONDS_AT_32, DERIVE_EXPONENT = 40.0, 2.9
#: Simulation, build and solve took about 1 s for the 1-link, 60 s at 100 Hz run (6001 nodes,
#: 4 states, 4 gains), and grow with the KKT factor's entries (see ``estimated_needs``).
SECONDS_PER_FACTOR_ENTRY = 1.0 / (6001 * 4 * (2 * 4 + 4))
#: A run longer than this (estimated) is announced as one that will take a while.
LONG_RUN_SECONDS = 60.0
#: Cart force amplitudes above this make the simulation crawl (1e300 N never ended).
MAX_FORCE_AMPLITUDE = 1e6
#: Largest angle noise [deg] accepted: a quarter turn, the spread of the links' own motion
#: under the default excitation (34-52 degrees on 1 and 2 links); --noise-std 1e6 iterated
#: without end.
MAX_NOISE_STD_DEG = 90.0


@dataclass(frozen=True)
class PendulumSettings:
    """Everything that determines a pendulum identification run.

    Attributes
    ----------
    num_links : int
    duration : float
        Seconds of simulated data.
    sample_rate : float
        Hz; the collocation grid is the sample grid.
    initial_guess : str
        One of :data:`colloc.identify.guesses.GAIN_GUESSES`.
    sensor_noise : bool
    noise_std_deg : float
        Standard deviation of the angle noise in degrees.
    cart_noise_std : float
        Standard deviation of the cart-position noise in metres (the arc length of
        ``noise_std_deg`` on a 1 m link by default).
    force_amplitude : float
        Amplitude of each of the 12 sines of the cart force, N.
    scheme : str
        One of :data:`SCHEME_NAMES` (the workflow maps each to its scheme class).
    hessian : str
        "exact" or "limited-memory".
    seed : int
    smoothing_window : float
        Seconds; Savitzky-Golay window for the state guess and direct identification.
    check_true_gains : bool
        Also solve with the gains fixed at the truth, to compare objectives.
    process_noise : float
        Standard deviation (N m) of white motor noise added to every joint torque in the
        simulation, drawn per sample and linear between samples; 0: none.
    input_noise : float
        Standard deviation (N) of the noise on the measured cart force; 0: the force is
        known exactly.
    noise_model : bool
        True: identify with the simulated noise modelled, a disturbance torque per joint
        penalised by ``process_noise`` and the cart force a measured input tracked with
        ``input_noise`` (the maximum a posteriori fit, its gains then moved to the Laplace
        marginal likelihood's optimum by :func:`colloc.marginal_correction`). False
        (default): exact dynamics and the measured force taken as exact, the output-error
        fit, which stays unbiased under motor noise independent of the cart force; with
        sandwich errors it is the honest default. Measured by
        ``benchmarks/uncertainty_calibration.py`` (50 realisations, 2 links, motor noise):
        the joint MAP gains were biased by 9.7 % (81 % on one gain), the corrected ones by
        1.8 %, the output-error fit's by 1.1 %; 99.8 % of the corrected gains within 3 SE,
        their spread about half the output-error fit's (``docs/process-noise.md``).
    uncertainty : str
        ``"sandwich"`` (robust over time blocks, the default, calibrated on this study),
        ``"autoregressive"`` (robust, the residuals' covariance from an autoregression) or
        ``"kkt"`` standard errors (see :func:`colloc.parameter_uncertainty`).
    """

    num_links: int = 1
    duration: float = 60.0
    sample_rate: float = 100.0
    initial_guess: str = "close"
    sensor_noise: bool = False
    noise_std_deg: float = 0.25
    cart_noise_std: float = float(np.deg2rad(0.25))
    force_amplitude: float = 10.0
    scheme: str = "midpoint"
    hessian: str = "exact"
    seed: int = 0
    smoothing_window: float = 0.15
    check_true_gains: bool = False
    process_noise: float = 0.0
    input_noise: float = 0.0
    noise_model: bool = False
    uncertainty: str = "sandwich"

    @property
    def num_nodes(self) -> int:
        """Samples in the record (also the collocation nodes)."""
        return int(np.floor(self.duration * self.sample_rate + 1e-9)) + 1

    def problems(self) -> list[str]:
        """Every problem with these settings (empty when they are usable)."""
        out = []
        if (
            isinstance(self.num_links, bool)
            or not isinstance(self.num_links, int)
            or self.num_links < 1
        ):
            out.append(f"num_links (-n): expected an integer >= 1, found {self.num_links!r}")
        duration_ok = _finite(self.duration) and self.duration > 0
        if not duration_ok:
            out.append(
                f"duration (-d): expected a positive number of seconds, found {self.duration!r}"
            )
        if not (_finite(self.sample_rate) and self.sample_rate > 0):
            out.append(
                f"sample_rate (-s): expected a positive rate in Hz, found {self.sample_rate!r}"
            )
        elif duration_ok and self.num_nodes < 3:
            out.append(
                f"duration (-d) x sample_rate (-s): gives {self.num_nodes} node(s); "
                "expected at least 3"
            )
        elif duration_ok and _finite(self.smoothing_window) and self.smoothing_window >= 0:
            window = max(5, int(round(self.smoothing_window * self.sample_rate)) | 1)
            if window > self.num_nodes:
                out.append(
                    f"duration (-d): {self.duration:g} s at {self.sample_rate:g} Hz gives "
                    f"{self.num_nodes} samples, fewer than the {window} over which the state "
                    f"guess is smoothed ({self.smoothing_window:g} s); expected at least "
                    f"{(window - 1) / self.sample_rate:g} s"
                )
        if self.initial_guess not in GAIN_GUESSES:
            out.append(
                f"initial_guess (-i): expected one of {sorted(GAIN_GUESSES)}, "
                f"found {self.initial_guess!r}"
            )
        if self.scheme not in SCHEME_NAMES:
            out.append(f"scheme: expected one of {sorted(SCHEME_NAMES)}, found {self.scheme!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            out.append(f"seed: expected an integer >= 0, found {self.seed!r}")
        if self.hessian not in ("exact", "limited-memory"):
            out.append(f"hessian: expected 'exact' or 'limited-memory', found {self.hessian!r}")
        if self.uncertainty not in UNCERTAINTY_METHODS:
            out.append(
                f"uncertainty: expected one of {list(UNCERTAINTY_METHODS)}, "
                f"found {self.uncertainty!r}"
            )
        if not isinstance(self.noise_model, bool):
            out.append(f"noise_model: expected True or False, found {self.noise_model!r}")
        names = (
            "noise_std_deg",
            "cart_noise_std",
            "force_amplitude",
            "smoothing_window",
            "process_noise",
            "input_noise",
        )
        for name in names:
            value = getattr(self, name)
            if not (isinstance(value, int | float) and np.isfinite(value) and value >= 0):
                out.append(f"{name}: expected a finite number >= 0, found {value!r}")
        if _finite(self.noise_std_deg) and self.noise_std_deg > MAX_NOISE_STD_DEG:
            out.append(
                f"noise_std_deg (--noise-std): expected at most {MAX_NOISE_STD_DEG:g} degrees "
                f"(a quarter turn; beyond, the noise buries the links' motion and the fit only "
                f"wanders), found {self.noise_std_deg!r}"
            )
        if _finite(self.force_amplitude) and self.force_amplitude > MAX_FORCE_AMPLITUDE:
            out.append(
                f"force_amplitude (--amplitude): expected at most {MAX_FORCE_AMPLITUDE:g} N "
                f"(the simulation crawls beyond), found {self.force_amplitude!r}"
            )
        return out

    def estimated_needs(self) -> dict[str, float]:
        """What the run will need, from its settings alone (before any work).

        Memory: eight bytes times a safety factor of three for each entry of the KKT
        factor, about ``N n_s (2 n_s + n_K)`` for ``N`` nodes, ``n_s`` states and ``n_K``
        gains (each node's block couples its states to its neighbour's and to every
        gain). Derivation time: the measured growth of Kane's method with the number of
        links (:data:`DERIVE_SECONDS_AT_32`, :data:`DERIVE_EXPONENT`).

        Returns
        -------
        dict
            ``nodes``, ``variables``, ``memory_bytes``, ``derive_seconds`` and ``seconds``
            (derivation plus the rest, scaled from the 1-link 60 s run's second by the
            factor's entries: a rough figure, for announcing long runs).
        """
        n = float(self.num_links)
        states = 2.0 * (n + 1.0)
        gains = n * states
        nodes = float(self.duration) * float(self.sample_rate) + 1.0
        entries = nodes * states * (2.0 * states + gains)
        derive = DERIVE_SECONDS_AT_32 * (n / 32.0) ** DERIVE_EXPONENT
        return {
            "nodes": nodes,
            "variables": nodes * states + gains,
            "memory_bytes": 3.0 * 8.0 * entries,
            "derive_seconds": derive,
            "seconds": derive + SECONDS_PER_FACTOR_ENTRY * entries,
        }

    def too_big(self, memory_bytes: float) -> list[str]:
        """Problems for a run that cannot fit in ``memory_bytes`` (e.g. the machine's RAM).

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
            f"num_links (-n) {self.num_links}, duration (-d) {self.duration:g} s at "
            f"{self.sample_rate:g} Hz (-s): {needs['nodes']:.3g} nodes and "
            f"{needs['variables']:.3g} unknowns need an estimated "
            f"{needs['memory_bytes'] / 2**30:.3g} GiB, more than the {memory_bytes / 2**30:.3g} "
            "GiB available; use fewer links, a shorter record or a lower rate"
        ]

    def validate(self) -> None:
        """Raise ``ValueError`` listing every problem (before any work starts)."""
        found = self.problems()
        if found:
            raise ValueError("invalid pendulum settings:\n" + "\n".join(f"  - {p}" for p in found))

    def to_dict(self) -> dict[str, Any]:
        """Plain settings for records and run ids."""
        return asdict(self)


def _finite(value: object) -> bool:
    return isinstance(value, int | float) and bool(np.isfinite(value))
