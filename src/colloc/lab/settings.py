"""How a lab record becomes a trial: the settings of :func:`colloc.lab.trial_from_lab`."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from colloc.data.filtering import DEFAULT_CUTOFF_HZ
from colloc.gait.strikes import HEEL_STRIKE_THRESHOLD
from colloc.lab.gaps import DEFAULT_MAX_GAP
from colloc.lab.markers import MarkerSet

#: Longest gap [s] a spline may fill: about a stride's swing phase.
MAX_GAP_LIMIT = 1.0

#: Lowest accepted filter cut-off [Hz].
MIN_CUTOFF_HZ = 1.0


@dataclass(frozen=True)
class LabSettings:
    """How a lab record becomes a trial.

    Attributes
    ----------
    body_mass : float
        [kg], scales the segments and is recorded in the trial.
    height : float
        [m], scales the segments' lengths and inertias.
    belt_speed : float or str
        The treadmill's belt speed: a constant [m/s] (0 overground), or the name of a column
        of the exports that holds it.
    cutoff_hz : float
        The zero-lag filter's -3 dB frequency [Hz].
    max_gap : float
        Longest marker gap filled [s].
    strike_threshold : float
        Vertical force [N] whose upward crossing is a heel strike: by default the detector of
        colloc's simulated trials (:data:`colloc.gait.strikes.HEEL_STRIKE_THRESHOLD`), so that
        lab and synthetic trials put the gait phase's zero at the same instant. (The centre of
        pressure is NaN below :data:`colloc.gait.strikes.UNLOADED_FORCE`.)
    marker_set : MarkerSet
        The exports' names of markers and plates.
    zeros_are_missing : bool
        Marker samples with every coordinate exactly 0 are missing.
    """

    body_mass: float
    height: float
    belt_speed: float | str
    cutoff_hz: float = DEFAULT_CUTOFF_HZ
    max_gap: float = DEFAULT_MAX_GAP
    strike_threshold: float = HEEL_STRIKE_THRESHOLD
    marker_set: MarkerSet = field(default_factory=MarkerSet)
    zeros_are_missing: bool = True

    def problems(self) -> list[str]:
        """Every invalid setting, named (empty when the settings can be used)."""
        out = []
        checks = {
            "body_mass": (self.body_mass, 20.0, 300.0, "kg"),
            "height": (self.height, 0.5, 2.5, "m"),
            # below about 1 Hz a filter removes the stride itself (0.9 Hz at 1.1 s a stride)
            "cutoff_hz": (self.cutoff_hz, MIN_CUTOFF_HZ, math.inf, "Hz"),
            "strike_threshold": (self.strike_threshold, 0.0, math.inf, "N"),
        }
        for name, (value, low, high, unit) in checks.items():
            if not (_real(value) and low < value < high):
                out.append(
                    f"{name}: expected a number of {unit} in ({low:g}, {high:g}), found {value!r}"
                )
        if not (_real(self.max_gap) and 0 <= self.max_gap <= MAX_GAP_LIMIT):
            out.append(
                f"max_gap: expected seconds from 0 to {MAX_GAP_LIMIT:g} (a spline across a "
                f"longer gap invents a step), found {self.max_gap!r}"
            )
        speed = self.belt_speed
        if _real(speed) and math.isfinite(float(speed)) and float(speed) < 0:
            out.append(
                f"belt_speed: expected a speed >= 0 m/s (the belt's surface runs backward under "
                f"a walker facing forward; 0 overground), found {speed!r}"
            )
        elif not (isinstance(speed, str) and speed) and not (
            _real(speed) and math.isfinite(float(speed))
        ):
            out.append(
                f"belt_speed: expected a speed in m/s (0 overground) or the name of a column, "
                f"found {speed!r}"
            )
        if not isinstance(self.marker_set, MarkerSet):
            out.append(f"marker_set: expected a MarkerSet, found {type(self.marker_set).__name__}")
        return out


def _real(value: Any) -> bool:
    return isinstance(value, int | float | np.number) and not isinstance(value, bool)


def check_settings(settings: Any) -> None:
    """A TypeError when ``settings`` is not a :class:`LabSettings` (a dict, None, ...).

    Parameters
    ----------
    settings : object

    Raises
    ------
    TypeError
    """
    if not isinstance(settings, LabSettings):
        raise TypeError(
            f"settings: expected LabSettings(body_mass, height, belt_speed=...), found "
            f"{type(settings).__name__}"
        )
