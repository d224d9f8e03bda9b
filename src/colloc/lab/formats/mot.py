"""OpenSim's MOT/STO ground-reaction files (and the ``_grf.xml`` saying which foot each
plate carries): read into a :class:`colloc.lab.record.LabRecord`, and write.

A MOT or STO file has header lines up to ``endheader``, a line of column names and one row
per sample. A plate is the set of columns ``<P>force_vx/vy/vz`` (the floor's force on the
foot, N), ``<P>force_px/py/pz`` (its point of application, m) and ``<P>torque_x/y/z`` (the
free torque, N m) for a prefix ``<P>`` such as ``ground_`` or ``1_ground_``. OpenSim's axes are
Y up. Any other column (a treadmill's belt speed, say) is kept by its name. The
``ExternalLoads`` XML beside it names, for each ``force_identifier``, the body the
force is ``applied_to_body``: ``calcn_r`` is the right foot, ``calcn_l`` the left.
"""

from __future__ import annotations

import os
import re
import xml.etree.ElementTree as ElementTree
from itertools import islice
from pathlib import Path

import numpy as np

from colloc.lab.exports import LabFileError
from colloc.lab.record import LabRecord, PlateSeries, regular_time

#: The line that ends a MOT/STO header.
END_HEADER = "endheader"

_FORCE = re.compile(r"^(?P<prefix>.*)force_v(?P<axis>[xyz])$")
_AXES = "xyz"


def is_mot(path: Path) -> bool:
    """Whether ``path`` holds a MOT/STO header (``endheader`` within its first 50 lines)."""
    try:
        with open(path, encoding="utf-8-sig", errors="replace") as stream:
            return any(line.strip().lower() == END_HEADER for line in islice(stream, 50))
    except OSError:
        return False


def read_mot(
    path: str | os.PathLike[str], mapping: str | os.PathLike[str] | None = None
) -> LabRecord:
    """Read the plates of a MOT/STO file in SI units.

    Parameters
    ----------
    path : path-like
    mapping : path-like, optional
        OpenSim's ``ExternalLoads`` XML (the ``_grf.xml``); its ``applied_to_body`` names
        the side of each plate. Without it the sides are left to the pipeline, which puts
        each plate under the foot whose markers its centre of pressure lies below.

    Returns
    -------
    LabRecord
        No markers; one :class:`PlateSeries` per prefix (named by it without the trailing
        ``_``, e.g. ``ground`` and ``1_ground``), Y up; the file's other columns in
        ``columns``, on the plates' times.

    Raises
    ------
    LabFileError
        Naming what is wrong: no header end, no plate columns, a plate lacking a column,
        text in a number field, a mapping that cannot be read or names no plate here.
    """
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8-sig").splitlines()
    except (OSError, UnicodeDecodeError) as error:
        raise LabFileError(str(path), [f"cannot read it as text ({error})"]) from error
    ends = [k for k, line in enumerate(lines) if line.strip().lower() == END_HEADER]
    if not ends:
        raise LabFileError(str(path), [f"not a MOT/STO file: no '{END_HEADER}' line"])
    header = ends[0] + 1
    while header < len(lines) and not lines[header].strip():
        header += 1
    if header >= len(lines):
        raise LabFileError(str(path), ["no column names after the header"])
    names = lines[header].split()
    try:
        data = np.array(
            [[float(v) for v in line.split()] for line in lines[header + 1 :] if line.strip()]
        )
    except ValueError as error:
        raise LabFileError(str(path), [f"a field is not a number ({error})"]) from error
    problems = []
    if data.ndim != 2 or data.shape[0] < 2 or data.shape[1] != len(names):
        problems.append(
            f"expected rows of {len(names)} numbers under the column names, found shape "
            f"{data.shape}"
        )
    column = {name: k for k, name in enumerate(names)}
    if "time" not in column:
        problems.append(f"no 'time' column (found {names[:5]})")
    prefixes = sorted({m["prefix"] for name in names if (m := _FORCE.match(name))})
    if not prefixes:
        problems.append("no plate columns <P>force_vx/vy/vz")
    for prefix in prefixes:
        wanted = [f"{prefix}force_{k}{a}" for k in "vp" for a in _AXES]
        lacking = [w for w in wanted if w not in column]
        if lacking:
            problems.append(f"plate {prefix.rstrip('_')}: no column {', '.join(lacking)}")
    if problems:
        raise LabFileError(str(path), problems)
    time, notes = regular_time(data[:, column["time"]], None, path.name)

    def block(names: list[str]) -> np.ndarray:
        return np.column_stack(
            [data[:, column[n]] if n in column else np.zeros(len(data)) for n in names]
        )

    plates = {}
    used = {"time"}
    for prefix in prefixes:
        parts = [[f"{prefix}force_v{a}" for a in _AXES], [f"{prefix}force_p{a}" for a in _AXES]]
        torque_prefix = prefix[: -len("force_")] if prefix.endswith("force_") else prefix
        parts.append([f"{torque_prefix}torque_{a}" for a in _AXES])
        used.update(name for part in parts for name in part)
        plates[prefix.rstrip("_")] = PlateSeries(time, *(block(part) for part in parts))
    others = {name: data[:, k].copy() for name, k in column.items() if name not in used}
    sides = _sides(Path(mapping), plates) if mapping is not None else {}
    if mapping is not None:
        notes.append(f"{path.name}: plate sides from {Path(mapping).name}: {sides}")
    return LabRecord(
        time=np.empty(0), markers={}, plates=plates, up=1, source=str(path), notes=notes,
        plate_sides=sides, columns=others,
    )  # fmt: skip


