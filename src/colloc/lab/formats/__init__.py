"""A lab's files as they come: one reader that picks the format by content and suffix.

=========================  ===========================================  ====================
format                     what it holds                                module
=========================  ===========================================  ====================
C3D                        markers, analogs, force platforms (ezc3d)    :mod:`.c3d`
OpenSim TRC                markers (units and rate in the header)       :mod:`.trc`
OpenSim MOT / STO          ground reactions (force, point, torque)      :mod:`.mot`
tab or comma export        planar ``NAME.PosX``, ``FP.ForX`` columns    :mod:`colloc.lab.exports`
=========================  ===========================================  ====================

The content decides (a C3D's parameter key, TRC's ``PathFileType``, a MOT's ``endheader``);
the suffix only names what was expected, so a file whose suffix and content disagree is read
by its content with a note.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path

from colloc.lab.exports import LabExport, LabFileError, read_lab_export
from colloc.lab.formats.c3d import is_c3d, read_c3d
from colloc.lab.formats.mot import is_mot, read_mot
from colloc.lab.formats.trc import SIGNATURE as TRC_SIGNATURE
from colloc.lab.formats.trc import read_trc
from colloc.lab.record import LabRecord

#: Suffix -> the format it names.
SUFFIXES: dict[str, str] = {".c3d": "C3D", ".trc": "TRC", ".mot": "MOT", ".sto": "MOT"}


def _is_trc(path: Path) -> bool:
    try:
        with open(path, encoding="utf-8-sig", errors="replace") as stream:
            return stream.readline().startswith(TRC_SIGNATURE)
    except OSError:
        return False


#: Content tests, in the order they are tried.
_DETECTORS: tuple[tuple[str, Callable[[Path], bool]], ...] = (
    ("C3D", is_c3d),
    ("TRC", _is_trc),
    ("MOT", is_mot),
)


def lab_file_format(path: str | os.PathLike[str]) -> str:
    """``"C3D"``, ``"TRC"``, ``"MOT"`` or ``"export"`` (a tab or comma export), by content.

    Parameters
    ----------
    path : path-like

    Returns
    -------
    str
    """
    path = Path(path)
    return next((name for name, test in _DETECTORS if test(path)), "export")


def read_lab_file(
    path: str | os.PathLike[str],
    *,
    names: Sequence[str] | None = None,
    zeros_are_missing: bool = True,
    mapping: str | os.PathLike[str] | None = None,
) -> LabExport | LabRecord:
    """Read any lab file colloc knows.

    Parameters
    ----------
    path : path-like
    names : sequence of str, optional
        Column names of a header-less tab export.
    zeros_are_missing : bool
        Tab exports: a marker sample at exactly 0, 0 is missing.
    mapping : path-like, optional
        MOT/STO: OpenSim's ``_grf.xml`` naming each plate's foot.

    Returns
    -------
    LabExport or LabRecord
        A tab export is planar already (:class:`LabExport`); the other formats are 3-D
        (:class:`LabRecord`, made planar by :func:`colloc.lab.sagittal.sagittal_exports`).

    Raises
    ------
    LabFileError
        If the file is missing or its reader names problems.
    """
    path = Path(path)
    if not path.is_file():
        raise LabFileError(str(path), ["file not found"])
    found = lab_file_format(path)
    expected = SUFFIXES.get(path.suffix.lower())
    readers: dict[str, Callable[[], LabExport | LabRecord]] = {
        "C3D": lambda: read_c3d(path),
        "TRC": lambda: read_trc(path),
        "MOT": lambda: read_mot(path, mapping),
        "export": lambda: read_lab_export(path, names=names, zeros_are_missing=zeros_are_missing),
    }
    if expected is not None and expected != found:
        if found == "export":
            return readers[expected]()  # its reader names what is wrong
        record = readers[found]()
        if isinstance(record, LabRecord):
            record.notes.append(f"{path.name}: read as {found} (its content), not {expected}")
        return record
    return readers[found]()


__all__ = ["SUFFIXES", "lab_file_format", "read_lab_file"]
