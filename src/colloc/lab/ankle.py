"""The ankle joint's height above the sole, as a lab record shows it (gait2d's ``h_ankle``).

gait2d scales the ankle's height from the subject's height (0.039 of it); the record says
where the subject's sole meets the floor: while a foot carries most of the body weight, its
malleolus stands at the ankle's height less the contact model's sinking under that load.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from colloc.data.columns import SIDES, TIME_COLUMN

#: Share of the body weight above which a foot counts as loaded for the ankle's height.
LOADED_SHARE = 0.8


def ankle_height(
    markers: pd.DataFrame,
    plates: pd.DataFrame,
    segments: Mapping[str, str],
    body_mass: float,
    stiffness: float,
    gravity: float = 9.81,
) -> float | None:
    """The ankle's height above the sole that the record shows: on each sample where a foot
    carries more than :data:`LOADED_SHARE` of the body weight, the height of its shank's
    lowest marker (the malleolus) plus the contact model's sinking under that load (heel
    and toe sharing it: ``(F / 2k)^(1/3)`` with the cubic stiffness ``k``); the lower
    quartile over both feet (the foot flat, its ankle lowest; heel or toe alone lift it).
    On a simulated walk's export 0.0697 m against the model's 0.0703 m; on OpenSim's example
    walk 0.124-0.128 m against the 0.070 m gait2d scales from the height.

    Parameters
    ----------
    markers : DataFrame
        ``time``, ``<marker>_x``, ``<marker>_y`` [m] (heights above the floor).
    plates : DataFrame
        ``time`` and ``<side>_force_y`` [N].
    segments : mapping
        Marker name -> its segment (``<side>_shank`` for the malleoli).
    body_mass : float
        [kg]
    stiffness : float
        The contact model's cubic stiffness [N/m^3].
    gravity : float
        [m/s^2]

    Returns
    -------
    float or None
        None when no sample is loaded enough or no shank marker was seen.
    """
    stamp = markers[TIME_COLUMN].to_numpy(dtype=float)
    estimates = []
    for side in SIDES:
        names = [n for n, seg in segments.items() if seg == f"{side}_shank"]
        if not names:
            continue
        heights = {n: markers[f"{n}_y"].to_numpy(dtype=float) for n in names}
        lowest = min(names, key=lambda n: float(np.nanmean(heights[n])))
        force = np.interp(stamp, plates[TIME_COLUMN], plates[f"{side}_force_y"])
        loaded = (force > LOADED_SHARE * body_mass * gravity) & np.isfinite(heights[lowest])
        estimates.append(heights[lowest][loaded] + np.cbrt(force[loaded] / (2.0 * stiffness)))
    found = np.concatenate(estimates) if estimates else np.empty(0)
    return float(np.percentile(found, 25)) if found.size else None
