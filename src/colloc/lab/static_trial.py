"""The subject in the model from the standing (static) trial.

A gait lab records a few seconds of the subject standing still, with the markers it leaves
off during the walk (the femoral epicondyles and the malleoli). From those frames this module
takes, in the walk's sagittal plane:

- the length of each thigh (hip to knee) and shank (knee to ankle) between gait2d's landmarks
  (:func:`colloc.lab.landmarks.landmark_record` makes them: the hip by regression on the
  pelvis markers, the knee and ankle as the midpoints of their epicondyles and malleoli);
- each tracked marker's position in its segment's frame (:mod:`colloc.models.gait2d_markers`:
  origin at the segment's proximal joint, ``x`` forward and ``y`` up at zero angle), with the
  frames placed as gait2d places them from the standing pose: the trunk's and both thighs'
  at the hip, each shank's at the end of its thigh, each foot's at the end of its shank, the
  segments oriented as :mod:`colloc.lab.kinematics` orients them.

The lengths are the mean of the two sides (gait2d has one thigh and one shank length), and
the frames are built with those lengths, so that a marker's position is in the frame the
marker smoother's model moves it with. Noise averages over the static frames: 1 mm of white
noise over 200 frames leaves 0.07 mm.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from colloc.data.columns import SIDES
from colloc.lab.exports import LabFileError
from colloc.lab.kinematics import segment_orientation, segment_orientations
from colloc.lab.landmarks import landmark_record
from colloc.lab.markers import DEFAULT_MARKER_SET, LANDMARKS
from colloc.lab.record import LabRecord

#: The proximal joint of each leg segment, and the segment whose end it is.
_ORIGINS = {"thigh": None, "shank": "thigh", "foot": "shank"}


@dataclass(frozen=True)
class StaticCalibration:
    """What the standing trial says of the subject.

    Attributes
    ----------
    lengths : dict
        ``<side>_thigh``, ``<side>_shank`` -> hip to knee, knee to ankle [m].
    in_segment : dict
        Marker name -> ``(a, b)`` in its segment's frame [m].
    frames : int
        Standing frames averaged.
    source : str
        The static trial's file or name.
    missing : list of str
        Tracked markers the static trial does not have (their positions come from the walk).
    """

    lengths: dict[str, float]
    in_segment: dict[str, tuple[float, float]]
    frames: int
    source: str
    missing: list[str]

    def segment_length(self, segment: str) -> float:
        """``thigh`` or ``shank``: the mean of the two sides [m]."""
        return float(np.mean([self.lengths[f"{side}_{segment}"] for side in SIDES]))

    def describe(self) -> str:
        """One line for the trial's notes."""
        said = (
            f"static trial {self.source}: thigh {self.segment_length('thigh') * 1000:.1f} mm, "
            f"shank {self.segment_length('shank') * 1000:.1f} mm (mean of the sides) and the "
            f"positions of {len(self.in_segment)} markers in their segments, from "
            f"{self.frames} standing frames"
        )
        if self.missing:
            said += f"; not in it: {', '.join(self.missing)} (placed from the walk)"
        return said


