"""OpenSim's TRC marker files: read into a :class:`colloc.lab.record.LabRecord`, and write.

A TRC file has a first line ``PathFileType 4 (X/Y/Z) name``, a line of header keys and one
of their values (``DataRate``, ``NumFrames``, ``NumMarkers``, ``Units``, ...), a line
``Frame# Time NAME1 <tab> <tab> NAME2 ...`` with each marker's name over its three columns,
a line of coordinate labels ``X1 Y1 Z1 ...``, then one row per frame. An unseen marker has
empty fields. OpenSim's axes are Y up (X forward, Z to the right in its examples).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from colloc.lab.exports import LabFileError
from colloc.lab.record import LENGTH_UNITS, LabRecord, regular_time

#: First word of a TRC file.
SIGNATURE = "PathFileType"

_HEADER_LINES = 5


def read_trc(path: str | os.PathLike[str]) -> LabRecord:
    """Read a TRC marker file in SI units.

    Parameters
    ----------
    path : path-like

    Returns
    -------
    LabRecord
        Markers in metres (converted from the file's ``Units``, said in ``notes``), Y up,
        time stamps of the stated ``DataRate`` (rounded stamps accepted with a note).

    Raises
    ------
    LabFileError
        Naming what is wrong: not a TRC file, unknown units, a marker name without its three
        columns, rows of the wrong length, text in a number field.
    """
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8-sig").splitlines()
    except (OSError, UnicodeDecodeError) as error:
        raise LabFileError(str(path), [f"cannot read it as text ({error})"]) from error
    if len(lines) < _HEADER_LINES or not lines[0].startswith(SIGNATURE):
        raise LabFileError(
            str(path), [f"not a TRC file: its first line does not start {SIGNATURE}"]
        )
    keys = lines[1].split("\t")
    values = lines[2].split("\t")
    header = {k.strip(): v.strip() for k, v in zip(keys, values, strict=False) if k.strip()}
    problems = []
    units = header.get("Units", "")
    if units not in LENGTH_UNITS:
        problems.append(f"Units: expected one of {list(LENGTH_UNITS)}, found {units!r}")
    try:
        rate = float(header.get("DataRate", "nan"))
    except ValueError:
        rate = float("nan")
    if not (np.isfinite(rate) and rate > 0):
        problems.append(
            f"DataRate: expected a positive rate in Hz, found {header.get('DataRate')!r}"
        )
    names_row = lines[3].split("\t")
    if len(names_row) < 2 or names_row[0].strip() != "Frame#":
        problems.append("line 4: expected 'Frame#', 'Time' and the marker names")
    names = [(k, n.strip()) for k, n in enumerate(names_row) if k >= 2 and n.strip()]
    for index, (column, name) in enumerate(names):
        following = names[index + 1][0] if index + 1 < len(names) else column + 3
        if following - column != 3:
            problems.append(
                f"marker {name}: expected three columns (X, Y, Z), found {following - column}"
            )
    if problems:
        raise LabFileError(str(path), problems)
    width = 2 + 3 * len(names)
    rows = []
    for number, line in enumerate(lines[_HEADER_LINES:], start=_HEADER_LINES + 1):
        if not line.strip():
            continue
        fields = line.split("\t")
        fields += [""] * (width - len(fields))
        if len(fields) > width and any(f.strip() for f in fields[width:]):
            problems.append(f"line {number}: {len(fields)} fields, expected {width}")
            continue
        try:
            rows.append([float(f) if f.strip() else np.nan for f in fields[:width]])
        except ValueError:
            problems.append(f"line {number}: a field is not a number")
        if len(problems) > 5:
            break
    if not rows:
        problems.append("no data rows")
    if problems:
        raise LabFileError(str(path), problems)
    data = np.asarray(rows)
    scale = LENGTH_UNITS[units]
    markers = {name: data[:, 2 + 3 * k : 5 + 3 * k] * scale for k, (_, name) in enumerate(names)}
    time, notes = regular_time(data[:, 1], rate, path.name)
    if scale != 1.0:
        notes.insert(0, f"{path.name}: markers in {units}, converted to m")
    return LabRecord(time=time, markers=markers, plates={}, up=1, source=str(path), notes=notes)


def write_trc(
    path: str | os.PathLike[str],
    time: np.ndarray,
    markers: dict[str, np.ndarray],
    units: str = "mm",
) -> Path:
    """Write markers as a TRC file (Y up), whole or not at all.

    Parameters
    ----------
    path : path-like
    time : ndarray, shape (N,)
        [s], of a fixed rate.
    markers : dict
        Name -> array (N, 3) [m]; NaN samples are written as empty fields.
    units : str
        The file's length unit (``mm``, ``cm`` or ``m``).

    Returns
    -------
    Path
    """
    if units not in LENGTH_UNITS:
        raise ValueError(f"units: expected one of {list(LENGTH_UNITS)}, found {units!r}")
    path = Path(path)
    time = np.asarray(time, float)
    rate = 1.0 / float(np.median(np.diff(time)))
    names = list(markers)
    scale = 1.0 / LENGTH_UNITS[units]
    header = [
        f"{SIGNATURE}\t4\t(X/Y/Z)\t{path.name}",
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame"
        "\tOrigNumFrames",
        f"{rate:.6g}\t{rate:.6g}\t{time.size}\t{len(names)}\t{units}\t{rate:.6g}\t1\t{time.size}",
        "Frame#\tTime\t" + "".join(f"{name}\t\t\t" for name in names),
        "\t\t" + "".join(f"X{k}\tY{k}\tZ{k}\t" for k in range(1, len(names) + 1)),
        "",
    ]
    body = []
    for i, t in enumerate(time):
        fields = [str(i + 1), f"{t:.6f}"]
        for name in names:
            fields += ["" if np.isnan(v) else f"{v * scale:.6f}" for v in markers[name][i]]
        body.append("\t".join(fields))
    partial = path.with_name(f".{path.name}.part")
    partial.write_text("\n".join(header + body) + "\n", encoding="utf-8")
    partial.replace(path)
    return path
