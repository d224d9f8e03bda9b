"""What a lab record says about itself, checked before it becomes a trial.

A mislabelled or damaged record can pass every format check and still describe no walk: the
markers upside down, a marker jumping a metre for one frame, a filter at the Nyquist frequency,
a belt speed the feet contradict, a strike threshold no step reaches. Each check here reads the
evidence the record carries (gravity's direction, marker speeds no body reaches, the feet's
speed in stance, the plates' peaks) and names the cause, or repairs what a lab would repair
(a single-frame spike) and says so.
"""

from __future__ import annotations

import numpy as np

from colloc.data.filtering import design_cutoff
from colloc.lab.exports import LabExport
from colloc.lab.markers import MarkerSet

#: Marker speed [m/s] no part of a walking body reaches (a foot in swing: about 6).
MAX_MARKER_SPEED = 25.0

#: Highest cut-off as a fraction of the sample rate: the two passes' design frequency must
#: stay clear of the Nyquist frequency.
MAX_CUTOFF_FRACTION = 0.4

#: Vertical force [N] above which a foot is in stance, for the feet's speed on the belt.
STANCE_FORCE = 200.0

#: How far [m/s] the feet's median speed in stance may lie from the stated belt speed.
BELT_TOLERANCE = 0.25


def spikes(markers: dict[str, np.ndarray], rate: float) -> dict[str, np.ndarray]:
    """Samples of each marker that jump away and back at a speed no body reaches.

    A sample is a spike when it is reached from the previous sample and left for the next
    faster than :data:`MAX_MARKER_SPEED`, while its neighbours are close to each other: a
    single-frame glitch (a marker relabelled for a frame, a reflection). Longer excursions are
    not spikes; the swapped-marker check names them.

    Parameters
    ----------
    markers : dict
        Name -> (N, 2) [m].
    rate : float
        [Hz].

    Returns
    -------
    dict
        Name -> indices of spikes (only markers with some).
    """
    found = {}
    limit = MAX_MARKER_SPEED / rate
    for name, xy in markers.items():
        # hypot, not a norm of squares: a glitch of 1e300 m is a spike, not an overflow
        before = np.hypot(*(xy[1:-1] - xy[:-2]).T)
        after = np.hypot(*(xy[2:] - xy[1:-1]).T)
        across = np.hypot(*(xy[2:] - xy[:-2]).T)
        jump = (before > limit) & (after > limit) & (across < limit)
        if jump.any():
            found[name] = np.flatnonzero(jump) + 1
    return found


def cutoff_problems(cutoff_hz: float, rate: float, what: str) -> list[str]:
    """A cut-off too close to the Nyquist frequency of ``what``'s rate."""
    if cutoff_hz < MAX_CUTOFF_FRACTION * rate and np.isfinite(design_cutoff(cutoff_hz, rate)):
        return []
    return [
        f"cutoff_hz: {cutoff_hz:g} Hz is at or near the Nyquist frequency of the {what} "
        f"({rate:g} Hz sampled, {rate / 2:g} Hz Nyquist); expected below "
        f"{MAX_CUTOFF_FRACTION * rate:g} Hz (walking: 6 Hz)"
    ]


def gravity_problems(markers: LabExport, plates: LabExport, ms: MarkerSet) -> list[str]:
    """Up must be up: shoulders above hips above ankles, and the plates pushing upward."""
    problems = []
    heights = {
        landmark: np.nanmedian(
            np.concatenate([markers.markers[ms.marker(s, landmark)][:, 1] for s in ms.prefixes])
        )
        for landmark in ("shoulder", "hip", "ankle")
    }
    if not heights["shoulder"] > heights["hip"] > heights["ankle"]:
        problems.append(
            f"markers: the shoulders ({heights['shoulder']:.3f}), hips ({heights['hip']:.3f}) and "
            f"ankles ({heights['ankle']:.3f}) are not one above the other along Y: the vertical "
            "axis is not Y up (negated, or another axis)"
        )
    vertical = np.concatenate([channels[:, 1] for channels in plates.plates.values()])
    loaded = vertical[np.abs(vertical) > STANCE_FORCE]
    if loaded.size and np.median(loaded) < 0:
        problems.append(
            "plates: the vertical forces are negative in stance: the plates report the foot's "
            "force on them, or Y points down; colloc reads the ground's force on the foot (up)"
        )
    return problems


def belt_problems(
    heel: dict[str, np.ndarray], load: dict[str, np.ndarray], rate: float, belt: np.ndarray
) -> list[str]:
    """The belt speed stated against the feet's speed while they stand on it.

    Parameters
    ----------
    heel : dict
        Side -> filtered heel marker (N, 2) [m].
    load : dict
        Side -> filtered vertical force (N,) [N] on the marker times.
    rate : float
        [Hz].
    belt : ndarray, shape (N,)
        The belt speed as given [m/s].

    Returns
    -------
    list of str
    """
    speeds = []
    for side, xy in heel.items():
        forward = np.gradient(xy[:, 0]) * rate
        stance = load[side] > STANCE_FORCE
        speeds.append(-forward[stance])
    stance_speed = np.concatenate(speeds)
    if stance_speed.size < 10:
        return []
    feet = float(np.median(stance_speed))
    stated = float(np.median(belt))
    if abs(feet - stated) <= max(BELT_TOLERANCE, BELT_TOLERANCE * abs(stated)):
        return []
    return [
        f"belt_speed: {stated:g} m/s given, but the heels move backward at {feet:.2f} m/s "
        "(median) while their feet stand on the plates; the belt carries a standing foot at "
        "its own speed (0 overground)"
    ]


def threshold_problems(threshold: float, load: dict[str, np.ndarray]) -> list[str]:
    """A heel-strike threshold above what any step of a side reaches."""
    out = []
    for side, force in load.items():
        peak = float(np.nanmax(force)) if force.size else 0.0
        if threshold >= peak:
            out.append(
                f"strike_threshold: {threshold:g} N, but the {side} foot's plate peaks at "
                f"{peak:.0f} N: no heel strike can be found; expected a force a step passes "
                "(default 100 N)"
            )
    return out
