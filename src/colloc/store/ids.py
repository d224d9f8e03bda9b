"""Run identifiers: a run is named by a hash of everything that determines it.

The same settings, data and package versions give the same id on any machine and in any
process, so a repeated run is recognised instead of stored twice. Hashing goes through
:func:`canonical_json`, which fixes key order, separators and number formatting.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import platform
from collections.abc import Mapping
from importlib import metadata as importlib_metadata
from typing import Any

import numpy as np

from colloc.store.errors import RecordError

#: Distributions whose versions determine a run; alternatives are tried in order.
_VERSIONED_DISTRIBUTIONS: dict[str, tuple[str, ...]] = {
    "colloc": ("colloc",),
    "numpy": ("numpy",),
    "scipy": ("scipy",),
    "sympy": ("sympy",),
    "casadi": ("casadi",),
    # The Linux wheels come from the ``cyipopt-wheels`` distribution.
    "cyipopt": ("cyipopt", "cyipopt-wheels"),
}


def to_json_value(value: Any, where: str, problems: list[str]) -> Any:
    """Convert ``value`` to plain JSON types, recording every unsupported part.

    Parameters
    ----------
    value : Any
        Nested dicts (string keys), lists/tuples, str, bool, int, float, None, NumPy
        scalars and arrays.
    where : str
        Name of ``value`` used in problem messages (e.g. ``"settings"``).
    problems : list of str
        Problems found are appended here; the offending parts become ``None``.

    Returns
    -------
    Any
        The same data made of dict, list, str, bool, int, float and None only.
    """
    if isinstance(value, np.ndarray):
        if value.dtype.hasobject:
            problems.append(f"{where}: arrays of Python objects cannot be stored as JSON")
            return None
        value = value.tolist()
    elif isinstance(value, np.generic):
        value = value.item()
    if value is None or isinstance(value, bool | str):
        return value
    if isinstance(value, int):
        return int(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            problems.append(f"{where}: expected a finite number, found {value!r}")
            return None
        return float(value)
    if isinstance(value, Mapping):
        converted = {}
        for key, item in value.items():
            if not isinstance(key, str):
                problems.append(
                    f"{where}: keys must be strings, found {key!r} ({type(key).__name__})"
                )
                continue
            converted[key] = to_json_value(item, f"{where}[{key!r}]", problems)
        return converted
    if isinstance(value, list | tuple):
        return [to_json_value(item, f"{where}[{i}]", problems) for i, item in enumerate(value)]
    problems.append(
        f"{where}: expected JSON data (dict, list, str, number, bool, None), "
        f"found {type(value).__name__}"
    )
    return None


def canonical_json(value: Any, name: str = "value") -> str:
    """Serialise ``value`` to one canonical JSON text.

    Keys are sorted, separators are fixed, floats use the shortest round-trip form, and
    NumPy scalars and arrays become plain numbers and lists, so equal data always gives
    the same text.

    Parameters
    ----------
    value : Any
        JSON-like data (see :func:`to_json_value`).
    name : str, optional
        Name of the argument, used in error messages.

    Returns
    -------
    str
        The canonical JSON text.

    Raises
    ------
    RecordError
        If any part of ``value`` is not JSON data; all such parts are listed.
    """
    problems: list[str] = []
    plain = to_json_value(value, name, problems)
    if problems:
        raise RecordError(problems, what=name)
    return json.dumps(plain, sort_keys=True, separators=(",", ":"), allow_nan=False)


def run_id_for(settings: Mapping[str, Any], data_digest: str, versions: Mapping[str, Any]) -> str:
    """Compute the id of a run from everything that determines it.

    Parameters
    ----------
    settings : Mapping
        Every setting of the run (model, scheme, grid, solver options, seeds, ...), as
        JSON-like data.
    data_digest : str
        Digest of the input data, e.g. from :func:`digest_arrays`.
    versions : Mapping
        Package versions, e.g. from :func:`package_versions`.

    Returns
    -------
    str
        64 hexadecimal characters: the SHA-256 of the canonical JSON of the three inputs.

    Raises
    ------
    RecordError
        If ``settings`` or ``versions`` hold values that are not JSON data, or
        ``data_digest`` is not a string.
    """
    problems: list[str] = []
    if not isinstance(data_digest, str):
        problems.append(f"data_digest: expected a str, found {type(data_digest).__name__}")
    payload = {
        "settings": to_json_value(settings, "settings", problems),
        "data": data_digest if isinstance(data_digest, str) else None,
        "versions": to_json_value(versions, "versions", problems),
    }
    if problems:
        raise RecordError(problems, what="run id inputs")
    text = json.dumps(payload, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def digest_arrays(arrays: Mapping[str, np.ndarray]) -> str:
    """Hash named arrays: names, dtypes, shapes and values, independent of memory layout.

    Parameters
    ----------
    arrays : Mapping of str to numpy.ndarray
        The input data of a run (e.g. measured coordinates and the applied force).

    Returns
    -------
    str
        64 hexadecimal characters (SHA-256).

    Raises
    ------
    RecordError
        If a name is not a string or an array holds Python objects.
    """
    problems: list[str] = []
    digest = hashlib.sha256()
    for name in sorted(arrays, key=str):
        if not isinstance(name, str):
            problems.append(f"arrays: names must be strings, found {name!r}")
            continue
        array = np.asarray(arrays[name])
        if array.dtype.hasobject:
            problems.append(f"arrays[{name!r}]: arrays of Python objects cannot be hashed")
            continue
        # Little-endian, C order: the same values hash the same on any machine.
        normalised = np.ascontiguousarray(array, dtype=array.dtype.newbyteorder("<"))
        header = json.dumps([name, normalised.dtype.str, list(normalised.shape)])
        digest.update(header.encode("utf-8"))
        digest.update(normalised.tobytes())
    if problems:
        raise RecordError(problems, what="arrays")
    return digest.hexdigest()


def package_versions() -> dict[str, str | None]:
    """Versions of Python and of the packages that determine a run's numbers.

    Read once per process (the metadata look-ups take 5 ms, and a batch keys every entry).

    Returns
    -------
    dict
        ``{"python": ..., "colloc": ..., "numpy": ..., "scipy": ..., "sympy": ...,
        "casadi": ..., "cyipopt": ...}``; a package that is not installed maps to ``None``.
    """
    return dict(_installed_versions())


@functools.cache
def _installed_versions() -> dict[str, str | None]:
    versions: dict[str, str | None] = {"python": platform.python_version()}
    for key, distributions in _VERSIONED_DISTRIBUTIONS.items():
        versions[key] = None
        for distribution in distributions:
            try:
                versions[key] = importlib_metadata.version(distribution)
                break
            except importlib_metadata.PackageNotFoundError:
                continue
    return versions
