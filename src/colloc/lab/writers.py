"""A planar lab export written in the formats labs use: tab export, TRC + MOT, C3D.

The planar markers and plates of a :class:`colloc.lab.exports.LabExport` (forward, up) are
set in three dimensions as each format's convention has it: OpenSim's X forward, Y up, Z to
the right for TRC and MOT (the right plate ``ground``, the left ``1_ground``, with the
``_grf.xml`` saying so), a Z-up lab with X forward and Y to the left for the C3D (plates
FP1 left and FP2 right, as colloc's default marker set names them). Each side's markers and
plate sit :data:`LATERAL` to its side of the plane; the files then read back, through
:func:`colloc.lab.formats.read_lab_file` and the sagittal projection, to the export itself.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from colloc.data.columns import SIDES
from colloc.lab.exports import LabExport
from colloc.lab.formats.c3d import write_c3d
from colloc.lab.formats.mot import write_grf_mapping, write_mot
from colloc.lab.formats.trc import write_trc
from colloc.lab.markers import DEFAULT_MARKER_SET, MarkerSet
from colloc.lab.record import LabRecord, PlateSeries
from colloc.lab.synthetic import write_lab_export

if TYPE_CHECKING:
    from colloc.lab.synthetic_skin import SkinLab

#: Distance [m] of each side's markers and plate from the sagittal plane.
LATERAL = 0.1

#: The formats :func:`write_lab_files` writes, and the files each makes.
FORMATS: dict[str, tuple[str, ...]] = {
    "tsv": ("lab-export.tsv",),
    "trc": ("lab-export.trc", "lab-export_grf.mot", "lab-export_grf.xml"),
    "c3d": ("lab-export.c3d",),
}

#: OpenSim's plate prefixes for the right and left foot (as its example walk has them).
OPENSIM_PLATES: dict[str, str] = {"right": "ground", "left": "1_ground"}


def write_lab_files(
    export: LabExport,
    folder: str | os.PathLike[str],
    formats: tuple[str, ...] = tuple(FORMATS),
    marker_set: MarkerSet = DEFAULT_MARKER_SET,
) -> dict[str, Path]:
    """Write ``export`` in each of ``formats`` into ``folder``.

    Parameters
    ----------
    export : LabExport
        Planar markers and plates on one time base (e.g.
        :func:`colloc.lab.lab_export_from_record`).
    folder : path-like
        An existing folder.
    formats : tuple of str
        Among :data:`FORMATS`.
    marker_set : MarkerSet
        Which markers and plates belong to which side.

    Returns
    -------
    dict
        File role (``tsv``, ``trc``, ``mot``, ``grf_xml``, ``c3d``) -> path.

    Raises
    ------
    ValueError
        If a format is unknown.
    """
    unknown = [f for f in formats if f not in FORMATS]
    if unknown:
        raise ValueError(f"formats: expected some of {list(FORMATS)}, found {unknown}")
    folder = Path(folder)
    sides = _marker_sides(export, marker_set)
    written: dict[str, Path] = {}
    if "tsv" in formats:
        written["tsv"] = write_lab_export(export, folder / FORMATS["tsv"][0])
    if "trc" in formats:
        trc, mot, xml = (folder / name for name in FORMATS["trc"])
        # OpenSim: X forward, Y up, Z right
        markers = {
            name: _embed(xy, (0, 1), 2, LATERAL * _sign(sides.get(name), +1))
            for name, xy in export.markers.items()
        }
        written["trc"] = write_trc(trc, export.time, markers, units="mm")
        plates = {
            OPENSIM_PLATES[side]: _plate(
                export, marker_set.plates[side], (0, 1), 2, LATERAL * _sign(side, +1)
            )
            for side in SIDES
        }
        written["mot"] = write_mot(mot, plates, _on(export.columns, export.time, export.time))
        written["grf_xml"] = write_grf_mapping(
            xml, {prefix: side for side, prefix in OPENSIM_PLATES.items()}, mot.name
        )
    if "c3d" in formats:
        # a Z-up lab: X forward, Z up, Y left
        markers = {
            name: _embed(xy, (0, 2), 1, LATERAL * _sign(sides.get(name), -1))
            for name, xy in export.markers.items()
        }
        order = sorted(SIDES, key=lambda side: marker_set.plates[side])  # FP1, FP2
        plates = {
            marker_set.plates[side]: _plate(
                export, marker_set.plates[side], (0, 2), 1, LATERAL * _sign(side, -1)
            )
            for side in order
        }
        rate = float(1.0 / np.median(np.diff(export.time)))
        written["c3d"] = write_c3d(
            folder / FORMATS["c3d"][0], export.time, markers, plates, rate,
            columns=dict(export.columns),
        )  # fmt: skip
    return written


def _marker_sides(export: LabExport, ms: MarkerSet) -> dict[str, str]:
    return {
        name: side
        for name in export.markers
        for side in SIDES
        if name.startswith(ms.prefixes[side])
    }


def _sign(side: str | None, right: float) -> float:
    """``right`` for the right side, its opposite for the left, 0 for neither."""
    return {"right": right, "left": -right}.get(side or "", 0.0)


def _embed(
    planar: np.ndarray, axes: tuple[int, int], lateral_axis: int, lateral: float
) -> np.ndarray:
    """(forward, up) into three axes, the lateral one at a constant."""
    out = np.full((len(planar), 3), lateral)
    out[:, axes[0]] = planar[:, 0]
    out[:, axes[1]] = planar[:, 1]
    return out


def _plate(
    export: LabExport, name: str, axes: tuple[int, int], lateral_axis: int, lateral: float
) -> PlateSeries:
    """A planar plate (``ForX, ForY, MomZ`` about the floor below the origin) in 3-D."""
    fx, fy, mz = export.plates[name].T
    force = np.zeros((len(fx), 3))
    force[:, axes[0]], force[:, axes[1]] = fx, fy
    point = np.zeros((len(fx), 3))
    with np.errstate(divide="ignore", invalid="ignore"):
        point[:, axes[0]] = np.where(fy != 0.0, mz / fy, 0.0)
    point[:, lateral_axis] = lateral
    return PlateSeries(export.time, force, point, np.zeros((len(fx), 3)))


#: The files :func:`write_skin_lab` writes per format: the walk's, then the static trial's.
SKIN_FILES: dict[str, tuple[str, ...]] = {
    "tsv": ("lab-skin.tsv", "lab-skin-static.tsv"),
    "trc": ("lab-skin.trc", "lab-skin_grf.mot", "lab-skin_grf.xml", "lab-skin-static.trc"),
    "c3d": ("lab-skin.c3d", "lab-skin-static.c3d"),
}


def write_skin_lab(
    lab: SkinLab,
    folder: str | os.PathLike[str],
    formats: tuple[str, ...] = tuple(SKIN_FILES),
    marker_set: MarkerSet = DEFAULT_MARKER_SET,
) -> dict[str, Path]:
    """Write a skin-marker walk and its static trial in each of ``formats``.

    The TSV holds ``NAME.PosX/PosY/PosZ`` (forward, up, right) and the plates at the
    markers' times (a tab export has one rate); TRC + MOT and C3D hold the plates at their
    own rate (MOT rows; C3D analogs). The static trials hold markers only.

    Parameters
    ----------
    lab : SkinLab
        :func:`colloc.lab.synthetic_skin.skin_lab_from_record`.
    folder : path-like
        An existing folder.
    formats : tuple of str
        Among :data:`SKIN_FILES`.
    marker_set : MarkerSet
        Which plate is under which foot.

    Returns
    -------
    dict
        File role (``tsv``, ``static_tsv``, ``trc``, ``mot``, ``grf_xml``, ``static_trc``,
        ``c3d``, ``static_c3d``) -> path.

    Raises
    ------
    ValueError
        If a format is unknown, or the plates' rate is not a whole multiple of the markers'.
    """
    unknown = [f for f in formats if f not in SKIN_FILES]
    if unknown:
        raise ValueError(f"formats: expected some of {list(SKIN_FILES)}, found {unknown}")
    folder = Path(folder)
    walk, static = lab.walk, lab.static
    rate = 1.0 / float(np.median(np.diff(walk.time)))
    plate_rate = next(iter(walk.plates.values())).sample_rate
    per_frame = int(round(plate_rate / rate))
    if abs(plate_rate / rate - per_frame) > 1e-6 or per_frame < 1:
        raise ValueError(
            f"lab: the plates' rate {plate_rate:g} Hz is not a whole multiple of the markers' "
            f"{rate:g} Hz"
        )
    written: dict[str, Path] = {}
    if "tsv" in formats:
        walk_tsv, static_tsv = (folder / name for name in SKIN_FILES["tsv"])
        written["tsv"] = _write_tsv(walk, walk_tsv, per_frame)
        written["static_tsv"] = _write_tsv(static, static_tsv, 1)
    if "trc" in formats:
        trc, mot, xml, static_trc = (folder / name for name in SKIN_FILES["trc"])
        written["trc"] = write_trc(trc, walk.time, walk.markers, units="mm")
        sides = {side: marker_set.plates[side] for side in SIDES}
        plate_time = next(iter(walk.plates.values())).time
        written["mot"] = write_mot(
            mot,
            {OPENSIM_PLATES[side]: walk.plates[name] for side, name in sides.items()},
            _on(walk.columns, walk.time, plate_time),
        )
        written["grf_xml"] = write_grf_mapping(
            xml, {prefix: side for side, prefix in OPENSIM_PLATES.items()}, mot.name
        )
        written["static_trc"] = write_trc(static_trc, static.time, static.markers, units="mm")
    if "c3d" in formats:
        walk_c3d, static_c3d = (folder / name for name in SKIN_FILES["c3d"])
        order = sorted(SIDES, key=lambda side: marker_set.plates[side])  # FP1, FP2
        plates = {
            marker_set.plates[side]: _z_up_plate(walk.plates[marker_set.plates[side]])
            for side in order
        }
        written["c3d"] = write_c3d(
            walk_c3d, walk.time, _z_up(walk.markers), plates, plate_rate,
            columns=dict(walk.columns),
        )  # fmt: skip
        written["static_c3d"] = write_c3d(static_c3d, static.time, _z_up(static.markers), {}, rate)
    return written


def _on(columns: dict[str, np.ndarray], time: np.ndarray, at: np.ndarray) -> dict[str, np.ndarray]:
    """Signals sampled at ``time`` (the belt speed), linearly at the times ``at``."""
    return {name: np.interp(at, time, values) for name, values in columns.items()}


def _z_up(markers: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """(forward, up, right) -> a Z-up lab's (forward, left, up)."""
    return {name: xyz[:, [0, 2, 1]] * np.array([1.0, -1.0, 1.0]) for name, xyz in markers.items()}


def _z_up_plate(plate: PlateSeries) -> PlateSeries:
    flip = np.array([1.0, -1.0, 1.0])
    return PlateSeries(
        plate.time,
        plate.force[:, [0, 2, 1]] * flip,
        plate.point[:, [0, 2, 1]] * flip,
        plate.free_torque[:, [0, 2, 1]] * flip,
    )


def _write_tsv(record: LabRecord, path: Path, per_frame: int) -> Path:
    """A 3-D record as a tab export: markers in (forward, up, right), each plate's forward
    and vertical force and moment about the origin at the markers' times."""
    plates = {}
    for name, plate in record.plates.items():
        force = plate.force[::per_frame][: record.time.size]
        point = plate.point[::per_frame][: record.time.size]
        moment = np.nan_to_num(point[:, 0] * force[:, 1] - point[:, 1] * force[:, 0])
        plates[name] = np.column_stack([force[:, 0], force[:, 1], moment])
    export = LabExport(
        time=record.time,
        markers={name: xyz[:, :2] for name, xyz in record.markers.items()},
        plates=plates,
        columns=dict(record.columns),
        source=record.source,
        lateral={name: xyz[:, 2] for name, xyz in record.markers.items()},
    )
    return write_lab_export(export, path)
