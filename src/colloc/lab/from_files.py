"""The lab's files to a trial: read each (any format), find the landmarks and the sagittal
plane, then :func:`colloc.lab.pipeline.process_lab`."""

from __future__ import annotations

import hashlib
import os
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from colloc.data.columns import SIDES
from colloc.gait.strikes import UNLOADED_FORCE
from colloc.lab.exports import LabExport, LabFileError
from colloc.lab.formats import read_lab_file
from colloc.lab.landmarks import landmark_record
from colloc.lab.markers import DEFAULT_MARKER_SET, LANDMARKS, TRACKED_MARKERS, MarkerSet
from colloc.lab.pipeline import LabResult, process_lab
from colloc.lab.record import LabRecord, PlateSeries
from colloc.lab.sagittal import sagittal_exports
from colloc.lab.settings import LabSettings, check_settings
from colloc.lab.static_trial import record_calibration, static_calibration


def trial_from_lab(
    markers_file: str | os.PathLike[str],
    settings: LabSettings,
    forces_file: str | os.PathLike[str] | None = None,
    *,
    names: Sequence[str] | None = None,
    force_names: Sequence[str] | None = None,
    mapping: str | os.PathLike[str] | None = None,
    forward: str | None = None,
    static: str | os.PathLike[str] | None = None,
    track: str = "markers",
    static_positions: bool = False,
) -> LabResult:
    """Read a lab's files and make a gait trial of them.

    Parameters
    ----------
    markers_file : path-like
        The motion capture: a C3D (it may hold the plates too), an OpenSim TRC, or a tab
        export (which may hold the plates too); the format is read from the content
        (:func:`colloc.lab.formats.read_lab_file`).
    settings : LabSettings
    forces_file : path-like, optional
        The force plates, if separate: a MOT/STO, a C3D or a tab export; its time stamps may
        differ from the markers' (the filtered plate signals are then interpolated onto the
        marker times).
    names, force_names : sequence of str, optional
        Column names of header-less tab exports.
    mapping : path-like, optional
        OpenSim's ``_grf.xml`` naming the foot of each plate of a MOT/STO.
    forward : str, optional
        The walking direction in a 3-D file's axes (``"+x"``, ``"-z"``, ...); by default found
        from the markers (:func:`colloc.lab.sagittal.find_plane`).
    static : path-like, optional
        The standing trial (TRC or C3D): the landmarks the walk does not mark (epicondyles,
        malleoli) are taken from it and carried by their segments' clusters
        (:mod:`colloc.lab.landmarks`); what was taken is in the trial's metadata.

    track : {"markers", "landmarks"}
        What the trial keeps, unfiltered, for the marker smoother (each with its segment, in
        the metadata's ``markers: segments``): ``"markers"`` (default), the markers the
        record holds, the landmarks when it marks them, else the clusters and pelvis markers
        they were made from; ``"landmarks"``, the landmarks, carried and regressed.
    static_positions : bool
        With ``static``: the marker smoother places the tracked markers in their segments,
        and sizes the thigh and shank, from the standing trial
        (:mod:`colloc.lab.static_trial`) instead of from the walk's own inverse kinematics
        (least squares over the walk). Either way the standing trial's values are in the
        metadata (``lab: static_trial``). On OpenSim's example walk the walk's own gave
        moments closer to OpenSim's (see ``docs/lab.md``).

    Returns
    -------
    LabResult

    Raises
    ------
    ValueError
        Every problem found at once: invalid settings, unreadable files
        (:class:`colloc.lab.exports.LabFileError`), missing markers or plates, gaps longer
        than ``max_gap``, markers whose distance jumps (swapped markers), plates under the
        wrong foot, too short a record.
    """
    _check_types(settings, markers_file=markers_file, forces_file=forces_file, static=static)
    problems = settings.problems()
    if not isinstance(static_positions, bool):
        problems.append(f"static_positions: expected True or False, found {static_positions!r}")
    elif static_positions and static is None:
        problems.append(
            "static_positions (--static-positions): asked for, but no static trial given "
            "(static=, --static)"
        )
    if track not in TRACKED_MARKERS:
        problems.append(f"track: expected one of {list(TRACKED_MARKERS)}, found {track!r}")
    read: list[LabExport | LabRecord] = []
    for path, header, grf in ((markers_file, names, None), (forces_file, force_names, mapping)):
        if path is None:
            continue
        try:
            read.append(
                read_lab_file(
                    path,
                    names=header,
                    zeros_are_missing=settings.zeros_are_missing,
                    mapping=grf,
                )
            )
        except LabFileError as error:
            problems += [f"{error.source}: {p}" for p in error.problems]
    standing = None
    if static is not None:
        try:
            standing = read_lab_file(static)
        except LabFileError as error:
            problems += [f"{error.source}: {p}" for p in error.problems]
        if isinstance(standing, LabExport):
            if _is_3d(standing):
                standing = _as_record(standing)
            else:
                problems.append(
                    f"{static}: a static trial must be 3-D (TRC, C3D, or a tab export with a "
                    "NAME.PosZ column for every marker), found a planar export"
                )
    if problems:
        raise LabFileError("lab record", problems)
    landmarks: dict[str, Any] = {}
    first = read[0]
    uses_default_names = settings.marker_set == MarkerSet()
    needed = [DEFAULT_MARKER_SET.marker(side, lm) for side in SIDES for lm in LANDMARKS]
    if (
        isinstance(first, LabExport)
        and uses_default_names
        and _is_3d(first)
        and not all(name in first.markers for name in needed)
    ):
        # a tab export of clusters and pelvis markers: their poses need the third axis
        first = read[0] = _as_record(first)
    if isinstance(first, LabRecord) and uses_default_names:
        if not all(name in first.markers for name in needed):
            read[0], landmarks = landmark_record(
                first, standing if isinstance(standing, LabRecord) else None
            )
    made_from = landmarks.pop("tracked", None)
    tracked = made_from if track == "markers" else None
    markers, forces, settings, notes, walking = _planar(read, settings, forward)
    result = process_lab(markers, settings, forces, tracked=tracked)
    if isinstance(standing, LabRecord) and walking is not None:
        try:
            calibration = static_calibration(
                standing, result.trial.metadata["markers"]["segments"], walking
            )
        except LabFileError as error:
            if static_positions:  # asked for: the trial cannot be what was asked
                raise
            notes.append(  # only information: the trial stands without it
                f"static trial {standing.source}: the subject standing was not measured "
                f"({'; '.join(error.problems)}); the markers are placed and the segments "
                "sized from the walk"
            )
        else:
            record_calibration(result.trial.metadata, calibration, use=static_positions)
            notes.append(
                calibration.describe()
                + (
                    ": the markers are placed and the segments sized from it"
                    if static_positions
                    else ": recorded; the markers are placed and the segments sized from the walk"
                )
            )
    result.notes[:0] = notes
    result.trial.metadata["lab"]["notes"][:0] = notes
    if landmarks:
        result.trial.metadata["lab"]["landmarks"] = landmarks
    result.notes.extend(_file_facts(read, settings, result.trial.metadata["lab"]))
    sources = {"markers": _file_record(markers_file)}
    if forces_file is not None:
        sources["forces"] = _file_record(forces_file)
    if mapping is not None:
        sources["plate_sides"] = _file_record(mapping)
    if static is not None:
        sources["static"] = _file_record(static)
    result.trial.metadata["lab"]["sources"] = sources
    return result


