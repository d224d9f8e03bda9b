"""The record of one run, and the byte form of its arrays."""

from __future__ import annotations

import io
import json
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any

import numpy as np
import pandas as pd

from colloc.store.errors import RecordError
from colloc.store.ids import to_json_value

#: Array names become file names on export, so they are restricted to a safe alphabet.
ARRAY_NAME_PATTERN = re.compile(r"^[A-Za-z_][A-Za-z0-9_.\-]{0,127}$")
#: File stems used by the CSV export for things other than arrays.
RESERVED_ARRAY_NAMES = frozenset({"parameters", "metadata"})


@dataclass(frozen=True)
class ParameterRow:
    """One row of a run's parameter table.

    Parameters
    ----------
    name : str
        Parameter name, e.g. ``"k_01"``.
    known : float or None
        The true value when it is known (simulated data), else ``None``.
    identified : float or None
        The identified value, ``None`` if the run did not produce one.
    std_error : float or None
        Standard error of the identified value, ``None`` if not computed.

    Notes
    -----
    NaN means "missing" here and is stored as ``None`` (SQL databases turn NaN into NULL
    anyway), so a row always reads back equal to how it was made.
    """

    name: str
    known: float | None = None
    identified: float | None = None
    std_error: float | None = None

    def __post_init__(self) -> None:
        for attribute in ("known", "identified", "std_error"):
            object.__setattr__(self, attribute, _optional_float(getattr(self, attribute)))


def _optional_float(value: Any) -> float | None:
    if value is None:
        return None
    number = float(value)
    return None if math.isnan(number) else number


@dataclass(eq=False)
class RunRecord:
    """Everything stored about one run.

    Parameters
    ----------
    run_id : str
        Caller-chosen id, normally :func:`colloc.store.ids.run_id_for` of the settings,
        data digest and versions.
    kind : str
        What the run is, e.g. ``"pendulum"``.
    settings : dict
        JSON-like settings that determine the run.
    versions : dict
        Package versions (see :func:`colloc.store.ids.package_versions`).
    statistics : dict, optional
        Solver statistics (iterations, timings, status, objective, ...), JSON-like.
    ipopt_log : str, optional
        The IPOPT output of the solve.
    parameters : list of ParameterRow, optional
        Known and identified parameters with standard errors, in display order.
    arrays : dict of str to numpy.ndarray, optional
        Named arrays (measurements, identified trajectories, force, times, ...). Names must
        match ``[A-Za-z_][A-Za-z0-9_.-]*`` and not be ``"parameters"`` or ``"metadata"``.
    created : datetime or None, optional
        Creation time; ``None`` means "now" when the record is added. Stored in UTC.
    """

    run_id: str
    kind: str
    settings: dict[str, Any]
    versions: dict[str, Any]
    statistics: dict[str, Any] = field(default_factory=dict)
    ipopt_log: str = ""
    parameters: list[ParameterRow] = field(default_factory=list)
    arrays: dict[str, np.ndarray] = field(default_factory=dict)
    created: datetime | None = None

    def parameters_frame(self) -> pd.DataFrame:
        """Return the parameter table as a DataFrame.

        Returns
        -------
        pandas.DataFrame
            Columns ``name, known, identified, std_error`` (missing values are NaN).
        """
        rows = [(p.name, p.known, p.identified, p.std_error) for p in self.parameters]
        frame = pd.DataFrame(rows, columns=["name", "known", "identified", "std_error"])
        return frame.astype({"known": "float64", "identified": "float64", "std_error": "float64"})

    def summary(self) -> str:
        """Describe the run in a few lines of text (for ``colloc runs show``).

        Returns
        -------
        str
            Id, creation time, kind, versions, settings, statistics, the parameter table,
            the arrays (name, shape, dtype) and the length of the IPOPT log.
        """
        created = self.created.isoformat() if self.created is not None else "not yet stored"
        lines = [
            f"run {self.run_id}",
            f"created:    {created}",
            f"kind:       {self.kind}",
            f"versions:   {json.dumps(self.versions, sort_keys=True)}",
            "settings:",
            *_indented(json.dumps(self.settings, indent=2, sort_keys=True)),
            "statistics:",
            *_indented(json.dumps(self.statistics, indent=2, sort_keys=True)),
            "parameters:",
        ]
        if self.parameters:
            lines += _indented(self.parameters_frame().to_string(index=False))
        else:
            lines.append("  (none)")
        lines.append("arrays:")
        lines += [
            f"  {name}: shape {array.shape}, dtype {array.dtype}"
            for name, array in self.arrays.items()
        ] or ["  (none)"]
        lines.append(f"ipopt log:  {len(self.ipopt_log.splitlines())} lines")
        return "\n".join(lines)


