"""The lab's measurements as they were recorded, kept in the trial for the marker smoother.

:func:`colloc.lab.pipeline.process_lab` makes the trial's signals through a filter, inverse
kinematics and inverse dynamics. The smoother that tracks markers and plates
(:func:`colloc.identify.gait.markers.marker_smoother`) needs what came before those steps:
each tracked marker's sagittal position, unfiltered and with its gaps left as gaps, at the
marker rate, and each foot's plate at the plate rate. Each marker is assigned to the gait2d
segment it moves with: a landmark's (:data:`colloc.lab.markers.LANDMARK_SEGMENTS`), or, for
clusters and skin markers, the segment whose cluster it belongs to
(:func:`colloc.lab.landmarks.landmark_record`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from colloc.data.columns import SIDES, TIME_COLUMN
from colloc.data.filtering import zero_lag_lowpass
from colloc.data.tables import PLATE_COLUMNS
from colloc.lab.exports import LabExport
from colloc.lab.markers import LANDMARKS, MarkerSet, landmark_segment
from colloc.lab.noise import moment_noise, off_plate_noise, robust_sd
from colloc.lab.plausibility import MAX_MARKER_SPEED, spikes


def landmark_segments(ms: MarkerSet) -> dict[str, str]:
    """Each landmark marker of ``ms`` -> the gait2d segment it moves with."""
    return {
        ms.marker(side, landmark): landmark_segment(side, landmark)
        for side in SIDES
        for landmark in LANDMARKS
    }


def marker_table(time: np.ndarray, markers: dict[str, np.ndarray]) -> pd.DataFrame:
    """The markers' raw positions as a table.

    Parameters
    ----------
    time : ndarray, shape (N,)
        The trial's times (the markers' own).
    markers : dict
        Marker name -> (N, 2) sagittal positions [m], NaN where not seen.

    Returns
    -------
    DataFrame
        ``time``, ``<marker>_x``, ``<marker>_y``.
    """
    columns: dict[str, np.ndarray] = {TIME_COLUMN: np.asarray(time, dtype=float)}
    for name, xy in markers.items():
        xy = np.asarray(xy, dtype=float)
        columns[f"{name}_x"], columns[f"{name}_y"] = xy[:, 0], xy[:, 1]
    return pd.DataFrame(columns)


def tracked_positions(
    time: np.ndarray,
    markers: dict[str, np.ndarray],
    rows: np.ndarray,
    rate: float,
    cutoff_hz: float,
) -> tuple[dict[str, np.ndarray], float, list[str]]:
    """Skin markers as the smoother tracks them: unfiltered, on the trial's rows, a sample
    that jumps away and back faster than a body moves (:func:`colloc.lab.plausibility.spikes`)
    and every gap left out (NaN), and their noise.

    Parameters
    ----------
    time : ndarray, shape (M,)
        The record's times (before its ends were cut).
    markers : dict
        Marker name -> (M, 2) sagittal positions [m], NaN where not seen.
    rows : ndarray of int
        The record's rows the trial keeps.
    rate : float
        The marker rate [Hz].
    cutoff_hz : float
        The low-pass cut-off the noise is read against.

    Returns
    -------
    positions : dict
        Marker name -> (len(rows), 2).
    noise : float
        1.4826 times the median absolute deviation of each marker's samples from their
        low-pass filtered course (gaps bridged linearly for the filter only), over all.
    notes : list of str
        One per marker with spikes.
    """
    positions, residuals, notes = {}, [], []
    found = spikes(markers, rate)
    for name, xy in markers.items():
        xy = np.array(xy, dtype=float)
        if name in found:
            xy[found[name]] = np.nan
            notes.append(
                f"marker {name}: {found[name].size} sample(s) jump away and back faster than "
                f"{MAX_MARKER_SPEED:g} m/s (first at t = {time[found[name][0]]:g} s): left out"
            )
        kept = xy[rows]
        seen = np.all(np.isfinite(kept), axis=1)
        positions[name] = kept
        if seen.sum() < 2:
            continue
        bridged = np.column_stack(
            [np.interp(time[rows], time[rows][seen], kept[seen, k]) for k in range(2)]
        )
        residuals.append((kept - zero_lag_lowpass(bridged, rate, cutoff_hz))[seen].ravel())
    noise = robust_sd(np.concatenate(residuals)) if residuals else 0.0
    return positions, noise, notes


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
    """The plates' noise, from the second differences of the samples (white noise: variance
    ``6 sigma^2``), robustly (1.4826 times the median absolute deviation): the forces' while
    the foot is off its plate (:func:`colloc.lab.noise.off_plate_noise`), the moment's where
    it is recorded (:func:`colloc.lab.noise.moment_noise`), when the forces show noise at
    all. Zero when nothing varies."""
    load = {side: table[f"{side}_force_y"].to_numpy(dtype=float) for side in SIDES}
    force = off_plate_noise(
        [
            (table[[f"{side}_force_x", f"{side}_force_y"]].to_numpy(dtype=float), load[side])
            for side in SIDES
        ]
    )
    # plates filtered before export show no noise to read: the moment's smooth remnants are
    # no white noise either (OpenSim's example MOT read 0.02 N m, which stopped the smoother)
    moment = (
        moment_noise(
            [(table[f"{side}_moment"].to_numpy(dtype=float), load[side]) for side in SIDES]
        )
        if force > 0
        else 0.0
    )
    return {"force": force, "moment": moment}


def raw_records(
    time: np.ndarray,
    markers: dict[str, np.ndarray],
    segments: dict[str, str],
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
    segments : dict
        Marker name -> the gait2d segment it moves with.
    plates : LabExport
    ms : MarkerSet
        Which plate is under which foot.
    marker_std : float
        The markers' noise [m] (estimated from the record).

    Returns
    -------
    tables : dict
    metadata : dict
        ``markers`` (segments, noise, rate) and ``plates`` (noise, rate) entries.
    """
    markers_table = marker_table(time, markers)
    plates_table = plate_table(plates, ms, float(time[0]), float(time[-1]))
    noise = plate_noise(plates_table)
    meta = {
        "markers": {
            "segments": {name: segments[name] for name in markers},
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
            "/ sqrt 6: the forces' while the foot is off its plate, the moment's where it is "
            "recorded (not exactly zero), off the plate if it is there, else under load",
            "unfiltered": True,
        },
    }
    return {"markers": markers_table, "plates": plates_table}, meta
