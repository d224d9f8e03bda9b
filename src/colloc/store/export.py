"""Write a stored run to plain files (CSV + JSON, or NPZ + JSON).

Every file is first written under a temporary name in the target directory and renamed only
when all files of the export are complete, so a failure never leaves a truncated file or a
half export behind.
"""

from __future__ import annotations

import json
import os
import secrets
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

import numpy as np
import pandas as pd

from colloc.store.errors import ExportError
from colloc.store.record import ARRAY_NAME_PATTERN, RESERVED_ARRAY_NAMES, RunRecord

#: dtype kinds a CSV cell can hold and read back exactly.
_CSV_KINDS = frozenset("biufUS")

Writer = Callable[[IO[bytes]], None]


def export_record(
    record: RunRecord, directory: str | Path, format: str = "csv", overwrite: bool = False
) -> list[Path]:
    """Write ``record`` to files in ``directory``.

    Parameters
    ----------
    record : RunRecord
        The run to write.
    directory : str or Path
        Target directory, created if missing.
    format : str, optional
        One of :data:`EXPORTERS` (``"csv"`` or ``"npz"``).
    overwrite : bool, optional
        Replace files of the same names already in ``directory``; by default their
        presence is an error and nothing is written.

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    ExportError
        If ``format`` is unknown, the record cannot be written in it, ``directory`` is
        not usable, or (without ``overwrite``) holds files of the same names. Nothing is
        written then.
    """
    exporter = EXPORTERS.get(format) if isinstance(format, str) else None
    if exporter is None:
        raise ExportError(f"format: expected one of {sorted(EXPORTERS)}, found {format!r}")
    # names become file names: checked here too, not only when stored (a crafted database)
    unsafe = [
        name
        for name in record.arrays
        if not isinstance(name, str)
        or not ARRAY_NAME_PATTERN.match(name)
        or name in RESERVED_ARRAY_NAMES
    ]
    if unsafe:
        raise ExportError(
            f"record: array names {unsafe!r} are not safe file names "
            f"({ARRAY_NAME_PATTERN.pattern}); nothing was written"
        )
    files = exporter(record)
    target = Path(directory)
    if target.exists() and not target.is_dir():
        raise ExportError(f"directory: expected a directory, found a file at {str(target)!r}")
    present = sorted(name for name in files if (target / name).exists())
    if present and not overwrite:
        raise ExportError(
            f"directory: {str(target)!r} already holds {present}; pass overwrite=True "
            "(colloc runs export --overwrite) to replace them"
        )
    try:
        target.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise ExportError(f"directory: cannot create {str(target)!r} ({error})") from error
    return _write_all(target, files)


def _write_all(directory: Path, files: dict[str, Writer]) -> list[Path]:
    staged: list[tuple[Path, Path]] = []
    try:
        for name, write in files.items():
            # Not tempfile.mkstemp: its 0600 mode would survive the rename.
            temporary = directory / f".{name}.{secrets.token_hex(8)}.part"
            with open(temporary, "xb") as stream:
                staged.append((temporary, directory / name))
                write(stream)
    except BaseException:
        for temporary, _ in staged:
            temporary.unlink(missing_ok=True)
        raise
    for temporary, final in staged:
        os.replace(temporary, final)
    return [final for _, final in staged]


def _metadata(record: RunRecord) -> dict[str, Any]:
    return {
        "run_id": record.run_id,
        "created": record.created.isoformat() if record.created is not None else None,
        "kind": record.kind,
        "settings": record.settings,
        "versions": record.versions,
        "statistics": record.statistics,
        "ipopt_log": record.ipopt_log,
    }


def _json_writer(document: dict[str, Any]) -> Writer:
    text = json.dumps(document, indent=2, sort_keys=True, allow_nan=False) + "\n"

    def write(stream: IO[bytes]) -> None:
        stream.write(text.encode("utf-8"))

    return write


