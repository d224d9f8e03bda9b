"""gait2d's landmarks from the markers a lab placed: named markers, points a static trial
fixes in a segment's cluster, and the hip joint centre from the pelvis.

The planar pipeline reads six landmarks per side (shoulder, hip, knee, ankle, heel, toe;
:class:`colloc.lab.markers.MarkerSet`). A lab's walk need not carry them: clusters of three
or more markers ride on the thigh and shank, and the epicondyles and malleoli are marked
only in the standing (static) trial. A landmark is then defined in the static trial (the
midpoint of the markers named for it), expressed in the frame of the markers of the segment
that carries it (their best rigid fit, :meth:`scipy.spatial.transform.Rotation.align_vectors`),
and carried through the walk by that cluster's pose at each frame. The hip joint centre
comes from the pelvis markers (:mod:`colloc.lab.hip_centre`).

:data:`MARKER_SETS` lists the conventions colloc recognises; :func:`landmark_record` picks
the one a record uses and returns the record with each landmark as a marker named as
colloc's default marker set names it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from colloc.data.columns import SIDES
from colloc.lab.exports import LabFileError
from colloc.lab.hip_centre import hip_joint_centres
from colloc.lab.markers import DEFAULT_MARKER_SET, LANDMARKS, landmark_segment
from colloc.lab.record import LabRecord

#: Fewest markers of a cluster seen at a frame for its pose to be known.
MIN_CLUSTER_MARKERS = 3


@dataclass(frozen=True)
class Landmark:
    """How one landmark of one side is found (names without the side's prefix).

    Attributes
    ----------
    markers : tuple of str
        Markers whose midpoint is the landmark (one: the marker itself).
    cluster : tuple of str
        Markers of the segment carrying it, for a landmark marked only in the static trial.
    """

    markers: tuple[str, ...]
    cluster: tuple[str, ...] = ()


@dataclass(frozen=True)
class HipRegression:
    """The hip joint centre from the pelvis (names without prefix, and sacral ones whole).

    Attributes
    ----------
    asis : str
        Each side's anterior superior iliac spine (with the side's prefix).
    posterior : tuple of str
        The posterior spines (with prefixes) or a sacral marker: their midpoint is used.
    """

    asis: str
    posterior: tuple[str, ...]


@dataclass(frozen=True)
class MarkerConvention:
    """A lab's marker set: its side prefixes and how each landmark is found.

    Attributes
    ----------
    name : str
    prefixes : dict
        Side -> prefix.
    landmarks : dict
        Landmark (:data:`colloc.lab.markers.LANDMARKS`) -> :class:`Landmark` or
        :class:`HipRegression`.
    """

    name: str
    prefixes: dict[str, str]
    landmarks: dict[str, Landmark | HipRegression] = field(default_factory=dict)

    def names(self, side: str, landmark: str) -> list[str]:
        """Every marker the landmark of ``side`` reads (for detection and messages)."""
        rule = self.landmarks[landmark]
        if isinstance(rule, HipRegression):
            return [f"{p}{rule.asis}" for p in self.prefixes.values()] + list(rule.posterior)
        return [f"{self.prefixes[side]}{m}" for m in (*rule.markers, *rule.cluster)]


#: The marker sets colloc recognises by their names.
MARKER_SETS: tuple[MarkerConvention, ...] = (
    MarkerConvention(
        "colloc (landmark markers)",
        {"right": "R", "left": "L"},
        {lm: Landmark((getattr(DEFAULT_MARKER_SET, lm),)) for lm in LANDMARKS},
    ),
    MarkerConvention(
        "OpenSim gait2354 example (clusters; epicondyles and malleoli in the static trial)",
        {"right": "R.", "left": "L."},
        {
            "shoulder": Landmark(("Acromium",)),
            "hip": HipRegression("ASIS", ("V.Sacral",)),
            "knee": Landmark(
                ("Knee.Lat", "Knee.Med"), ("Thigh.Upper", "Thigh.Front", "Thigh.Rear")
            ),
            "ankle": Landmark(
                ("Ankle.Lat", "Ankle.Med"), ("Shank.Upper", "Shank.Front", "Shank.Rear")
            ),
            "heel": Landmark(("Heel",)),
            "toe": Landmark(("Toe.Lat",)),
        },
    ),
    MarkerConvention(
        "Plug-in Gait",
        {"right": "R", "left": "L"},
        {
            "shoulder": Landmark(("SHO",)),
            "hip": HipRegression("ASI", ("RPSI", "LPSI")),
            "knee": Landmark(("KNE",)),
            "ankle": Landmark(("ANK",)),
            "heel": Landmark(("HEE",)),
            "toe": Landmark(("TOE",)),
        },
    ),
)


def detect_convention(record: LabRecord, static: LabRecord | None = None) -> MarkerConvention:
    """The marker set of ``record``: the first of :data:`MARKER_SETS` whose every landmark
    it (with ``static``) can give.

    Raises
    ------
    LabFileError
        Naming, for the closest set, what is missing.
    """
    scores = []
    for convention in MARKER_SETS:
        missing = _missing(convention, record, static)
        if not missing:
            return convention
        scores.append((len(missing), convention, missing))
    _, closest, missing = min(scores, key=lambda item: item[0])
    raise LabFileError(
        record.source,
        [
            f"markers: none of colloc's marker sets is complete here; closest "
            f"{closest.name!r}, which lacks {'; '.join(missing)} (name the landmarks' markers "
            "with --marker-names and --prefixes, or give the static trial with --static)"
        ],
    )


def _missing(
    convention: MarkerConvention, record: LabRecord, static: LabRecord | None
) -> list[str]:
    """What ``record`` (with ``static``) lacks of ``convention``'s landmarks, per landmark."""
    out = []
    for side in SIDES:
        p = convention.prefixes[side]
        for landmark, rule in convention.landmarks.items():
            if isinstance(rule, HipRegression):
                lacking = [n for n in convention.names(side, landmark) if n not in record.markers]
                if lacking:
                    out.append(f"{side} {landmark}: {', '.join(lacking)}")
                continue
            marked = [f"{p}{m}" for m in rule.markers]
            cluster = [f"{p}{m}" for m in rule.cluster]
            if all(n in record.markers for n in marked):
                continue
            if (
                cluster
                and static is not None
                and all(n in static.markers for n in marked + cluster)
                and all(n in record.markers for n in cluster)
            ):
                continue
            where = (
                f" (in the walk, or in a static trial with {'/'.join(cluster)})" if cluster else ""
            )
            out.append(f"{side} {landmark}: {'/'.join(marked)}{where}")
    return out


