"""The gait phase a trial's controller is scheduled on, read once per identification.

``--phase`` names the law (:data:`colloc.identify.gait.settings.PHASES`): ``causal``, reset at
each right heel strike and running at the controller's own rate (what a real-time controller
can know; the default), ``heel-strikes``, linear between the strikes, or ``controller``, the
trial's recorded ``controller_phase`` column. :func:`phase_law` makes the law of a trial
once, with its parameters; each stage reads the phase from it at its own times.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar, TypeGuard

import numpy as np

from colloc.data.phase import causal_gait_phase, unwrapped_gait_phase


class PhaseLaw:
    """How a trial's gait phase is read: at its samples, between them, and as the clock of
    a forward walk (its stride and the phase at a heel strike)."""

    name: ClassVar[str]

    def at(self, t: np.ndarray, signals: Any) -> np.ndarray:
        """Unwrapped phase in cycles at times ``t`` (``signals``: the trial's rows at ``t``)."""
        raise NotImplementedError

    def between(self, t: np.ndarray, times: np.ndarray, phase: np.ndarray) -> np.ndarray:
        """The phase at times ``t`` that fall between the samples ``times`` whose phase is
        ``phase`` (the collocation's interval midpoints). By default the law at ``t``."""
        return self.at(t, None)

    def walk_clock(self, fit: Any) -> tuple[float, float]:
        """``(stride [s], phase at a right heel strike)`` for a forward walk under the law,
        read from the fit part ``fit`` (a :class:`colloc.data.Trial`)."""
        raise NotImplementedError

    def note(self) -> str | None:
        """What the identification says of the law, if anything."""
        return None


@dataclass(frozen=True)
class CausalPhase(PhaseLaw):
    """Reset to ``phase_at_strike`` at each right heel strike, one cycle per ``stride``.

    Attributes
    ----------
    strikes : ndarray
        The trial's right heel strikes [s].
    stride : float
        [s]
    phase_at_strike : float
        In cycles, in [0, 1).
    source : str
        Where ``stride`` came from.
    """

    name: ClassVar[str] = "causal"
    strikes: np.ndarray
    stride: float
    phase_at_strike: float
    source: str

    def at(self, t: np.ndarray, signals: Any) -> np.ndarray:
        """The causal phase (:func:`colloc.data.causal_gait_phase`)."""
        return causal_gait_phase(t, self.strikes, self.stride, self.phase_at_strike)

    def walk_clock(self, fit: Any) -> tuple[float, float]:
        """The law's own stride and phase at a strike."""
        return self.stride, self.phase_at_strike

    def note(self) -> str:
        """The reset, the rate and their source."""
        return (
            f"phase: causal, reset to {self.phase_at_strike:.4g} at each right heel strike, one "
            f"cycle per {self.stride:.4g} s ({self.source})"
        )


@dataclass(frozen=True)
class HeelStrikePhase(PhaseLaw):
    """Linear from one right heel strike to the next (:func:`colloc.data.unwrapped_gait_phase`).

    Attributes
    ----------
    strikes : ndarray
        The trial's right heel strikes [s].
    """

    name: ClassVar[str] = "heel-strikes"
    strikes: np.ndarray

    def at(self, t: np.ndarray, signals: Any) -> np.ndarray:
        """Linear between the strikes (NaN outside them)."""
        return unwrapped_gait_phase(t, self.strikes)

    def walk_clock(self, fit: Any) -> tuple[float, float]:
        """The fit part's median stride, the phase 0 at a strike."""
        return float(np.median(np.diff(fit.right_heel_strikes))), 0.0


@dataclass(frozen=True)
class ControllerPhase(PhaseLaw):
    """The trial's recorded ``controller_phase`` column."""

    name: ClassVar[str] = "controller"

    def at(self, t: np.ndarray, signals: Any) -> np.ndarray:
        """The column at the rows ``signals``."""
        return signals["controller_phase"].to_numpy(dtype=float)

    def between(self, t: np.ndarray, times: np.ndarray, phase: np.ndarray) -> np.ndarray:
        """The column interpolated (it exists at the samples only)."""
        return np.interp(t, times, phase)

    def walk_clock(self, fit: Any) -> tuple[float, float]:
        """The column's median rate, and its median value at the strikes as the rate
        carries it from each strike to the next sample."""
        column = fit.signals["controller_phase"].to_numpy(dtype=float)
        steps = np.diff(column)
        rate = float(np.median(steps[steps > 0]) / np.median(np.diff(fit.time)))
        after = np.searchsorted(fit.time, fit.right_heel_strikes[1:])
        after = after[after < fit.time.size]
        phi0 = np.mod(
            column[after] - (fit.time[after] - fit.right_heel_strikes[1 : 1 + after.size]) * rate,
            1.0,
        )
        return 1.0 / rate, float(np.median(phi0))


def _causal(trial: Any) -> PhaseLaw:
    strikes = trial.right_heel_strikes
    stride, phi0, source = causal_phase_parameters(trial.metadata, strikes)
    return CausalPhase(strikes, stride, phi0, source)


#: ``--phase`` -> the law of a trial.
PHASE_LAWS: dict[str, Callable[[Any], PhaseLaw]] = {
    CausalPhase.name: _causal,
    HeelStrikePhase.name: lambda trial: HeelStrikePhase(trial.right_heel_strikes),
    ControllerPhase.name: lambda trial: ControllerPhase(),
}


def phase_law(convention: str, trial: Any) -> PhaseLaw:
    """The phase law ``convention`` of ``trial`` (its strikes and metadata).

    Parameters
    ----------
    convention : str
        One of :data:`PHASE_LAWS`.
    trial : Trial

    Returns
    -------
    PhaseLaw

    Raises
    ------
    ValueError
        For another convention.
    """
    if convention not in PHASE_LAWS:
        raise ValueError(f"phase: expected one of {list(PHASE_LAWS)}, found {convention!r}")
    return PHASE_LAWS[convention](trial)


def gait_phase(convention: str, trial: Any, t: np.ndarray, signals: Any) -> np.ndarray:
    """Unwrapped phase in cycles at times ``t`` under the law ``convention`` of ``trial``
    (:func:`phase_law`; ``signals``, its rows at ``t``, for the ``controller`` law)."""
    return phase_law(convention, trial).at(t, signals)


def causal_phase_parameters(
    metadata: dict[str, Any], strikes: np.ndarray
) -> tuple[float, float, str]:
    """``D``, ``phi_0`` and where they came from, for :func:`colloc.data.causal_gait_phase`.

    A synthetic trial records its controller's (``controller.stride_duration``,
    ``controller.phase_at_strike``); otherwise ``D`` is the designed cycle's duration
    (``cycle.duration``) or the median stride, and ``phi_0`` is 0 (the schedule starts at the
    heel strike).

    Parameters
    ----------
    metadata : dict
        The trial's metadata.
    strikes : ndarray
        Right heel-strike times.

    Returns
    -------
    stride_duration : float
    phase_at_strike : float
    source : str
    """
    controller = metadata.get("controller") if isinstance(metadata, dict) else None
    controller = controller if isinstance(controller, dict) else {}
    cycle = metadata.get("cycle") if isinstance(metadata, dict) else None
    cycle = cycle if isinstance(cycle, dict) else {}
    recorded, designed = controller.get("stride_duration"), cycle.get("duration")
    if _positive(recorded):
        stride, source = float(recorded), "the trial's controller"
    elif _positive(designed):
        stride, source = float(designed), "the trial's designed cycle"
    else:
        stride, source = float(np.median(np.diff(strikes))), "the median stride"
    given = controller.get("phase_at_strike")
    phi0 = float(given) if isinstance(given, int | float) and 0 <= given < 1 else 0.0
    return stride, phi0, source


def _positive(value: object) -> TypeGuard[float]:
    return isinstance(value, int | float) and not isinstance(value, bool) and 0 < value < np.inf