def _indented(text: str) -> list[str]:
    return ["  " + line for line in text.splitlines()]


def validate_record(record: RunRecord) -> None:
    """Check a record before it is stored, reporting every problem at once.

    Parameters
    ----------
    record : RunRecord
        The record to check.

    Raises
    ------
    TypeError
        If ``record`` is not a :class:`RunRecord`.
    RecordError
        Listing every problem found in the record's fields.
    """
    if not isinstance(record, RunRecord):
        raise TypeError(f"record: expected a RunRecord, found {type(record).__name__}")
    problems: list[str] = []
    if not isinstance(record.run_id, str) or not record.run_id or len(record.run_id) > 128:
        problems.append(
            f"run_id: expected a non-empty str of at most 128 characters, found {record.run_id!r}"
        )
    if not isinstance(record.kind, str) or not record.kind or len(record.kind) > 64:
        problems.append(
            f"kind: expected a non-empty str of at most 64 characters, found {record.kind!r}"
        )
    for name in ("settings", "versions", "statistics"):
        value = getattr(record, name)
        if not isinstance(value, Mapping):
            problems.append(f"{name}: expected a dict, found {type(value).__name__}")
        else:
            to_json_value(value, name, problems)
    if not isinstance(record.ipopt_log, str):
        problems.append(f"ipopt_log: expected a str, found {type(record.ipopt_log).__name__}")
    if record.created is not None and not isinstance(record.created, datetime):
        problems.append(
            f"created: expected a datetime or None, found {type(record.created).__name__}"
        )
    problems.extend(_parameter_problems(record.parameters))
    problems.extend(_array_problems(record.arrays))
    if problems:
        raise RecordError(problems)


def _parameter_problems(parameters: Any) -> list[str]:
    if not isinstance(parameters, list | tuple):
        return [f"parameters: expected a list of ParameterRow, found {type(parameters).__name__}"]
    problems = []
    seen: set[str] = set()
    for i, row in enumerate(parameters):
        if not isinstance(row, ParameterRow):
            problems.append(f"parameters[{i}]: expected a ParameterRow, found {type(row).__name__}")
        elif not isinstance(row.name, str) or not row.name:
            problems.append(f"parameters[{i}].name: expected a non-empty str, found {row.name!r}")
        elif row.name in seen:
            problems.append(f"parameters[{i}].name: {row.name!r} appears more than once")
        else:
            seen.add(row.name)
    return problems


def _array_problems(arrays: Any) -> list[str]:
    if not isinstance(arrays, Mapping):
        return [f"arrays: expected a dict of str to numpy.ndarray, found {type(arrays).__name__}"]
    problems = []
    for name, array in arrays.items():
        if not isinstance(name, str) or not ARRAY_NAME_PATTERN.match(name):
            problems.append(
                f"arrays: name {name!r} must match {ARRAY_NAME_PATTERN.pattern} "
                "(it becomes a file name on export)"
            )
        elif name in RESERVED_ARRAY_NAMES:
            problems.append(f"arrays: name {name!r} is reserved for the export's own files")
        if not isinstance(array, np.ndarray):
            problems.append(
                f"arrays[{name!r}]: expected a numpy.ndarray, found {type(array).__name__}"
            )
        elif array.dtype.hasobject:
            problems.append(
                f"arrays[{name!r}]: dtype {array.dtype} holds Python objects; only plain "
                "numeric, bool and string dtypes can be stored without pickling"
            )
    return problems


def encode_array(array: np.ndarray) -> bytes:
    """Return the ``.npy`` bytes of ``array`` (never a pickle).

    Parameters
    ----------
    array : numpy.ndarray
        Array without Python objects.

    Returns
    -------
    bytes
        The array in NumPy's ``.npy`` format.
    """
    buffer = io.BytesIO()
    np.save(buffer, array, allow_pickle=False)
    return buffer.getvalue()


def decode_array(data: bytes) -> np.ndarray:
    """Read an array written by :func:`encode_array`, refusing pickled content.

    Parameters
    ----------
    data : bytes
        ``.npy`` bytes.

    Returns
    -------
    numpy.ndarray
        The stored array.
    """
    return np.load(io.BytesIO(data), allow_pickle=False)


def utc(moment: datetime) -> datetime:
    """Return ``moment`` in UTC; a naive datetime is taken to be UTC already.

    Parameters
    ----------
    moment : datetime
        A timezone-aware or naive datetime.

    Returns
    -------
    datetime
        The same instant with ``tzinfo=UTC``.
    """
    if moment.tzinfo is None:
        return moment.replace(tzinfo=UTC)
    return moment.astimezone(UTC)
