"""SQL statements on the run tables, each run inside the caller's transaction."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import Connection, delete, insert, select

from colloc.store import schema
from colloc.store.errors import RunNotFoundError
from colloc.store.ids import canonical_json
from colloc.store.record import RunRecord, encode_array

#: How many matching ids an "ambiguous prefix" error shows.
AMBIGUOUS_SHOWN = 5


def insert_run(connection: Connection, record: RunRecord, created: datetime) -> None:
    """Insert every row of a validated record.

    Parameters
    ----------
    connection : sqlalchemy.Connection
        Connection inside the caller's transaction; a failure here rolls back with it.
    record : RunRecord
        A record that passed :func:`colloc.store.record.validate_record`.
    created : datetime
        The creation time to store (UTC).
    """
    connection.execute(
        insert(schema.runs).values(
            run_id=record.run_id,
            created=created,
            kind=record.kind,
            settings=canonical_json(record.settings, "settings"),
            versions=canonical_json(record.versions, "versions"),
            statistics=canonical_json(record.statistics, "statistics"),
            ipopt_log=record.ipopt_log,
        )
    )
    if record.parameters:
        connection.execute(
            insert(schema.parameters),
            [
                {
                    "run_id": record.run_id,
                    "position": position,
                    "name": row.name,
                    "known": row.known,
                    "identified": row.identified,
                    "std_error": row.std_error,
                }
                for position, row in enumerate(record.parameters)
            ],
        )
    # One statement per array keeps only one array's bytes in memory besides the record.
    for position, (name, array) in enumerate(record.arrays.items()):
        connection.execute(
            insert(schema.arrays).values(
                run_id=record.run_id, position=position, name=name, data=encode_array(array)
            )
        )


def delete_run(connection: Connection, run_id: str) -> None:
    """Delete a run and its child rows.

    Parameters
    ----------
    connection : sqlalchemy.Connection
        Connection inside the caller's transaction.
    run_id : str
        The full id.
    """
    # Children first and explicitly: not every backend enforces ON DELETE CASCADE.
    for table in (schema.arrays, schema.parameters, schema.runs):
        connection.execute(delete(table).where(table.c.run_id == run_id))


def resolve_run_id(connection: Connection, run_id: str) -> str:
    """Return the one stored id equal to, or else starting with, ``run_id``.

    Parameters
    ----------
    connection : sqlalchemy.Connection
        An open connection.
    run_id : str
        Full id or prefix; SQL wildcards in it match literally.

    Returns
    -------
    str
        The full id.

    Raises
    ------
    RunNotFoundError
        If ``run_id`` is empty, matches nothing, or is a prefix of several ids.
    """
    return resolve_id(connection, schema.runs.c.run_id, run_id, "run")


def resolve_id(connection: Connection, column: Any, given: str, what: str) -> str:
    """The one value of ``column`` equal to, or else starting with, ``given``.

    Parameters
    ----------
    connection : sqlalchemy.Connection
    column : sqlalchemy column
        A primary-key id column.
    given : str
        Full id or prefix; SQL wildcards in it match literally.
    what : str
        What the ids name, for the errors ("run", "batch").

    Returns
    -------
    str

    Raises
    ------
    RunNotFoundError
        If ``given`` is empty, matches nothing, or is a prefix of several ids.
    """
    name = f"{what}_id"
    if not isinstance(given, str) or not given:
        raise RunNotFoundError(f"{name}: expected a non-empty id or id prefix, found {given!r}")
    exact = connection.execute(select(column).where(column == given)).scalar()
    if exact is not None:
        return str(exact)
    matches = (
        connection.execute(
            select(column)
            .where(column.startswith(given, autoescape=True))
            .order_by(column)
            .limit(AMBIGUOUS_SHOWN + 1)
        )
        .scalars()
        .all()
    )
    if not matches:
        raise RunNotFoundError(f"{name}: no stored {what} has an id starting with {given!r}")
    if len(matches) > 1:
        shown = ", ".join(matches[:AMBIGUOUS_SHOWN])
        more = ", ..." if len(matches) > AMBIGUOUS_SHOWN else ""
        raise RunNotFoundError(
            f"{name}: prefix {given!r} is ambiguous, it matches {shown}{more}; give more characters"
        )
    return str(matches[0])
