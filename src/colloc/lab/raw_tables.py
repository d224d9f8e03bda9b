"""The lab's measurements as they were recorded, kept in the trial for the marker smoother.

:func:`colloc.lab.pipeline.process_lab` makes the trial's signals through a filter, inverse
kinematics and inverse dynamics. The smoother that tracks markers and plates
(:class:`colloc.identify.gait.markers.MarkerModel`) needs what came before those steps: each
landmark's sagittal position, unfiltered and with its gaps left as gaps, at the marker rate,
and each foot's plate at the plate rate. Each marker is assigned to the gait2d segment it
moves with (:data:`LANDMARK_SEGMENTS`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from colloc.data.columns import SIDES, TIME_COLUMN
from colloc.data.tables import PLATE_COLUMNS
from colloc.lab.exports import LabExport
from colloc.lab.markers import LANDMARKS, MarkerSet
from colloc.lab.noise import off_plate_noise

#: The gait2d segment each landmark moves with (without the side): the hip joint centre is
#: the trunk's origin, the lateral epicondyle sits on the femur, the malleolus on the shank.
LANDMARK_SEGMENTS: dict[str, str] = {
    "shoulder": "trunk",
    "hip": "trunk",
    "knee": "thigh",
    "ankle": "shank",
    "heel": "foot",
    "toe": "foot",
}


def marker_table(
    time: np.ndarray, markers: dict[str, np.ndarray], ms: MarkerSet
) -> tuple[pd.DataFrame, dict[str, str]]:
    """The landmarks' raw positions and the segment each one moves with.

    Parameters
    ----------
    time : ndarray, shape (N,)
        The trial's times (the markers' own).
    markers : dict
        Marker name -> (N, 2) sagittal positions [m], NaN where not seen.
    ms : MarkerSet

    Returns
    -------
    table : DataFrame
        ``time``, ``<marker>_x``, ``<marker>_y``.
    segments : dict
        Marker name -> ``<side>_<segment>`` (``trunk`` for the trunk's).
    """
    columns: dict[str, np.ndarray] = {TIME_COLUMN: np.asarray(time, dtype=float)}
    segments = {}
    for side in SIDES:
        for landmark in LANDMARKS:
            name = ms.marker(side, landmark)
            xy = np.asarray(markers[name], dtype=float)
            columns[f"{name}_x"], columns[f"{name}_y"] = xy[:, 0], xy[:, 1]
            segment = LANDMARK_SEGMENTS[landmark]
            segments[name] = segment if segment == "trunk" else f"{side}_{segment}"
    return pd.DataFrame(columns), segments


def plate_table(plates: LabExport, ms: MarkerSet, start: float, stop: float) -> pd.DataFrame:
    """Each foot's plate, unfiltered, at the plate rate, over ``start`` to ``stop`` [s]
    (with half a plate sample either side).

    Parameters
    ----------
    plates : LabExport
        Planar plates (``Fx, Fy, Mz`` with ``Mz / Fy`` the centre of pressure).
    ms : MarkerSet
        Which plate is under which foot.
    start, stop : float

    Returns
    -------
    DataFrame
        ``time`` and :data:`colloc.data.tables.PLATE_COLUMNS`.
    """
    half = 0.5 / plates.sample_rate
    keep = (plates.time >= start - half) & (plates.time <= stop + half)
    values = np.hstack([plates.plates[ms.plates[side]][keep] for side in SIDES])
    return pd.DataFrame(
        np.column_stack([plates.time[keep], values]), columns=[TIME_COLUMN, *PLATE_COLUMNS]
    )


def plate_noise(table: pd.DataFrame) -> dict[str, float]:
    """The plates' noise: force and moment, from the second differences of the samples
    while the foot is off its plate (white noise: variance ``6 sigma^2``), robustly
    (1.4826 times the median absolute deviation). Zero when nothing varies."""
    out = {}
    for quantity, names in (("force", ("force_x", "force_y")), ("moment", ("moment",))):
        out[quantity] = off_plate_noise(
            [
                (
                    table[[f"{side}_{n}" for n in names]].to_numpy(dtype=float),
                    table[f"{side}_force_y"].to_numpy(dtype=float),
                )
                for side in SIDES
            ]
        )
    return out


def raw_records(
    time: np.ndarray,
    markers: dict[str, np.ndarray],
    plates: LabExport,
    ms: MarkerSet,
    marker_std: float,
) -> tuple[dict[str, pd.DataFrame], dict[str, Any]]:
    """The trial's ``markers`` and ``plates`` tables and what the metadata says of them.

    Parameters
    ----------
    time : ndarray
        The trial's times.
    markers : dict
        Marker name -> raw sagittal positions on ``time``, NaN in gaps.
    plates : LabExport
    ms : MarkerSet
    marker_std : float
        The markers' noise [m] (estimated from the record).

    Returns
    -------
    tables : dict
    metadata : dict
        ``markers`` (segments, noise, rate) and ``plates`` (noise, rate) entries.
    """
    markers_table, segments = marker_table(time, markers, ms)
    plates_table = plate_table(plates, ms, float(time[0]), float(time[-1]))
    noise = plate_noise(plates_table)
    meta = {
        "markers": {
            "segments": segments,
            "noise_std_m": float(marker_std),
            "estimated": "1.4826 x the median absolute deviation of the unfiltered minus the "
            "filtered marker positions",
            "unfiltered": True,
        },
        "plates": {
            "sample_rate": float(f"{plates.sample_rate:.9g}"),
            "force_noise_std_n": noise["force"],
            "moment_noise_std_nm": noise["moment"],
            "estimated": "1.4826 x the median absolute deviation of the second differences "
            "/ sqrt 6 while the foot is off its plate",
            "unfiltered": True,
        },
    }
    return {"markers": markers_table, "plates": plates_table}, meta
