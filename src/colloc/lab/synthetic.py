"""A simulated walk as a gait lab would have recorded it: markers and force plates.

The markers sit on gait2d's landmarks (:mod:`colloc.lab.markers`): the shoulder at the top of
the trunk, the greater trochanter at the hip, the knee and ankle markers on their joints, heel
and toe on the foot's contact points (one sole line, as the lab places them at one height).
Each plate reports its foot's ground reaction: the forces on the heel and toe points summed,
and their moment about the lab's origin. The treadmill's speed is in the columns
``LeftBeltSpeed`` and ``RightBeltSpeed`` (one belt speed for both), as D-Flow exports it. Seeded Gaussian noise is added to every coordinate
and channel, so that the lab pipeline can be checked against the simulation's truth.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import pandas as pd

from colloc.data.columns import SIDES
from colloc.lab.exports import MARKER_AXES, PLATE_CHANNELS, LabExport
from colloc.lab.markers import DEFAULT_MARKER_SET, MarkerSet
from colloc.models.gait2d_params import Gait2DParameters
from colloc.models.gait2d_points import StickFigureGeometry, stick_figure_points

#: The export's columns of the (split-belt) treadmill's speed [m/s].
BELT_SPEED_COLUMNS: tuple[str, ...] = ("LeftBeltSpeed", "RightBeltSpeed")

#: gait2d's point (:func:`colloc.plot.gait_animation.stick_figure_points`) per landmark, with
#: ``{side}`` for the side's points.
LANDMARK_POINTS: dict[str, str] = {
    "shoulder": "trunk_top",
    "hip": "hip",
    "knee": "{side}_knee",
    "ankle": "{side}_ankle",
    "heel": "{side}_heel",
    "toe": "{side}_toe",
}


class WalkRecord(Protocol):
    """What :func:`lab_export_from_record` reads of a closed-loop walk."""

    times: np.ndarray
    states: np.ndarray
    contact_forces: np.ndarray
    belt_speed: np.ndarray


@dataclass(frozen=True)
class LabNoise:
    """Standard deviations of the simulated lab's measurement noise.

    Attributes
    ----------
    marker : float
        Per marker coordinate [m] (motion capture: about a millimetre).
    force : float
        Per plate force channel [N].
    moment : float
        Per plate moment channel [N m].
    """

    marker: float = 0.001
    force: float = 2.0
    moment: float = 1.0

    def as_dict(self) -> dict[str, float]:
        """Plain types, for metadata."""
        return {"marker": self.marker, "force": self.force, "moment": self.moment}


def lab_export_from_record(
    record: WalkRecord,
    params: Gait2DParameters,
    *,
    seed: int,
    noise: LabNoise | None = None,
    marker_set: MarkerSet = DEFAULT_MARKER_SET,
) -> LabExport:
    """The markers and plates a lab would have recorded of a simulated walk.

    Parameters
    ----------
    record : WalkRecord
        ``times (N,)``, ``states (N, 18)``, ``contact_forces (N, 8)``, ``belt_speed (N,)``
        (e.g. :class:`colloc.gait.closed_loop.ClosedLoopRecord`).
    params : Gait2DParameters
        The subject the walk was simulated with.
    seed : int
        Seed of the noise (``numpy.random.default_rng``).
    noise : LabNoise, optional
        Default :class:`LabNoise` (``LabNoise(0, 0, 0)`` for none).
    marker_set : MarkerSet
        The names to give markers and plates.

    Returns
    -------
    LabExport
        Markers, plates and the belt speed (noise-free) on the record's times.

    Raises
    ------
    ValueError
        If the record's arrays do not have the shapes above, or ``seed`` is not a
        non-negative integer.
    """
    noise = LabNoise() if noise is None else noise
    time = np.asarray(record.times, float)
    states = np.asarray(record.states, float)
    forces = np.asarray(record.contact_forces, float)
    problems = []
    if states.shape != (time.size, 18):
        problems.append(f"record.states: expected shape ({time.size}, 18), found {states.shape}")
    if forces.shape != (time.size, 8):
        problems.append(
            f"record.contact_forces: expected shape ({time.size}, 8), found {forces.shape}"
        )
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        problems.append(f"seed: expected a non-negative int, found {seed!r}")
    if problems:
        raise ValueError("; ".join(problems))
    rng = np.random.default_rng(seed)
    points = stick_figure_points(states[:, :9], StickFigureGeometry.from_parameters(params))
    markers = {}
    for side in SIDES:
        for landmark, point in LANDMARK_POINTS.items():
            xy = points[point.format(side=side)]
            markers[marker_set.marker(side, landmark)] = xy + noise.marker * rng.standard_normal(
                xy.shape
            )
    plates = {}
    for k, side in enumerate(SIDES):
        total, moment = foot_reaction(points, forces[:, 4 * k : 4 * k + 4], side)
        channels = np.column_stack([total, moment])
        scale = np.array([noise.force, noise.force, noise.moment])
        plates[marker_set.plates[side]] = channels + scale * rng.standard_normal(channels.shape)
    belt = np.asarray(record.belt_speed, float)
    if belt.shape != time.shape:
        raise ValueError(f"record.belt_speed: expected shape {time.shape}, found {belt.shape}")
    columns = dict.fromkeys(BELT_SPEED_COLUMNS, belt)
    return LabExport(
        time=time, markers=markers, plates=plates, columns=columns, source="simulated walk"
    )


def foot_reaction(
    points: dict[str, np.ndarray], forces: np.ndarray, side: str
) -> tuple[np.ndarray, np.ndarray]:
    """One foot's ground reaction as its plate reports it.

    Parameters
    ----------
    points : dict
        :func:`colloc.models.gait2d_points.stick_figure_points` of the walk.
    forces : ndarray, shape (N, 4)
        ``Fx, Fy`` on the foot's heel, then its toe [N].
    side : str
        ``right`` or ``left``.

    Returns
    -------
    force : ndarray, shape (N, 2)
        Forward and vertical force, heel plus toe [N].
    moment : ndarray, shape (N,)
        Their moment about the lab's origin [N m].
    """
    heel, toe = points[f"{side}_heel"], points[f"{side}_toe"]
    f_heel, f_toe = forces[:, 0:2], forces[:, 2:4]
    moment = sum(p[:, 0] * f[:, 1] - p[:, 1] * f[:, 0] for p, f in ((heel, f_heel), (toe, f_toe)))
    return f_heel + f_toe, np.asarray(moment)


def write_lab_export(export: LabExport, path: str | os.PathLike[str]) -> Path:
    """Write an export as a lab would: tab separated, ``TimeStamp`` then markers (with
    ``.PosZ`` where the export has a marker's lateral coordinate) and plates.

    Parameters
    ----------
    export : LabExport
    path : path-like
        The file to write (its folder must exist); written whole or not at all.

    Returns
    -------
    Path
    """
    columns: dict[str, Any] = {"TimeStamp": export.time}
    for name, xy in export.markers.items():
        for k, axis in enumerate(MARKER_AXES):
            columns[f"{name}.{axis}"] = xy[:, k]
        if name in export.lateral:
            columns[f"{name}.PosZ"] = export.lateral[name]
    for name, channels in export.plates.items():
        for k, channel in enumerate(PLATE_CHANNELS):
            columns[f"{name}.{channel}"] = channels[:, k]
    columns.update(export.columns)
    path = Path(path)
    partial = path.with_name(f".{path.name}.part")
    pd.DataFrame(columns).to_csv(partial, sep="\t", index=False, float_format="%.6f")
    partial.replace(path)
    return path