def _csv_columns(name: str, array: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """A table of ``array``: one row per index of its first axis, one column per index of
    the others (``K_3_11`` is ``K[:, 3, 11]``); ``metadata.json`` keeps the shape."""
    if array.ndim < 2:
        return array.reshape(-1, 1), [name]
    rest = array.shape[1:]
    columns = [f"{name}_{'_'.join(map(str, index))}" for index in np.ndindex(*rest)]
    return array.reshape(array.shape[0], -1), columns


def _frame_writer(frame: pd.DataFrame) -> Writer:
    def write(stream: IO[bytes]) -> None:
        stream.write(frame.to_csv(index=False, lineterminator="\n").encode("utf-8"))

    return write


def csv_files(record: RunRecord) -> dict[str, Writer]:
    """Plan a CSV export: one file per array, ``parameters.csv`` and ``metadata.json``.

    Parameters
    ----------
    record : RunRecord
        The run to export.

    Returns
    -------
    dict of str to callable
        File name to a function writing the file's bytes to a binary stream.

    Raises
    ------
    ExportError
        Listing every array that CSV cannot hold (complex or other non-plain dtypes); use
        ``format="npz"`` for those. Arrays of more than two dimensions are written one row
        per index of their first axis (the shape is in ``metadata.json``).
    """
    problems = [
        f"arrays[{name!r}]: CSV holds numeric, bool or string values, found dtype "
        f"{array.dtype} (shape {array.shape})"
        for name, array in record.arrays.items()
        if array.dtype.kind not in _CSV_KINDS
    ]
    if problems:
        raise ExportError(
            "format: 'csv' cannot hold this run; use 'npz'.\n  - " + "\n  - ".join(problems)
        )
    files: dict[str, Writer] = {}
    layout = {}
    for name, array in record.arrays.items():
        table, columns = _csv_columns(name, array)
        files[f"{name}.csv"] = _frame_writer(pd.DataFrame(table, columns=columns))
        layout[name] = {
            "file": f"{name}.csv",
            "dtype": array.dtype.str,
            "shape": list(array.shape),
            "columns": columns,
        }
    files["parameters.csv"] = _frame_writer(record.parameters_frame())
    files["metadata.json"] = _json_writer({**_metadata(record), "arrays": layout})
    return files


def npz_files(record: RunRecord) -> dict[str, Writer]:
    """Plan an NPZ export: ``<run_id>.npz`` with every array and ``<run_id>.json``.

    Parameters
    ----------
    record : RunRecord
        The run to export.

    Returns
    -------
    dict of str to callable
        File name to a function writing the file's bytes to a binary stream.
    """
    arrays = dict(record.arrays)

    def write_npz(stream: IO[bytes]) -> None:
        # Written entry by entry rather than through numpy.savez(**arrays), whose own keyword
        # names ("file", "allow_pickle") would clash with arrays of those names.
        with zipfile.ZipFile(stream, "w", compression=zipfile.ZIP_DEFLATED) as archive:
            for name, array in arrays.items():
                with archive.open(f"{name}.npy", "w", force_zip64=True) as entry:
                    np.lib.format.write_array(entry, array, allow_pickle=False)

    document = _metadata(record)
    document["parameters"] = [
        {"name": p.name, "known": p.known, "identified": p.identified, "std_error": p.std_error}
        for p in record.parameters
    ]
    document["arrays"] = {
        name: {"dtype": array.dtype.str, "shape": list(array.shape)}
        for name, array in arrays.items()
    }
    stem = _safe_stem(record.run_id)
    return {f"{stem}.npz": write_npz, f"{stem}.json": _json_writer(document)}


def _safe_stem(run_id: str) -> str:
    # Run ids are caller-given; keep only characters that are harmless in a file name.
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in run_id).lstrip(".") or "run"


#: Export format name -> planner of the files to write.
EXPORTERS: dict[str, Callable[[RunRecord], dict[str, Writer]]] = {
    "csv": csv_files,
    "npz": npz_files,
}