def _check_types(settings: Any, **paths: Any) -> None:
    """A TypeError naming an argument of the wrong kind (before any file is opened)."""
    check_settings(settings)
    for name, value in paths.items():
        if value is not None and not isinstance(value, str | os.PathLike):
            raise TypeError(f"{name}: expected a file path, found {type(value).__name__} {value!r}")
    if paths.get("markers_file") is None:
        raise TypeError("markers_file: expected a file path, found None")


def _planar(
    read: list[LabExport | LabRecord], settings: LabSettings, forward: str | None
) -> tuple[LabExport, LabExport | None, LabSettings, list[str], np.ndarray | None]:
    """The planar exports of what was read, the settings with the plates' sides where
    the files (or the centres of pressure under the feet) state them, and the forward
    direction of 3-D records in their axes (None for planar exports)."""
    if not any(isinstance(item, LabRecord) for item in read):
        exports = [item for item in read if isinstance(item, LabExport)]
        return exports[0], exports[1] if len(exports) > 1 else None, settings, [], None
    records = [item if isinstance(item, LabRecord) else _as_record(item) for item in read]
    marker_record = records[0]
    plate_record = records[1] if len(records) > 1 else records[0]
    markers, plates, sides, notes, plane = sagittal_exports(
        marker_record, plate_record, settings.marker_set, forward
    )
    notes = (
        marker_record.notes
        + (plate_record.notes if plate_record is not marker_record else [])
        + notes
    )
    if markers is None:
        raise LabFileError(marker_record.source, ["no markers in it"])
    if plates is not None and plate_record is marker_record:
        markers = (
            replace(markers, plates=plates.plates)
            if plates.time.size == markers.time.size
            else markers
        )
        forces = None if plates.time.size == markers.time.size else plates
    else:
        forces = plates
    ms = settings.marker_set
    stated = {side: name for name, side in sides.items()}
    if len(stated) == 2 and stated != dict(ms.plates):
        known = set((forces or markers).plates)
        if all(name in known for name in ms.plates.values()) and ms.plates != MarkerSet().plates:
            raise LabFileError(
                "lab record",
                [
                    f"plates: the given plates {dict(ms.plates)} contradict the record, whose "
                    f"centres of pressure put {stated} under the feet"
                ],
            )
        settings = replace(settings, marker_set=replace(ms, plates=stated))
        notes.append(f"plates under the feet: {stated}")
    return markers, forces, settings, notes, plane.forward