def static_calibration(
    standing: LabRecord, segments: Mapping[str, str], forward: Any
) -> StaticCalibration:
    """Segment lengths and the tracked markers' positions in their segments, from the
    standing trial.

    Parameters
    ----------
    standing : LabRecord
        The static trial (3-D), with the markers of a convention
        :func:`colloc.lab.landmarks.detect_convention` knows.
    segments : mapping
        Tracked marker name -> its gait2d segment (:data:`colloc.models.gait2d_markers.SEGMENTS`).
    forward : array_like, shape (3,)
        The walk's forward direction in the record's axes (the sagittal plane's
        :attr:`colloc.lab.sagittal.SagittalPlane.forward`).

    Returns
    -------
    StaticCalibration

    Raises
    ------
    LabFileError
        When a landmark cannot be made from the static trial, or one is never seen in it.
    """
    up = np.zeros(3)
    up[standing.up] = 1.0
    along = np.asarray(forward, dtype=float) - (np.asarray(forward, dtype=float) @ up) * up
    if not np.linalg.norm(along) > 0.5:
        raise ValueError(f"forward: expected a horizontal direction, found {forward!r}")
    along = along / np.linalg.norm(along)
    landmarked, _ = landmark_record(standing, standing)

    problems: list[str] = []

    def planar(name: str) -> np.ndarray:
        xyz = landmarked.markers[name]
        seen = np.all(np.isfinite(xyz), axis=1)
        if not seen.any():
            problems.append(f"marker {name}: never seen in the standing frames")
            return np.full(2, np.nan)
        mean = xyz[seen].mean(axis=0)
        return np.array([mean @ along, mean @ up])

    points = {
        (side, landmark): planar(DEFAULT_MARKER_SET.marker(side, landmark))
        for side in SIDES
        for landmark in LANDMARKS
    }
    present = {name: planar(name) for name in segments if name in landmarked.markers}
    if problems:
        raise LabFileError(standing.source or "static trial", problems)
    hip = 0.5 * (points[("right", "hip")] + points[("left", "hip")])
    shoulder = 0.5 * (points[("right", "shoulder")] + points[("left", "shoulder")])
    trunk = float(segment_orientation(hip[None], shoulder[None], (0.0, 1.0))[0])
    lengths = {}
    for side in SIDES:
        lengths[f"{side}_thigh"] = float(
            np.linalg.norm(points[(side, "knee")] - points[(side, "hip")])
        )
        lengths[f"{side}_shank"] = float(
            np.linalg.norm(points[(side, "ankle")] - points[(side, "knee")])
        )
    mean_length = {
        segment: float(np.mean([lengths[f"{side}_{segment}"] for side in SIDES]))
        for segment in ("thigh", "shank")
    }
    frames: dict[str, tuple[np.ndarray, float]] = {"trunk": (hip, trunk)}
    for side in SIDES:
        orientation = segment_orientations({lm: points[(side, lm)][None] for lm in LANDMARKS})
        origin = hip
        for segment, before in _ORIGINS.items():
            if before is not None:  # the end of the segment before, down its y axis
                angle = frames[f"{side}_{before}"][1]
                origin = origin + mean_length[before] * np.array([np.sin(angle), -np.cos(angle)])
            frames[f"{side}_{segment}"] = (origin, float(orientation[segment][0]))
    in_segment = {}
    for name, xy in present.items():
        origin, angle = frames[segments[name]]
        c, s = np.cos(angle), np.sin(angle)
        dx, dy = xy - origin
        in_segment[name] = (float(c * dx + s * dy), float(-s * dx + c * dy))
    return StaticCalibration(
        lengths=lengths,
        in_segment=in_segment,
        frames=int(standing.time.size),
        source=standing.source or "static trial",
        missing=sorted(set(segments) - set(present)),
    )


def record_calibration(
    metadata: dict[str, Any], calibration: StaticCalibration, use: bool = False
) -> None:
    """Write ``calibration`` into a lab trial's metadata.

    It is always recorded as what the standing trial says (``lab: static_trial``: its
    segment lengths and the markers' positions in their segments). With ``use`` the model
    takes it: the markers' positions (``markers: in_segment_m``, with ``in_segment_from``)
    and the standing lengths beside the walk's (``lab: segment_lengths_m: <side>_<segment>:
    static``), which the marker smoother then reads in place of the walk's own.

    Parameters
    ----------
    metadata : dict
        :func:`colloc.lab.pipeline.process_lab`'s trial metadata, changed in place.
    calibration : StaticCalibration
    use : bool
        Place the markers and size the segments from the standing trial.
    """
    lab = metadata.setdefault("lab", {})
    placed = {name: [float(a), float(b)] for name, (a, b) in calibration.in_segment.items()}
    lab["static_trial"] = {
        "source": calibration.source,
        "frames": calibration.frames,
        "segment_lengths_m": dict(calibration.lengths),
        "in_segment_m": placed,
        "not_in_it": list(calibration.missing),
        "used": bool(use),
    }
    if not use:
        return
    markers = metadata.setdefault("markers", {})
    markers["in_segment_m"] = placed
    markers["in_segment_from"] = (
        f"the static trial {calibration.source} ({calibration.frames} standing frames)"
    )
    lengths = lab.setdefault("segment_lengths_m", {})
    for key, value in calibration.lengths.items():
        lengths.setdefault(key, {})["static"] = float(value)


__all__ = ["StaticCalibration", "record_calibration", "static_calibration"]
