"""A trial's raw records at their own sample rates: the lab's markers and plates.

A trial's ``trial.csv`` holds the signals the model reads on one uniform grid. A lab trial
also keeps what the lab measured before any filter, inverse kinematics or dynamics, each
at the rate it was recorded, so that a smoother can track the measurements themselves:

==============  ===========================================================================
file            columns
==============  ===========================================================================
``markers.csv`` ``time`` [s], then ``<marker>_x`` and ``<marker>_y`` [m] per marker: the
                sagittal position (forward, up), unfiltered; NaN where the marker was not
                seen (gaps are left, not filled)
``plates.csv``  ``time`` [s], then per foot (``right``, ``left``) ``<side>_force_x``,
                ``<side>_force_y`` [N] and ``<side>_moment`` [N m]: the forward and vertical
                force of the floor on that foot and its moment about the lab origin on the
                floor (the centre of pressure times the vertical force), unfiltered
==============  ===========================================================================
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from colloc.data.columns import SIDES, TIME_COLUMN
from colloc.data.text_tables import read_table

#: Names of the tables a trial may carry (each written as ``<name>.csv``).
TABLE_NAMES: tuple[str, ...] = ("markers", "plates")

#: The plates table's value columns, in order.
PLATE_COLUMNS: tuple[str, ...] = tuple(
    f"{side}_{quantity}" for side in SIDES for quantity in ("force_x", "force_y", "moment")
)


def table_file_names() -> tuple[str, ...]:
    """The file names of the tables, ``<name>.csv``."""
    return tuple(f"{name}.csv" for name in TABLE_NAMES)


def marker_names(markers: pd.DataFrame) -> list[str]:
    """The markers of a markers table, in column order (each has ``_x`` and ``_y``)."""
    return [str(c)[:-2] for c in markers.columns if str(c).endswith("_x")]


def table_problems(name: str, table: pd.DataFrame) -> list[str]:
    """Every problem of one table (empty when it is sound).

    Parameters
    ----------
    name : str
        One of :data:`TABLE_NAMES`.
    table : DataFrame
        Its ``time`` column and value columns.

    Returns
    -------
    list of str
        One sentence per problem, each naming the table.
    """
    where = f"{name}.csv"
    if name not in TABLE_NAMES:
        return [f"tables: expected names among {list(TABLE_NAMES)}, found {name!r}"]
    if not isinstance(table, pd.DataFrame):
        return [f"{where}: expected a pandas.DataFrame, found {type(table).__name__}"]
    if TIME_COLUMN not in table.columns:
        return [f"{where}: expected a {TIME_COLUMN!r} column, found {list(table.columns)[:5]}"]
    problems = []
    time = pd.to_numeric(table[TIME_COLUMN], errors="coerce").to_numpy(dtype=float)
    if time.size < 2:
        problems.append(f"{where}: expected at least 2 samples, found {time.size}")
    elif not np.all(np.isfinite(time)):
        problems.append(f"{where}: the time column holds NaN or infinite values")
    elif not np.all(np.diff(time) > 0):
        first = int(np.argmax(~(np.diff(time) > 0)))
        problems.append(
            f"{where}: expected increasing time, found {time[first + 1]:g} s after "
            f"{time[first]:g} s (row {first + 3})"
        )
    values = table.drop(columns=TIME_COLUMN)
    if name == "plates":
        if list(values.columns) != list(PLATE_COLUMNS):
            problems.append(
                f"{where}: expected columns {[TIME_COLUMN, *PLATE_COLUMNS]}, found "
                f"{list(table.columns)}"
            )
    else:
        names = [str(c) for c in values.columns]
        paired = [n for n in names if not (n.endswith(("_x", "_y")) and len(n) > 2)] + [
            f"{m}_y missing" for m in marker_names(values) if f"{m}_y" not in names
        ]
        if paired or not names:
            problems.append(
                f"{where}: expected <marker>_x and <marker>_y columns in pairs, found "
                f"{paired or 'none'}"
            )
    numbers = values.apply(pd.to_numeric, errors="coerce").to_numpy(dtype=float)
    text = values.isna().to_numpy()
    unreadable = np.isnan(numbers) & ~text
    if unreadable.any():
        column = str(values.columns[int(np.argmax(unreadable.any(axis=0)))])
        problems.append(f"{where}: column {column!r} holds values that are not numbers")
    if np.isinf(numbers).any():
        column = str(values.columns[int(np.argmax(np.isinf(numbers).any(axis=0)))])
        problems.append(f"{where}: column {column!r} holds infinite values (NaN marks a gap)")
    if name == "plates" and np.isnan(numbers).any():
        problems.append(f"{where}: expected every plate sample, found NaN")
    return problems


def tables_problems(tables: Mapping[str, pd.DataFrame]) -> list[str]:
    """Every problem of a trial's tables (see :func:`table_problems`)."""
    if not isinstance(tables, Mapping):
        return [f"tables: expected a mapping name -> DataFrame, found {type(tables).__name__}"]
    return [p for name, table in tables.items() for p in table_problems(str(name), table)]


def write_tables(directory: Path, tables: Mapping[str, pd.DataFrame]) -> None:
    """Write each table as ``<name>.csv`` in ``directory``."""
    for name, table in tables.items():
        table.to_csv(directory / f"{name}.csv", index=False)


def read_tables(directory: Path, problems: list[str]) -> dict[str, pd.DataFrame]:
    """The tables a trial folder holds (none is required); problems are appended."""
    out = {}
    for name in TABLE_NAMES:
        path = directory / f"{name}.csv"
        if not path.is_file():
            continue
        try:
            table = read_table(path)
        except ValueError as error:
            problems.append(str(error))
            continue
        table.columns = [str(c).strip() for c in table.columns]
        found = table_problems(name, table)
        if found:
            problems.extend(found)
            continue
        out[name] = table.apply(pd.to_numeric, errors="coerce")
    return out


def slice_tables(
    tables: Mapping[str, pd.DataFrame], start: float, stop: float, margin: float
) -> dict[str, pd.DataFrame]:
    """The rows of each table from ``start - margin`` to ``stop + margin`` [s]."""
    out = {}
    for name, table in tables.items():
        time = table[TIME_COLUMN].to_numpy(dtype=float)
        keep = (time >= start - margin) & (time <= stop + margin)
        out[name] = table.loc[keep].reset_index(drop=True)
    return out