def _is_3d(export: LabExport) -> bool:
    """Every marker of a tab export has its ``.PosZ`` column."""
    return bool(export.markers) and all(name in export.lateral for name in export.markers)


def _as_record(export: LabExport) -> LabRecord:
    """A tab export as a 3-D record in (forward, up, right), so it can pair with a 3-D file
    or carry clusters; a marker without ``.PosZ`` lies in the plane."""
    markers = {
        name: np.column_stack([xy, export.lateral.get(name, np.zeros(len(xy)))])
        for name, xy in export.markers.items()
    }
    plates = {}
    for name, channels in export.plates.items():
        fx, fy, mz = channels.T
        with np.errstate(divide="ignore", invalid="ignore"):
            cop = np.where(fy > UNLOADED_FORCE, mz / fy, np.nan)
        zeros = np.zeros(len(fx))
        plates[name] = PlateSeries(
            export.time,
            np.column_stack([fx, fy, zeros]),
            np.column_stack([cop, zeros, zeros]),
            np.zeros((len(fx), 3)),
        )
    return LabRecord(
        time=export.time, markers=markers, plates=plates, up=1, source=export.source,
        columns=dict(export.columns),
    )  # fmt: skip


def _file_record(path: str | os.PathLike[str]) -> dict[str, str]:
    data = Path(path).read_bytes()
    return {"path": str(Path(path).resolve()), "sha256": hashlib.sha256(data).hexdigest()}


def _file_facts(
    read: list[LabExport | LabRecord], settings: LabSettings, lab: dict[str, Any]
) -> list[str]:
    """The files' own events and subject, kept in the metadata; a subject whose stated mass
    or height differs from the settings' is noted (the settings are used)."""
    notes = []
    for record in read:
        if not isinstance(record, LabRecord):
            continue
        if record.events:
            lab.setdefault("file_events", []).extend(record.events)
        if record.subject:
            lab["file_subject"] = dict(record.subject)
            for key, given in (("body_mass", settings.body_mass), ("height", settings.height)):
                stated = record.subject.get(key)
                if isinstance(stated, float) and abs(stated - float(given)) > 0.01 * float(given):
                    notes.append(
                        f"{Path(record.source).name} states the subject's {key} as {stated:g}; "
                        f"the {given:g} given is used"
                    )
    if notes:
        lab["notes"].extend(notes)
    return notes