def landmark_record(
    record: LabRecord, static: LabRecord | None = None
) -> tuple[LabRecord, dict[str, Any]]:
    """``record`` with gait2d's landmarks as markers named by colloc's default marker set.

    Parameters
    ----------
    record : LabRecord
        The walk (3-D markers).
    static : LabRecord, optional
        The standing trial, for landmarks the walk does not mark.

    Returns
    -------
    record : LabRecord
        The walk's markers plus ``RSHO``, ``RGTRO``, ``RLEK``, ``RLM``, ``RHEE``, ``RMT5`` and
        the left side's.
    made : dict
        What was done (the convention, and per landmark its source), for the metadata, and
        under ``tracked`` the markers the landmarks were made from, each with the gait2d
        segment it moves with (a cluster's markers with its segment, the pelvis markers with
        the trunk): what the marker smoother tracks in place of the landmarks.

    Raises
    ------
    LabFileError
        When no known marker set is complete (:func:`detect_convention`).
    """
    convention = detect_convention(record, static)
    markers = dict(record.markers)
    made: dict[str, Any] = {"marker_set": convention.name, "landmarks": {}}
    tracked: dict[str, str] = {}
    up = np.zeros(3)
    up[record.up] = 1.0
    for side in SIDES:
        p = convention.prefixes[side]
        for landmark, rule in convention.landmarks.items():
            target = DEFAULT_MARKER_SET.marker(side, landmark)
            if isinstance(rule, HipRegression):
                right, left = hip_joint_centres(
                    record.markers[f"{convention.prefixes['right']}{rule.asis}"],
                    record.markers[f"{convention.prefixes['left']}{rule.asis}"],
                    np.mean([record.markers[n] for n in rule.posterior], axis=0),
                    up,
                )
                markers[target] = right if side == "right" else left
                tracked.update(dict.fromkeys(convention.names(side, landmark), "trunk"))
                made["landmarks"][target] = (
                    "hip joint centre, Harrington et al. 2007 regression on the pelvis width "
                    f"and depth from {p}{rule.asis} of both sides and {'/'.join(rule.posterior)}"
                )
                continue
            marked = [f"{p}{m}" for m in rule.markers]
            segment = landmark_segment(side, landmark)
            if all(n in record.markers for n in marked):
                markers[target] = np.mean([record.markers[n] for n in marked], axis=0)
                tracked.update(dict.fromkeys(marked, segment))
                made["landmarks"][target] = (
                    f"midpoint of {', '.join(marked)}" if len(marked) > 1 else marked[0]
                )
                continue
            assert static is not None  # else detect_convention refused
            cluster = [f"{p}{m}" for m in rule.cluster]
            markers[target], local = _carried(record, static, marked, cluster)
            tracked.update(dict.fromkeys(cluster, segment))
            made["landmarks"][target] = {
                "static": f"midpoint of {', '.join(marked)}",
                "carried_by": cluster,
                "in_cluster_frame_mm": [round(float(v) * 1000, 2) for v in local],
            }
    made["tracked"] = tracked
    return (
        LabRecord(
            time=record.time,
            markers=markers,
            plates=record.plates,
            up=record.up,
            source=record.source,
            notes=list(record.notes),
            plate_sides=dict(record.plate_sides),
            columns=dict(record.columns),
        ),  # fmt: skip
        made,
    )


def _carried(
    record: LabRecord, static: LabRecord, marked: list[str], cluster: list[str]
) -> tuple[np.ndarray, np.ndarray]:
    """A landmark marked in the static trial, carried through the walk by its cluster."""
    reference = np.array([np.nanmean(static.markers[n], axis=0) for n in cluster])
    point = np.mean([np.nanmean(static.markers[n], axis=0) for n in marked], axis=0)
    centre = reference.mean(axis=0)
    local = point - centre
    walk = np.stack([record.markers[n] for n in cluster], axis=1)  # (N, k, 3)
    out = np.full((len(record.time), 3), np.nan)
    for i, frame in enumerate(walk):
        seen = np.all(np.isfinite(frame), axis=1)
        if seen.sum() < MIN_CLUSTER_MARKERS:
            continue
        here = frame[seen].mean(axis=0)
        rotation, _ = Rotation.align_vectors(
            frame[seen] - here, reference[seen] - reference[seen].mean(axis=0)
        )
        out[i] = here + rotation.apply(local + centre - reference[seen].mean(axis=0))
    return out, local
