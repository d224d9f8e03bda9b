"""Heel strikes as the online detector of the closed-loop simulation sees them.

A heel strike is an upward crossing of a force threshold by a foot's total vertical floor
force, interpolated linearly between two samples, made by the heel: the crossing counts once
the heel carries at least :data:`HEEL_SHARE` of the foot's force, before the foot unloads
again (:class:`StrikeDetector`). :func:`strike_phase` is where that detector fires on a
designed cycle, the phase to which the simulated controller resets.

Why the heel's share: the collocation cycles' swing toe grazes the belt where it passes the
stance foot (40-50 N at 82-86 % of the stride at 1.3 m/s), and under 3 N m of motor noise such
a graze passed the threshold in 6 of 357 strides (up to 108 N). Counted as a strike, one reset
the controller's phase at 84 % of the stride, and the walk fell 1.6 s later (at 409 s) with
its push-off torque spinning a foot that had left the belt. A heel switch alone would not do:
in stance the foot rocks, its heel leaving the belt and striking it again mid-stance while
the toe carries the load. At a real heel strike the toe is in the air, so the strikes are the
whole foot's crossings, to the sample (a force plate, which has only the foot's force, gives
the same strikes: :mod:`colloc.lab`). A foot that lands flat or on its toe is a strike as
soon as its force reaches :data:`LANDING_FORCE`, which no graze does.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np


def vertical_foot_forces(contact_forces: np.ndarray) -> np.ndarray:
    """Total vertical floor force on each foot (heel plus toe).

    Parameters
    ----------
    contact_forces : ndarray, shape (N, 8)
        ``Fx, Fy`` on the right heel, right toe, left heel, left toe [N].

    Returns
    -------
    ndarray, shape (N, 2)
        Right and left foot [N].
    """
    fy = np.asarray(contact_forces, dtype=float)[:, 1::2]
    return np.column_stack([fy[:, 0] + fy[:, 1], fy[:, 2] + fy[:, 3]])


#: Vertical force [N] below which a foot counts as unloaded and its centre of pressure is
#: undefined (NaN), as a force plate's software leaves it below a few tens of newtons.
UNLOADED_FORCE = 20.0


def foot_ground_reactions(
    contact_forces: np.ndarray, contact_x: np.ndarray, unloaded: float = UNLOADED_FORCE
) -> np.ndarray:
    """Each foot's ground reaction as a force plate under it reports it.

    Parameters
    ----------
    contact_forces : ndarray, shape (N, 8)
        ``Fx, Fy`` on the right heel, right toe, left heel, left toe [N].
    contact_x : ndarray, shape (N, 4)
        Forward positions of the same four points [m].
    unloaded : float
        Vertical force [N] below which the centre of pressure is NaN.

    Returns
    -------
    ndarray, shape (N, 6)
        Right ``Fx, Fy, CoP x``, then left, in the order of
        :data:`colloc.data.columns.GRF_COLUMNS`.
    """
    f = np.asarray(contact_forces, dtype=float)
    x = np.asarray(contact_x, dtype=float)
    out = []
    for heel, toe in ((0, 1), (2, 3)):
        fx = f[:, 2 * heel] + f[:, 2 * toe]
        fy = f[:, 2 * heel + 1] + f[:, 2 * toe + 1]
        moment = x[:, heel] * f[:, 2 * heel + 1] + x[:, toe] * f[:, 2 * toe + 1]
        loaded = fy >= unloaded
        cop = np.full(fy.shape, np.nan)
        cop[loaded] = moment[loaded] / fy[loaded]
        out += [fx, fy, cop]
    return np.column_stack(out)


#: A foot's vertical force [N] whose upward crossing is a heel strike. Well above the
#: 20-50 N with which a swing foot of the collocation cycles grazes the belt, which a
#: lower threshold took for a heel strike (resetting the phase mid-swing).
HEEL_STRIKE_THRESHOLD = 100.0
#: Minimum time between heel strikes of one foot [s] (rejects contact chatter).
MIN_STRIDE_INTERVAL = 0.4
#: Share of a foot's vertical force its heel must carry for a threshold crossing to be a heel
#: strike (a toe grazing the belt in swing carries it all on the toe).
HEEL_SHARE = 0.5
#: A foot's vertical force [N] that makes a pending crossing a strike whatever the heel
#: carries: a foot landing flat or toe first after the belt slowed (0.8 m/s walks, the belt at
#: 0.48 m/s, fell at 291 s waiting for the heel), far above a graze (at most 127 N measured:
#: 108 N at 1.3 m/s and 3 N m, 127 N at 0.8 m/s and 5 N m).
LANDING_FORCE = 300.0


@dataclass
class StrikeDetector:
    """The online heel-strike detector of one foot, fed one sample at a time.

    An upward crossing of ``threshold`` by the foot's vertical force is held until the heel
    carries :data:`HEEL_SHARE` of that force or the force reaches :data:`LANDING_FORCE`, and
    then reported at the crossing's time; if the force falls below ``threshold`` first (a toe
    grazing the belt), it is dropped.

    Attributes
    ----------
    threshold : float
        [N].
    pending : float or None
        Time of a crossing waiting for the heel.
    """

    threshold: float = HEEL_STRIKE_THRESHOLD
    pending: float | None = None

    def update(self, t0: float, t1: float, f0: float, f1: float, heel1: float) -> float | None:
        """Feed the sample at ``t1``; return the heel strike's time if it is now known.

        Parameters
        ----------
        t0, t1 : float
            The previous and this sample's time [s].
        f0, f1 : float
            The foot's vertical force at them [N].
        heel1 : float
            The heel's vertical force at ``t1`` [N].

        Returns
        -------
        float or None
        """
        if f1 < self.threshold:
            self.pending = None
            return None
        crossing = threshold_crossing(t0, t1, f0, f1, self.threshold)
        if crossing is not None:
            self.pending = crossing
        if self.pending is not None and (heel1 >= HEEL_SHARE * f1 or f1 >= LANDING_FORCE):
            strike, self.pending = self.pending, None
            return strike
        return None


def strike_phase(cycle: Any, threshold: float = HEEL_STRIKE_THRESHOLD) -> float:
    """Phase at which the online detector finds the right heel strike on the cycle itself.

    The first heel strike of the right foot (:class:`StrikeDetector`) over the cycle's nodes,
    interpolated linearly, as a fraction of the stride; 0 if the force never crosses the
    threshold (e.g. standing).

    Parameters
    ----------
    cycle : WalkingCycle
    threshold : float
        [N], as given to :func:`simulate_walking`.

    Returns
    -------
    float
        In ``[0, 1)``.
    """
    t = np.asarray(cycle.times, float)
    fy = np.asarray(cycle.vertical_grf, float)[:, 0]
    heel = np.asarray(cycle.contact_forces, float)[:, 1]
    detector = StrikeDetector(threshold)
    for k in range(1, t.size):
        strike = detector.update(t[k - 1], t[k], fy[k - 1], fy[k], heel[k])
        if strike is not None:
            return float((strike - t[0]) / cycle.duration % 1.0)
    return 0.0


def threshold_crossing(
    t0: float, t1: float, f0: float, f1: float, threshold: float
) -> float | None:
    """Time at which ``f`` rises through ``threshold`` between two samples, or None.

    Parameters
    ----------
    t0, t1 : float
        Sample times.
    f0, f1 : float
        Values at them.
    threshold : float

    Returns
    -------
    float or None
        Linear interpolation of the crossing if ``f0 < threshold <= f1``.
    """
    if f0 < threshold <= f1:
        return t0 + (threshold - f0) / (f1 - f0) * (t1 - t0)
    return None


__all__ = [
    "HEEL_SHARE",
    "HEEL_STRIKE_THRESHOLD",
    "LANDING_FORCE",
    "MIN_STRIDE_INTERVAL",
    "StrikeDetector",
    "strike_phase",
    "threshold_crossing",
    "vertical_foot_forces",
]
