"""C3D files through ezc3d: markers, analog channels and force platforms, read and written.

Reading takes the points in their stated ``POINT:UNITS``, the analog channels at their own
rate, and each force platform (types 1-4, with corners, origin and calibration matrix) as
ezc3d's platform filter gives it: the ground reaction on the foot in the lab's axes, its
centre of pressure and the free torque. The vertical is the axis along which the platforms
push (their summed force), else ``POINT:Y_SCREEN`` when the file states it, else +Z.

Writing makes what a lab's system would: points in millimetres, Z up, X forward, and type-2
platforms (six channels Fx, Fy, Fz, Mx, My, Mz in the plate's axes, z down, moments in
N mm about the sensor origin below the surface), so that the whole lab path can be tested
from a C3D.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from colloc.lab.exports import LabFileError
from colloc.lab.record import LENGTH_UNITS, LabRecord, PlateSeries

#: Byte 2 of every C3D file (its parameter section's key).
SIGNATURE_BYTE = 0x50


#: Depth of the written plates' sensor origin below the surface [mm] (C3D ORIGIN z).
SENSOR_DEPTH = 40.0

#: Extent of the written plates [mm]: along x (forward) and across.
PLATE_LENGTH, PLATE_WIDTH = 3000.0, 500.0


def is_c3d(path: Path) -> bool:
    """Whether ``path`` starts like a C3D file (second byte 0x50)."""
    try:
        with open(path, "rb") as stream:
            head = stream.read(2)
    except OSError:
        return False
    return len(head) == 2 and head[1] == SIGNATURE_BYTE


def read_c3d(path: str | os.PathLike[str]) -> LabRecord:
    """Read a C3D file's markers, analogs and force platforms in SI units.

    Parameters
    ----------
    path : path-like

    Returns
    -------
    LabRecord
        Markers [m] at the point rate; plates named ``FP1``, ``FP2``, ... (their order in
        ``FORCE_PLATFORM``) at the analog rate; analog channels by label in ``analogs``.

    Raises
    ------
    LabFileError
        If ezc3d cannot read it, the point units are unknown, or the platforms push along
        no single axis.
    """
    import ezc3d  # a compiled reader: loaded only for C3D files

    path = Path(path)
    try:
        c3d = ezc3d.c3d(str(path), extract_forceplat_data=True)
    except Exception as error:  # ezc3d raises many kinds on a damaged file
        raise LabFileError(str(path), [f"ezc3d cannot read it ({error})"]) from error
    point = c3d["parameters"]["POINT"]
    units = (point.get("UNITS", {}).get("value") or ["mm"])[0].strip()
    if units not in LENGTH_UNITS:
        raise LabFileError(
            str(path), [f"POINT:UNITS: expected one of {list(LENGTH_UNITS)}, found {units!r}"]
        )
    scale = LENGTH_UNITS[units]
    rate = float(c3d["header"]["points"]["frame_rate"])
    labels = [str(label).strip() for label in point["LABELS"]["value"]]
    points = np.asarray(c3d["data"]["points"], float)
    frames = points.shape[2]
    time = np.arange(frames) / rate
    markers = {label: points[:3, k, :].T * scale for k, label in enumerate(labels)}
    notes = [f"{path.name}: markers in {units}, converted to m"] if scale != 1.0 else []
    analog_rate = float(c3d["header"]["analogs"]["frame_rate"] or 0.0)
    analogs = np.asarray(c3d["data"]["analogs"], float)
    analog_labels = [str(v).strip() for v in c3d["parameters"]["ANALOG"]["LABELS"]["value"]]
    analog_time = np.arange(analogs.shape[2]) / analog_rate if analog_rate else np.empty(0)
    columns = _other_channels(c3d["parameters"], analogs, analog_labels, frames)
    plates = {}
    for k, platform in enumerate(c3d["data"]["platform"]):
        plates[f"FP{k + 1}"] = _plate(platform, analog_time)
    up = _vertical(plates, point, path)
    for plate in plates.values():
        # kept wherever the plate reports a force: times the force it is the plate's moment,
        # which the planar pipeline reads (it leaves the centre of pressure out when unloaded)
        plate.point[plate.force[:, up] == 0.0] = np.nan
    return LabRecord(
        time=time,
        markers=markers,
        plates=plates,
        up=up,
        source=str(path),
        notes=notes,
        columns=columns,
        analogs={label: analogs[0, k] for k, label in enumerate(analog_labels)},
        analog_time=analog_time,
        events=_events(c3d["parameters"]),
        subject=_subject(c3d["parameters"]),
    )


def _other_channels(
    parameters: dict[str, Any], analogs: np.ndarray, labels: list[str], frames: int
) -> dict[str, np.ndarray]:
    """The analog channels no force platform reads (a treadmill's belt speed, say), at the
    frames: each frame's first analog sample."""
    used = parameters.get("FORCE_PLATFORM", {}).get("CHANNEL", {}).get("value", [])
    taken = {int(c) - 1 for c in np.ravel(np.asarray(used, dtype=float))}
    samples = analogs.shape[2]
    if not frames or not samples or samples % frames:
        return {}
    step = samples // frames
    return {
        label: analogs[0, k, ::step][:frames].copy()
        for k, label in enumerate(labels)
        if k not in taken and label
    }


def _events(parameters: dict[str, Any]) -> list[dict[str, object]]:
    """The EVENT group's events, in time order (TIMES holds minutes and seconds)."""
    group = parameters.get("EVENT", {})
    if "TIMES" not in group:
        return []
    times = np.asarray(group["TIMES"]["value"], float).reshape(2, -1)
    labels = list(group.get("LABELS", {}).get("value", []))
    contexts = list(group.get("CONTEXTS", {}).get("value", []))
    events = [
        {
            "label": str(labels[k]).strip() if k < len(labels) else "",
            "context": str(contexts[k]).strip() if k < len(contexts) else "",
            "time": float(60.0 * times[0, k] + times[1, k]),
        }
        for k in range(times.shape[1])
    ]
    return sorted(events, key=lambda event: float(event["time"]))  # type: ignore[arg-type]


def _subject(parameters: dict[str, Any]) -> dict[str, object]:
    """Name, body mass and height where the file states them (SUBJECTS, and the PROCESSING
    group Plug-in Gait writes: ``Bodymass`` in kg, ``Height`` in mm)."""
    out: dict[str, object] = {}
    names = parameters.get("SUBJECTS", {}).get("NAMES", {}).get("value", [])
    if len(names) and str(names[0]).strip():
        out["name"] = str(names[0]).strip()
    processing = parameters.get("PROCESSING", {})
    for key, name, scale in (("Bodymass", "body_mass", 1.0), ("Height", "height", 0.001)):
        value = processing.get(key, {}).get("value", [])
        if len(value) and float(value[0]) > 0:
            out[name] = float(value[0]) * scale
    return out


def _plate(platform: dict[str, Any], time: np.ndarray) -> PlateSeries:
    """One ezc3d platform in SI units (its positions and moments carry their own units)."""
    length = LENGTH_UNITS.get(str(platform["unit_position"]).strip(), 0.001)
    moment_unit = str(platform["unit_moment"]).strip()
    torque_scale = 0.001 if moment_unit.lower() == "nmm" else 1.0
    force = np.asarray(platform["force"], float).T
    point = np.asarray(platform["center_of_pressure"], float).T * length
    torque = np.asarray(platform["Tz"], float).T * torque_scale
    return PlateSeries(time=time, force=force, point=point, free_torque=torque)


def _vertical(plates: dict[str, PlateSeries], point: dict[str, Any], path: Path) -> int:
    if plates:
        total = sum(np.nansum(plate.force, axis=0) for plate in plates.values())
        axis = int(np.argmax(np.abs(total)))
        if total[axis] < 0:
            raise LabFileError(
                str(path),
                [f"force platforms: they push along -{'xyz'[axis]}: the lab's up axis points down"],
            )
        return axis
    screen = (point.get("Y_SCREEN", {}).get("value") or ["+Z"])[0].strip().upper()
    return "XYZ".index(screen[-1]) if screen[-1:] in ("X", "Y", "Z") else 2


def write_c3d(
    path: str | os.PathLike[str],
    time: np.ndarray,
    markers: dict[str, np.ndarray],
    plates: dict[str, PlateSeries],
    analog_rate: float,
    events: list[dict[str, object]] | None = None,
    columns: dict[str, np.ndarray] | None = None,
) -> Path:
    """Write markers and type-2 force platforms as a C3D file (X forward, Z up, mm).

    Parameters
    ----------
    path : path-like
    time : ndarray, shape (N,)
        The markers' times [s], of a fixed rate.
    markers : dict
        Name -> array (N, 3) [m] in (forward, left, up).
    plates : dict
        Name -> :class:`PlateSeries` in the same axes, sampled at ``analog_rate`` over the
        markers' span (an integer number of samples per frame; the last frame's samples past
        the plate's last hold its last value); the centre of pressure on the floor (up = 0). Plate ``k`` lies across ``y`` from ``(-1)^(k+1)`` (0 to 500 mm):
        the first on the right.
    analog_rate : float
        [Hz].
    events : list of dict, optional
        ``label``, ``context`` and ``time`` [s] of each event (e.g. heel strikes).
    columns : dict, optional
        More signals at the markers' times (e.g. the belt speed), each written as an analog
        channel of its name after the platforms', its value held over each frame.

    Returns
    -------
    Path
    """
    import ezc3d

    path = Path(path)
    rate = 1.0 / float(np.median(np.diff(time)))
    per_frame = int(round(analog_rate / rate))
    c3d = ezc3d.c3d()
    c3d["parameters"]["POINT"]["RATE"]["value"] = [rate]
    c3d["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    c3d["parameters"]["POINT"]["LABELS"]["value"] = tuple(markers)
    points = np.ones((4, len(markers), time.size))
    for k, xyz in enumerate(markers.values()):
        points[:3, k, :] = xyz.T * 1000.0
    c3d["data"]["points"] = points
    c3d["parameters"]["ANALOG"]["RATE"]["value"] = [analog_rate]
    extra = columns or {}
    labels = tuple(
        f"{c}{k + 1}" for k in range(len(plates)) for c in ("Fx", "Fy", "Fz", "Mx", "My", "Mz")
    ) + tuple(extra)
    c3d["parameters"]["ANALOG"]["LABELS"]["value"] = labels
    analogs = np.zeros((1, len(labels), time.size * per_frame))
    for k, values in enumerate(extra.values(), start=6 * len(plates)):
        analogs[0, k, :] = np.repeat(np.asarray(values, dtype=float), per_frame)
    corners = np.zeros((3, 4, len(plates)))
    for k, plate in enumerate(plates.values()):
        lateral = np.nanmedian(plate.point[:, 1]) if np.isfinite(plate.point[:, 1]).any() else 0.0
        centre = np.array([0.0, 1000.0 * lateral, 0.0])
        corners[:, :, k] = _corners(centre).T
        # a frame's analog samples run to the next frame: the last frame's past the
        # plate's last sample hold it (zeros there would read as a foot lifted at the end)
        channels = _type2_channels(plate, centre)[: analogs.shape[2]]
        analogs[0, 6 * k : 6 * k + 6, :] = np.pad(
            channels, ((0, analogs.shape[2] - len(channels)), (0, 0)), mode="edge"
        ).T
    c3d["data"]["analogs"] = analogs
    c3d.add_parameter("FORCE_PLATFORM", "USED", len(plates))
    _integers(c3d, "TYPE", [2] * len(plates), [len(plates)])
    c3d.add_parameter("FORCE_PLATFORM", "CORNERS", corners)
    origin = np.tile(np.array([[0.0], [0.0], [-SENSOR_DEPTH]]), (1, len(plates)))
    c3d.add_parameter("FORCE_PLATFORM", "ORIGIN", origin)
    channels = np.arange(1, 6 * len(plates) + 1).reshape(len(plates), 6).T
    _integers(c3d, "CHANNEL", channels, list(channels.shape))
    _integers(c3d, "ZERO", [0, 0], [2])
    for event in events or []:
        seconds = float(event["time"])  # type: ignore[arg-type]
        c3d.add_event(
            [int(seconds // 60), seconds % 60],
            context=str(event["context"]),
            label=str(event["label"]),
        )
    partial = path.with_name(f".{path.stem}.part.c3d")  # ezc3d writes to names ending .c3d
    c3d.write(str(partial))
    partial.replace(path)
    return path


def _corners(centre: np.ndarray) -> np.ndarray:
    """The four corners [mm] of a plate whose axes are x forward, y right, z down (the
    usual AMTI layout in a Z-up lab): corner order fixes the plate's axes for readers."""
    hx, hy = PLATE_LENGTH / 2, PLATE_WIDTH / 2
    offsets = np.array([[hx, -hy, 0.0], [-hx, -hy, 0.0], [-hx, hy, 0.0], [hx, hy, 0.0]])
    return centre + offsets


def _type2_channels(plate: PlateSeries, centre: np.ndarray) -> np.ndarray:
    """Fx, Fy, Fz [N] and Mx, My, Mz [N mm] a type-2 plate reports for a ground reaction.

    The plate's axes are (x, -y, -z) of the lab's; it reports the reaction on the foot in
    them, and the moments about its sensor origin ``SENSOR_DEPTH`` below the surface.
    """
    force = plate.force * np.array([1.0, -1.0, -1.0])
    cop = np.nan_to_num((plate.point * 1000.0 - centre) * np.array([1.0, -1.0, -1.0]))
    fx, fy, fz = force.T
    depth = -SENSOR_DEPTH
    my = fx * depth - cop[:, 0] * fz
    mx = cop[:, 1] * fz - fy * depth
    free = -plate.free_torque[:, 2] * 1000.0
    mz = free + cop[:, 0] * fy - cop[:, 1] * fx
    return np.column_stack([fx, fy, fz, mx, my, mz])


def _integers(c3d: Any, name: str, values: Any, shape: list[int]) -> None:
    """An integer FORCE_PLATFORM parameter (ezc3d's add_parameter writes lists as floats,
    which its platform filter refuses)."""
    import ezc3d

    parameter = ezc3d.ezc3d.Parameter(name)
    flat = [int(v) for v in np.ravel(np.asarray(values), order="F")]
    parameter.set(ezc3d.ezc3d.VecInt(flat), ezc3d.ezc3d.VecUInt([int(d) for d in shape]))
    c3d._storage["parameters"].add_parameter("FORCE_PLATFORM", parameter)
