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

import numpy as np

from colloc.data.columns import SIDES
from colloc.lab.exports import LabExport
from colloc.lab.formats.c3d import write_c3d
from colloc.lab.formats.mot import write_grf_mapping, write_mot
from colloc.lab.formats.trc import write_trc
from colloc.lab.markers import DEFAULT_MARKER_SET, MarkerSet
from colloc.lab.record import PlateSeries
from colloc.lab.synthetic import write_lab_export

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
        written["mot"] = write_mot(mot, plates)
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
        written["c3d"] = write_c3d(folder / FORMATS["c3d"][0], export.time, markers, plates, rate)
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
