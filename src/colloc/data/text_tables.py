"""Delimited text files as a lab writes them: the delimiter sniffed, the file named in any
error (not UTF-8, empty, not a table). Trials, their tables, belt records and lab exports all
read through here.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pandas as pd


def detect_delimiter(path: str | os.PathLike[str]) -> str:
    """Return the field delimiter of a delimited text file.

    The header line is sniffed: the most frequent of tab, comma and semicolon wins. A
    header without any of them falls back on the extension (``.tsv`` and ``.txt`` mean tab,
    anything else comma).

    Parameters
    ----------
    path : path-like
        A delimited text file.

    Returns
    -------
    str
        The delimiter character.
    """
    path = Path(path)
    with open(path, encoding="utf-8-sig") as stream:
        header = stream.readline()
    counts = {delimiter: header.count(delimiter) for delimiter in ("\t", ",", ";")}
    best = max(counts, key=lambda delimiter: counts[delimiter])
    if counts[best] > 0:
        return best
    return "\t" if path.suffix.lower() in (".tsv", ".txt") else ","


def not_utf8(error: UnicodeDecodeError) -> str:
    """What a decode error says about a file, for messages that name it."""
    return (
        f"not UTF-8 text (byte {error.object[error.start]:#04x} at position {error.start}); "
        "save it as UTF-8"
    )


def read_table(path: str | os.PathLike[str], **options: Any) -> pd.DataFrame:
    """Read a delimited text file (delimiter sniffed), naming the file in any error.

    Parameters
    ----------
    path : path-like
    **options
        Passed to :func:`pandas.read_csv` (e.g. ``header=None``).

    Returns
    -------
    pandas.DataFrame

    Raises
    ------
    ValueError
        If the file is not UTF-8 text, is empty or does not parse as a table.
    """
    try:
        return pd.read_csv(path, sep=detect_delimiter(path), encoding="utf-8-sig", **options)
    except UnicodeDecodeError as error:
        raise ValueError(f"path {os.fspath(path)!r}: {not_utf8(error)}") from error
    except (pd.errors.ParserError, pd.errors.EmptyDataError) as error:
        raise ValueError(
            f"path {os.fspath(path)!r}: cannot parse it as a table ({error})"
        ) from error


__all__ = ["detect_delimiter", "not_utf8", "read_table"]
