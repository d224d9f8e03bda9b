"""A simulated walk as a gait lab records it with skin markers: clusters, a static trial, and
force plates at their own rate.

:func:`skin_lab_from_record` gives two 3-D :class:`colloc.lab.record.LabRecord` objects in
(forward, up, right) axes, OpenSim's: the walk, with :data:`colloc.lab.skin_markers.SKIN_MARKERS`
(no marker on a knee or an ankle) at the record's rate and each foot's plate at the plates'
rate (the record's ``fine_*`` arrays when the walk was simulated with ``substeps``), and the
standing trial, with the epicondyles and malleoli as well. Seeded Gaussian noise is added to
every marker coordinate and plate channel. Each plate reports its foot's ground reaction:
the forward and vertical force and the centre of pressure on the floor where the moment of
the heel's and toe's forces about it vanishes (no free torque in a planar walk).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from colloc.data.columns import SIDES
from colloc.lab.markers import DEFAULT_MARKER_SET, MarkerSet
from colloc.lab.record import LabRecord, PlateSeries
from colloc.lab.skin_markers import skin_marker_positions, standing_pose
from colloc.lab.synthetic import BELT_SPEED_COLUMNS, LabNoise, foot_reaction
from colloc.models.gait2d_params import Gait2DParameters
from colloc.models.gait2d_points import StickFigureGeometry, stick_figure_points

#: Distance [m] of each plate's centre of pressure from the sagittal plane, to its side.
PLATE_LATERAL = 0.1
#: Vertical force [N] below which a plate reports no centre of pressure (unloaded).
UNLOADED = 1.0
#: Seconds of standing in the static trial.
STATIC_SECONDS = 2.0


class FineWalk(Protocol):
    """What :func:`skin_lab_from_record` reads of a closed-loop walk."""

    times: np.ndarray
    states: np.ndarray
    contact_forces: np.ndarray
    belt_speed: np.ndarray
    fine_times: np.ndarray | None
    fine_states: np.ndarray | None
    fine_contact_forces: np.ndarray | None


@dataclass(frozen=True)
class SkinLab:
    """A synthetic lab's walk and static trial.

    Attributes
    ----------
    walk : LabRecord
        Skin markers at the record's rate, plates at theirs, the belt speed in ``columns``.
    static : LabRecord
        The standing trial's markers (no plates).
    """

    walk: LabRecord
    static: LabRecord


def skin_lab_from_record(
    record: FineWalk,
    params: Gait2DParameters,
    *,
    seed: int,
    noise: LabNoise | None = None,
    marker_set: MarkerSet = DEFAULT_MARKER_SET,
) -> SkinLab:
    """The skin markers, plates and static trial a lab would have recorded of a walk.

    Parameters
    ----------
    record : FineWalk
        A simulated walk (:class:`colloc.gait.closed_loop.ClosedLoopRecord`); its ``fine_*``
        arrays, when present, give the plates' rate.
    params : Gait2DParameters
        The subject the walk was simulated with.
    seed : int
        Seed of the noise (``numpy.random.default_rng``).
    noise : LabNoise, optional
        Default :class:`colloc.lab.synthetic.LabNoise` (``LabNoise(0, 0, 0)`` for none); the
        moment's noise is put on the centre of pressure as the moment's error over the
        vertical force.
    marker_set : MarkerSet
        The plates' names (``marker_set.plates``).

    Returns
    -------
    SkinLab

    Raises
    ------
    ValueError
        If the record's arrays do not have matching shapes, or ``seed`` is not a
        non-negative integer.
    """
    noise = LabNoise() if noise is None else noise
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed: expected a non-negative int, found {seed!r}")
    time = np.asarray(record.times, float)
    states = np.asarray(record.states, float)
    if states.shape != (time.size, 18):
        raise ValueError(f"record.states: expected shape ({time.size}, 18), found {states.shape}")
    fine = record.fine_times is not None
    plate_time = np.asarray(record.fine_times if fine else time, float)
    plate_states = np.asarray(record.fine_states if fine else states, float)
    forces = np.asarray(record.fine_contact_forces if fine else record.contact_forces, float)
    if plate_states.shape != (plate_time.size, 18) or forces.shape != (plate_time.size, 8):
        raise ValueError(
            f"record: the plates' states {plate_states.shape} and contact forces "
            f"{forces.shape} do not match their {plate_time.size} times"
        )
    rng = np.random.default_rng(seed)
    geometry = StickFigureGeometry.from_parameters(params)
    markers = {
        name: xyz + noise.marker * rng.standard_normal(xyz.shape)
        for name, xyz in skin_marker_positions(states[:, :9], geometry).items()
    }
    points = stick_figure_points(plate_states[:, :9], geometry)
    plates = {}
    for k, side in enumerate(SIDES):
        plates[marker_set.plates[side]] = _plate(
            plate_time, points, forces[:, 4 * k : 4 * k + 4], side, noise, rng
        )
    belt = np.asarray(record.belt_speed, float)
    walk = LabRecord(
        time=time,
        markers=markers,
        plates=plates,
        up=1,
        source="simulated walk (skin markers)",
        columns=dict.fromkeys(BELT_SPEED_COLUMNS, belt),
    )
    standing_time = np.arange(int(round(STATIC_SECONDS / np.median(np.diff(time))))) * float(
        np.median(np.diff(time))
    )
    q = np.tile(standing_pose(geometry), (standing_time.size, 1))
    static = LabRecord(
        time=standing_time,
        markers={
            name: xyz + noise.marker * rng.standard_normal(xyz.shape)
            for name, xyz in skin_marker_positions(q, geometry, standing=True).items()
        },
        plates={},
        up=1,
        source="simulated static trial (skin markers)",
    )
    return SkinLab(walk=walk, static=static)


def _plate(
    time: np.ndarray,
    points: dict[str, np.ndarray],
    forces: np.ndarray,
    side: str,
    noise: LabNoise,
    rng: np.random.Generator,
) -> PlateSeries:
    """One foot's plate: forces with noise, the centre of pressure from the noisy moment."""
    total, moment = foot_reaction(points, forces, side)
    total = total + noise.force * rng.standard_normal(total.shape)
    moment = moment + noise.moment * rng.standard_normal(moment.shape)
    fx, fy = total.T
    cop = np.full((time.size, 3), np.nan)
    loaded = fy > UNLOADED
    cop[loaded, 0] = moment[loaded] / fy[loaded]
    cop[loaded, 1] = 0.0
    cop[loaded, 2] = PLATE_LATERAL * (1.0 if side == "right" else -1.0)
    force = np.column_stack([fx, fy, np.zeros(time.size)])
    return PlateSeries(time, force, cop, np.zeros((time.size, 3)))


__all__ = ["FineWalk", "STATIC_SECONDS", "SkinLab", "skin_lab_from_record"]