def _sides(mapping: Path, plates: dict[str, PlateSeries]) -> dict[str, str]:
    """Plate name -> side from an ExternalLoads XML."""
    try:
        root = ElementTree.parse(mapping).getroot()
    except (OSError, ElementTree.ParseError) as error:
        raise LabFileError(str(mapping), [f"cannot read it as XML ({error})"]) from error
    sides = {}
    for force in root.iter("ExternalForce"):
        body = (force.findtext("applied_to_body") or "").strip()
        identifier = (force.findtext("force_identifier") or "").strip()
        name = identifier[: -len("force_v")].rstrip("_") if identifier.endswith("force_v") else ""
        side = {"r": "right", "l": "left"}.get(body.rsplit("_", 1)[-1].lower())
        if name in plates and side is not None:
            sides[name] = side
    if sorted(sides.values()) != ["left", "right"]:
        raise LabFileError(
            str(mapping),
            [
                f"expected one plate for each foot (applied_to_body ..._r and ..._l naming the "
                f"plates {sorted(plates)}), found {sides or 'none'}"
            ],
        )
    return sides


def write_mot(
    path: str | os.PathLike[str],
    plates: dict[str, PlateSeries],
    extra: dict[str, np.ndarray] | None = None,
) -> Path:
    """Write plates as an OpenSim ground-reaction MOT file (Y up), whole or not at all.

    Parameters
    ----------
    path : path-like
    plates : dict
        Prefix (e.g. ``ground``, ``1_ground``) -> :class:`PlateSeries`, all on one time base.
    extra : dict, optional
        More columns on the plates' times (e.g. the belt speed), after the plates'.

    Returns
    -------
    Path
    """
    path = Path(path)
    first = next(iter(plates.values()))
    names, columns = ["time"], [first.time]
    for prefix, plate in plates.items():
        for kind, values in (("force_v", plate.force), ("force_p", plate.point)):
            for k, axis in enumerate(_AXES):
                names.append(f"{prefix}_{kind}{axis}")
                columns.append(np.nan_to_num(values[:, k]))
    for prefix, plate in plates.items():
        for k, axis in enumerate(_AXES):
            names.append(f"{prefix}_torque_{axis}")
            columns.append(plate.free_torque[:, k])
    for name, values in (extra or {}).items():
        names.append(name)
        columns.append(np.asarray(values, dtype=float))
    data = np.column_stack(columns)
    header = [
        path.name,
        "version=1",
        f"nRows={len(data)}",
        f"nColumns={len(names)}",
        "inDegrees=yes",
        END_HEADER,
        "\t".join(names),
    ]
    rows = ["\t".join(f"{v:.12g}" for v in row) for row in data]
    partial = path.with_name(f".{path.name}.part")
    partial.write_text("\n".join(header + rows) + "\n", encoding="utf-8")
    partial.replace(path)
    return path


def write_grf_mapping(path: str | os.PathLike[str], sides: dict[str, str], datafile: str) -> Path:
    """Write the ``ExternalLoads`` XML naming each plate's foot (``calcn_r``/``calcn_l``).

    Parameters
    ----------
    path : path-like
    sides : dict
        Plate prefix -> ``right``/``left``.
    datafile : str
        The MOT file it describes.

    Returns
    -------
    Path
    """
    root = ElementTree.Element("OpenSimDocument", Version="40000")
    loads = ElementTree.SubElement(root, "ExternalLoads", name="externalloads")
    objects = ElementTree.SubElement(loads, "objects")
    for prefix, side in sides.items():
        force = ElementTree.SubElement(objects, "ExternalForce", name=side)
        for tag, text in (
            ("applied_to_body", f"calcn_{side[0]}"),
            ("force_expressed_in_body", "ground"),
            ("point_expressed_in_body", "ground"),
            ("force_identifier", f"{prefix}_force_v"),
            ("point_identifier", f"{prefix}_force_p"),
            ("torque_identifier", f"{prefix}_torque_"),
        ):
            ElementTree.SubElement(force, tag).text = text
    ElementTree.SubElement(loads, "datafile").text = datafile
    path = Path(path)
    ElementTree.ElementTree(root).write(path, encoding="UTF-8", xml_declaration=True)
    return path
