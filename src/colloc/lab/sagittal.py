"""The sagittal plane of a 3-D lab record: forward and up, left and right checked.

The planar pipeline reads markers as (forward, up) and each plate as its forward and
vertical force and its moment about the floor below the lab's origin. A 3-D record states
its up axis (:attr:`colloc.lab.record.LabRecord.up`); forward is the horizontal direction
the feet travel along, found from the markers: the principal horizontal axis of the
markers' velocities, pointing the way the swing phase moves them (swing is fast and short,
stance slow and long, so their velocities along the walking direction are skewed forward,
on a treadmill and overground alike). It may also be given.

Left and right come from the markers' names (the marker set's prefixes) and are checked
against their positions: the right side's markers lie to the right of the left side's,
right being forward x up. A plate without a stated side is put under the foot whose
markers its centre of pressure lies between while it is loaded.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from colloc.data.columns import SIDES
from colloc.lab.exports import LabExport, LabFileError
from colloc.lab.markers import MarkerSet
from colloc.lab.record import LabRecord

#: Vertical force [N] above which a plate counts as loaded for the floor and side checks.
LOADED_FORCE = 50.0
#: How far [m] a loaded plate's centre of pressure may lie beyond its foot's heel and toe
#: markers (skin markers sit off the sole; the pressure moves to the toe's tip at push-off).
FOOT_MARGIN = 0.08

_AXIS_NAMES = {"x": 0, "y": 1, "z": 2}


@dataclass(frozen=True)
class SagittalPlane:
    """Forward and up unit vectors in a record's axes.

    Attributes
    ----------
    forward, up : ndarray, shape (3,)
    how : str
        How forward was found (for the trial's metadata).
    """

    forward: np.ndarray
    up: np.ndarray
    how: str

    @property
    def right(self) -> np.ndarray:
        """Forward x up: the subject's right."""
        return np.cross(self.forward, self.up)


def parse_axis(text: str) -> np.ndarray:
    """``"+x"``, ``"-z"``, ``"x"`` -> a unit vector.

    Parameters
    ----------
    text : str

    Returns
    -------
    ndarray, shape (3,)

    Raises
    ------
    ValueError
        If ``text`` is not an optional sign and one of x, y, z.
    """
    value = text.strip().lower()
    sign = -1.0 if value.startswith("-") else 1.0
    axis = value.lstrip("+-")
    if axis not in _AXIS_NAMES:
        raise ValueError(f"forward: expected an axis such as +x, -x, +z, found {text!r}")
    vector = np.zeros(3)
    vector[_AXIS_NAMES[axis]] = sign
    return vector


def find_plane(record: LabRecord, forward: str | None = None) -> SagittalPlane:
    """Forward and up of ``record`` (forward from the markers unless given).

    Parameters
    ----------
    record : LabRecord
        With markers (unless ``forward`` is given).
    forward : str, optional
        The walking direction as an axis (``"+x"``, ``"-z"``, ...).

    Returns
    -------
    SagittalPlane

    Raises
    ------
    LabFileError
        If ``forward`` is vertical, or the markers are too few to find it.
    """
    up = np.zeros(3)
    up[record.up] = 1.0
    if forward is not None:
        direction = parse_axis(forward)
        if abs(direction @ up) > 0.5:
            raise LabFileError(record.source, [f"forward: {forward!r} is the vertical axis"])
        return SagittalPlane(direction, up, f"given ({forward})")
    horizontal = [k for k in range(3) if k != record.up]
    velocities = []
    for xyz in record.markers.values():
        v = np.diff(xyz[:, horizontal], axis=0) / np.diff(record.time)[:, None]
        velocities.append(v[np.all(np.isfinite(v), axis=1)])
    pooled = np.concatenate(velocities) if velocities else np.empty((0, 2))
    if len(pooled) < 10:
        raise LabFileError(
            record.source, ["forward: too few marker samples to find the walking direction"]
        )
    pooled = pooled - pooled.mean(axis=0)
    _, _, axes = np.linalg.svd(pooled, full_matrices=False)
    along = axes[0]
    if np.sum((pooled @ along) ** 3) < 0:
        along = -along
    direction = np.zeros(3)
    direction[horizontal] = along
    return SagittalPlane(
        direction,
        up,
        "the principal horizontal axis of the markers' velocities, signed by the swing "
        f"phase's forward skew: ({', '.join(f'{c:+.3f}' for c in direction)})",
    )


def sagittal_exports(
    markers: LabRecord | None,
    plates: LabRecord | None,
    marker_set: MarkerSet,
    forward: str | None = None,
) -> tuple[LabExport | None, LabExport | None, dict[str, str], list[str], SagittalPlane]:
    """The planar exports of 3-D records: markers and plates in (forward, up).

    Parameters
    ----------
    markers : LabRecord or None
        The motion capture.
    plates : LabRecord or None
        The force plates (the same record as ``markers`` for a C3D holding both).
    marker_set : MarkerSet
        Names of the landmarks' markers and prefixes, for the side checks.
    forward : str, optional
        The walking direction, if not to be found from the markers.

    Returns
    -------
    markers, plates : LabExport or None
        Markers relative to the floor (when the plates say where it is); each plate's
        ``ForX, ForY`` and ``MomZ = cop_forward ForY`` (the moment about the floor point below
        the origin, so that ``MomZ / ForY`` is the centre of pressure).
    plate_sides : dict
        Plate -> side, as the file stated or as found under the feet.
    notes : list of str
    plane : SagittalPlane

    Raises
    ------
    LabFileError
        Naming every problem: sides swapped against the names, a plate under no foot or
        both plates under one.
    """
    source = markers if markers is not None else plates
    assert source is not None
    plane = find_plane(markers if forward is None and markers is not None else source, forward)
    notes = [f"sagittal plane: forward {plane.how}; up the file's {'xyz'[source.up]} axis"]
    problems: list[str] = []
    floor = 0.0
    plate_export = None
    sides = dict(plates.plate_sides) if plates is not None else {}
    if plates is not None and plates.plates:
        heights = []
        channels = {}
        time = next(iter(plates.plates.values())).time
        for name, plate in plates.plates.items():
            fx, fy = plate.force @ plane.forward, plate.force @ plane.up
            cop = plate.point @ plane.forward
            loaded = (fy > LOADED_FORCE) & np.isfinite(cop)
            heights.append((plate.point @ plane.up)[loaded])
            moment = np.where(np.isfinite(cop), cop * fy, 0.0)
            channels[name] = np.column_stack([fx, fy, moment])
        level = np.concatenate(heights)
        if level.size:
            floor = float(np.median(level))
            if abs(floor) > 1e-6:
                notes.append(
                    f"the floor lies {floor * 1000:+.1f} mm from the origin along up (the plates' "
                    "points of application): marker heights are taken above it"
                )
        plate_export = LabExport(
            time=time, markers={}, plates=channels, source=plates.source,
            # a file of its own keeps its columns on its times; a C3D's are the markers'
            columns=dict(plates.columns) if plates is not markers else {},
        )  # fmt: skip
    marker_export = None
    if markers is not None and markers.markers:
        planar = {
            name: np.column_stack([xyz @ plane.forward, xyz @ plane.up - floor])
            for name, xyz in markers.markers.items()
        }
        marker_export = LabExport(
            time=markers.time, markers=planar, plates={}, columns=dict(markers.columns),
            source=markers.source,
        )  # fmt: skip
        problems += _side_problems(markers, plane, marker_set)
        if plate_export is not None and len(sides) < len(plate_export.plates):
            found, side_problems = plates_under_feet(marker_export, plate_export, marker_set)
            problems += side_problems
            for name, side in found.items():
                sides.setdefault(name, side)
            if found:
                notes.append(
                    f"plates under the feet (centre of pressure between the foot's markers): {found}"
                )
    if problems:
        raise LabFileError("lab record", problems)
    return marker_export, plate_export, sides, notes, plane


def _side_problems(record: LabRecord, plane: SagittalPlane, ms: MarkerSet) -> list[str]:
    """The right side's markers must lie to the right of the left side's."""
    mean = {}
    for side in SIDES:
        names = [n for n in record.markers if n.startswith(ms.prefixes[side])]
        values = [record.markers[n] @ plane.right for n in names]
        finite = [v[np.isfinite(v)] for v in values]
        if any(f.size for f in finite):
            mean[side] = float(np.mean(np.concatenate(finite)))
    if len(mean) == 2 and mean["right"] <= mean["left"]:
        return [
            f"markers: the {ms.prefixes['right']}* markers lie {abs(mean['right'] - mean['left']) * 100:.0f} "
            f"cm to the LEFT of the {ms.prefixes['left']}* markers (right = forward x up): left "
            "and right swapped, or the walking direction is reversed (give it with --forward)"
        ]
    return []


def plates_under_feet(
    markers: LabExport, plates: LabExport, ms: MarkerSet
) -> tuple[dict[str, str], list[str]]:
    """Each plate's foot: the one whose heel-toe span holds its loaded centre of pressure.

    Parameters
    ----------
    markers : LabExport
        Planar markers with each side's heel and toe (else nothing is found).
    plates : LabExport
        Planar plates (``ForX, ForY, MomZ`` with ``MomZ / ForY`` the centre of pressure).
    ms : MarkerSet

    Returns
    -------
    sides : dict
        Plate -> side, for the plates loaded long enough to tell.
    problems : list of str
        A plate under neither foot, or two plates under one.
    """
    span = {}
    for side in SIDES:
        heel, toe = (markers.markers.get(ms.marker(side, lm)) for lm in ("heel", "toe"))
        if heel is None or toe is None:
            return {}, []
        span[side] = (np.minimum(heel[:, 0], toe[:, 0]), np.maximum(heel[:, 0], toe[:, 0]))
    found, problems = {}, []
    for name, channels in plates.plates.items():
        fy = np.interp(markers.time, plates.time, channels[:, 1])
        moment = np.interp(markers.time, plates.time, channels[:, 2])
        loaded = fy > LOADED_FORCE
        if loaded.sum() < 3:
            continue
        cop = moment[loaded] / fy[loaded]
        share = {
            side: float(
                np.mean((cop >= low[loaded] - FOOT_MARGIN) & (cop <= high[loaded] + FOOT_MARGIN))
            )
            for side, (low, high) in span.items()
        }
        best = max(share, key=lambda side: share[side])
        if share[best] < 0.5:
            problems.append(
                f"plate {name}: its centre of pressure lies under neither foot while loaded "
                f"(between heel and toe markers {share['right']:.0%} of the time on the right, "
                f"{share['left']:.0%} on the left): a free torque read as a moment, a plate "
                "origin or axis mix-up, or markers of another trial"
            )
        else:
            found[name] = best
    if len(found) == 2 and len(set(found.values())) == 1:
        problems.append(f"plates: both lie under the {next(iter(found.values()))} foot ({found})")
    return found, problems
