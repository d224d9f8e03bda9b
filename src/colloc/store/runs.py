"""The results database: add, list, get, export and delete runs.

Any SQLAlchemy URL works; the default is an SQLite file in the working directory. Each run is
written in one transaction, so a failure part-way through leaves the database exactly as it
was before.
"""

from __future__ import annotations

import builtins
import json
import sqlite3
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import pandas as pd
from sqlalchemy import Engine, create_engine, event, func, insert, inspect, select
from sqlalchemy.engine import make_url
from sqlalchemy.exc import ArgumentError, IntegrityError, NoSuchModuleError, SQLAlchemyError

from colloc.store import schema
from colloc.store.batches import BatchLog, set_entry
from colloc.store.errors import (
    DuplicateRunError,
    ForeignDatabaseError,
    StoreDamagedError,
    StoreURLError,
    StoreWriteError,
)
from colloc.store.export import EXPORTERS, export_record
from colloc.store.queries import delete_run, insert_run, resolve_run_id
from colloc.store.record import (
    ParameterRow,
    RunRecord,
    decode_array,
    utc,
    validate_record,
)
from colloc.store.url import DEFAULT_URL

#: Settings shown by :meth:`RunStore.list` (dotted keys reach into nested settings).
DEFAULT_SETTING_COLUMNS = ("num_links", "scheme", "num_nodes", "duration", "sample_rate")
#: Solver statistics shown by :meth:`RunStore.list`.
DEFAULT_STATISTIC_COLUMNS = ("success", "iterations", "objective", "solve_time")
#: Columns :meth:`RunStore.list` shows for a kind of run: (settings, statistics, whether the
#: largest relative parameter error means anything). A gait run's entries of K include gains
#: near zero, whose relative errors are meaningless; its own summary errors are shown instead.
KIND_COLUMNS: dict[str, tuple[tuple[str, ...], tuple[str, ...], bool]] = {
    "pendulum": (DEFAULT_SETTING_COLUMNS, DEFAULT_STATISTIC_COLUMNS, True),
    "gait-identify": (
        ("trial", "method", "fit_fraction"),
        (
            "points",  # the schedule points used (the setting is often left to the trial)
            "success",
            "iterations",
            "K_relative_error",
            "Tstar_relative_error",
            "fraction_within_3se",
            "validation.walks",
        ),
        False,
    ),
}


def _require_existing_file(parsed: Any, url: str) -> None:
    """For a file-backed SQLite URL, refuse one whose file does not exist (no empty file)."""
    database = parsed.database
    if parsed.get_backend_name() != "sqlite" or not database or database == ":memory:":
        return
    if database.startswith("file:"):
        return  # an SQLite URI: its own options decide
    if not Path(database).is_file():
        raise StoreURLError(
            f"url: there is no database at {url!r} (no file {database!r}); nothing was "
            "created: check the path, or store a run there first"
        )


BUSY_TIMEOUT_SECONDS = 30.0
"""How long a write waits for another writer's lock on an SQLite file before failing."""


def _sqlite_setup(busy_timeout: float) -> Any:
    """A connect hook: SQLite ignores foreign keys unless asked, and fails at once on a
    locked file unless given a timeout; parallel batch runs write to the same file."""

    def on_connect(dbapi_connection: Any, connection_record: Any) -> None:
        if isinstance(dbapi_connection, sqlite3.Connection):
            cursor = dbapi_connection.cursor()
            cursor.execute("PRAGMA foreign_keys=ON")
            cursor.execute(f"PRAGMA busy_timeout={round(busy_timeout * 1000)}")
            cursor.close()

    return on_connect


#: What SQLite says of a file it cannot read as a database.
_DAMAGED_MESSAGES = ("malformed", "file is not a database", "disk image")


def _damage_translator(url: str, database: str | None) -> Any:
    """An engine ``handle_error`` hook: a damaged SQLite file is named, with what to do."""

    def on_error(context: Any) -> None:
        original = context.original_exception
        if not isinstance(original, sqlite3.DatabaseError) or isinstance(
            original, sqlite3.OperationalError
        ):
            return  # locks, missing tables and the like keep their own messages
        if not any(text in str(original) for text in _DAMAGED_MESSAGES):
            return
        where = f"file {database!r}" if database else repr(url)
        recover = (
            f"; `sqlite3 {database} .recover | sqlite3 recovered.db` saves what is readable"
            if database
            else ""
        )
        raise StoreDamagedError(
            f"url: the database {where} is damaged ({original}); nothing was changed: "
            f"restore it from a copy{recover}, or pass another --db"
        ) from original

    return on_error


class RunStore:
    """A database of identification runs.

    Parameters
    ----------
    url : str, optional
        SQLAlchemy database URL, e.g. ``"sqlite:///colloc-runs.db"`` (the default),
        ``"sqlite://"`` (in memory) or ``"postgresql+psycopg://user@host/db"``.
    create : bool, optional
        Create the database file and colloc's tables when missing (default). False (for
        reading, or deleting): refuse a missing SQLite file or a database without colloc's
        tables, changing nothing.
    allow_other_tables : bool, optional
        Add colloc's tables to a database that already holds other applications' tables
        (default False: such a database is refused, unchanged, unless it already holds
        colloc's runs).
    busy_timeout : float, optional
        Seconds a write waits for another writer's lock on an SQLite file before it fails
        (default, None: :data:`BUSY_TIMEOUT_SECONDS`).

    Raises
    ------
    StoreURLError
        If ``url`` is not a URL, names a backend without an installed driver, or the
        database cannot be opened or created (or, with ``create=False``, does not exist or
        holds no colloc tables), or ``busy_timeout`` is not a finite number >= 0.
    ForeignDatabaseError
        If the database holds other tables and no colloc runs, and ``allow_other_tables``
        is False.
    StoreDamagedError
        If the SQLite file is damaged (here or in any later call).

    Examples
    --------
    >>> store = RunStore("sqlite://")
    >>> store.list().empty
    True
    """

    def __init__(
        self,
        url: str = DEFAULT_URL,
        *,
        create: bool = True,
        allow_other_tables: bool = False,
        busy_timeout: float | None = None,
    ) -> None:
        if not isinstance(url, str):
            raise StoreURLError(f"url: expected a str, found {type(url).__name__}")
        if busy_timeout is None:
            busy_timeout = BUSY_TIMEOUT_SECONDS
        if (
            isinstance(busy_timeout, bool)
            or not isinstance(busy_timeout, int | float)
            or not 0 <= busy_timeout < float("inf")
        ):
            raise StoreURLError(
                f"busy_timeout: expected a finite number of seconds >= 0, found {busy_timeout!r}"
            )
        try:
            parsed = make_url(url)
            self._engine: Engine = create_engine(url)
        except (ArgumentError, NoSuchModuleError, ImportError, ValueError) as error:
            raise StoreURLError(
                f"url: expected a SQLAlchemy database URL such as {DEFAULT_URL!r}, "
                f"found {url!r} ({error})"
            ) from error
        if not create:
            try:
                _require_existing_file(parsed, url)
            except StoreURLError:
                self._engine.dispose()
                raise
        self.busy_timeout = float(busy_timeout)
        event.listen(self._engine, "connect", _sqlite_setup(self.busy_timeout))
        event.listen(self._engine, "handle_error", _damage_translator(url, parsed.database))
        self.url = url
        self.create = create
        self.allow_other_tables = bool(allow_other_tables)
        try:
            self._prepare_schema()
        except SQLAlchemyError as error:
            self._engine.dispose()
            cause = getattr(error, "orig", None) or error
            raise StoreURLError(
                f"url: could not open or create the database at {url!r} "
                f"({type(error).__name__}: {cause})"
            ) from error
        except StoreURLError:
            self._engine.dispose()
            raise

    def _prepare_schema(self) -> None:
        if self.create:
            found = set(inspect(self._engine).get_table_names())
            other = sorted(found - set(schema.metadata.tables))
            if other and not self.allow_other_tables and not set(schema.RUN_TABLES) <= found:
                shown = ", ".join(other[:8]) + (", ..." if len(other) > 8 else "")
                raise ForeignDatabaseError(
                    f"url: the database at {self.url!r} holds other tables ({shown}) and no "
                    "colloc runs; nothing was added: pass a database of its own, or say that "
                    "colloc's tables may go beside them (--db-allow-other-tables; "
                    "RunStore(..., allow_other_tables=True))"
                )
            schema.metadata.create_all(self._engine)
        else:
            found = set(inspect(self._engine).get_table_names())
            missing = sorted(set(schema.RUN_TABLES) - found)
            if missing:
                raise StoreURLError(
                    f"url: the database at {self.url!r} holds no colloc runs (tables "
                    f"{missing} are missing; found {sorted(found)}); nothing was changed"
                )
        with self._engine.begin() as connection:
            versions = connection.execute(select(schema.schema_info.c.version)).scalars().all()
            if not versions and self.create:
                connection.execute(insert(schema.schema_info).values(version=schema.SCHEMA_VERSION))
            elif versions != [schema.SCHEMA_VERSION]:
                raise StoreURLError(
                    f"url: the database at {self.url!r} has schema version {versions}, this "
                    f"colloc reads version {schema.SCHEMA_VERSION}; use a new database file"
                )

    def check_writable(self) -> None:
        """Raise unless a run could be stored now (a write is tried and rolled back).

        Raises
        ------
        StoreURLError
            If the database is read-only, locked for longer than the busy timeout,
            or its tables cannot take a row.
        """
        try:
            with self._engine.connect() as connection:
                transaction = connection.begin()
                try:
                    connection.execute(insert(schema.schema_info).values(version=-1))
                finally:
                    transaction.rollback()
        except SQLAlchemyError as error:
            cause = getattr(error, "orig", None) or error
            raise StoreURLError(
                f"url: the database at {self.url!r} cannot be written ({cause}); nothing was "
                "computed: fix it, or pass another --db (or --no-store)"
            ) from error

    @property
    def batches(self) -> BatchLog:
        """The record of the batches run against this database (:class:`BatchLog`)."""
        return BatchLog(self._engine)

    def close(self) -> None:
        """Release the database connections."""
        self._engine.dispose()

    def __enter__(self) -> RunStore:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"RunStore({self.url!r})"

    # ----------------------------------------------------------------------------- writing

    def add(
        self,
        record: RunRecord,
        *,
        replace: bool = False,
        batch_entry: tuple[str, int, str] | None = None,
    ) -> None:
        """Store a run, all of it or nothing.

        Parameters
        ----------
        record : RunRecord
            The run. A ``created`` of ``None`` is set to the current UTC time.
        replace : bool, optional
            Replace a stored run with the same id instead of raising.
        batch_entry : (batch_id, position, status), optional
            The batch entry that computed the run, recorded with ``status`` (``"done"`` or
            ``"failed"``) and the run's id in the same transaction, so that a stored run is
            never left looking unfinished (:mod:`colloc.store.batches`).

        Raises
        ------
        RecordError
            If the record has problems (all are listed).
        DuplicateRunError
            If a run with this id is stored and ``replace`` is false.
        StoreWriteError
            If the database refuses the write (read-only, locked past the busy timeout,
            damaged); nothing of the run is stored.
        """
        validate_record(record)
        created = utc(record.created) if record.created is not None else datetime.now(UTC)
        duplicate = DuplicateRunError(
            f"record.run_id: a run with id {record.run_id!r} is already stored; "
            "pass replace=True to overwrite it or delete it first"
        )
        try:
            with self._engine.begin() as connection:
                exists = connection.execute(
                    select(schema.runs.c.run_id).where(schema.runs.c.run_id == record.run_id)
                ).first()
                if exists is not None:
                    if not replace:
                        raise duplicate
                    delete_run(connection, record.run_id)
                insert_run(connection, record, created)
                if batch_entry is not None:
                    batch_id, position, status = batch_entry
                    set_entry(connection, batch_id, position, status, run_id=record.run_id)
        except IntegrityError as error:
            # Another process stored the same id between our check and our insert.
            raise duplicate from error
        except SQLAlchemyError as error:
            cause = getattr(error, "orig", None) or error
            raise StoreWriteError(
                f"url: the database at {self.url!r} refused run {record.run_id[:12]} "
                f"({type(cause).__name__}: {cause}); nothing of it was stored"
            ) from error

    def delete(self, run_id: str) -> str:
        """Delete a run.

        Parameters
        ----------
        run_id : str
            Full id or unique prefix.

        Returns
        -------
        str
            The full id of the deleted run.

        Raises
        ------
        RunNotFoundError
            If no run or more than one run matches.
        """
        with self._engine.begin() as connection:
            full_id = resolve_run_id(connection, run_id)
            delete_run(connection, full_id)
        return full_id

    # ----------------------------------------------------------------------------- reading

    def resolve(self, run_id: str) -> str:
        """Return the full id of the run that ``run_id`` (an id or unique prefix) names.

        Parameters
        ----------
        run_id : str
            Full id or unique prefix.

        Returns
        -------
        str
            The full run id.

        Raises
        ------
        RunNotFoundError
            If no run or more than one run matches.
        """
        with self._engine.connect() as connection:
            return resolve_run_id(connection, run_id)

    def get(self, run_id: str, *, arrays: bool = True) -> RunRecord:
        """Load a run.

        Parameters
        ----------
        run_id : str
            Full id or unique prefix.
        arrays : bool, optional
            False: leave the arrays (the bulk of a run) unread; ``record.arrays`` is empty.

        Returns
        -------
        RunRecord
            The stored record; arrays are read back exactly (dtype, shape and values).

        Raises
        ------
        RunNotFoundError
            If no run or more than one run matches.
        """
        with self._engine.connect() as connection:
            full_id = resolve_run_id(connection, run_id)
            run = connection.execute(
                select(schema.runs).where(schema.runs.c.run_id == full_id)
            ).one()
            parameter_rows = connection.execute(
                select(schema.parameters)
                .where(schema.parameters.c.run_id == full_id)
                .order_by(schema.parameters.c.position)
            ).all()
            array_rows = (
                connection.execute(
                    select(schema.arrays.c.name, schema.arrays.c.data)
                    .where(schema.arrays.c.run_id == full_id)
                    .order_by(schema.arrays.c.position)
                ).all()
                if arrays
                else []
            )
        return RunRecord(
            run_id=run.run_id,
            kind=run.kind,
            settings=json.loads(run.settings),
            versions=json.loads(run.versions),
            statistics=json.loads(run.statistics),
            ipopt_log=run.ipopt_log,
            parameters=[
                ParameterRow(row.name, row.known, row.identified, row.std_error)
                for row in parameter_rows
            ],
            arrays={row.name: decode_array(row.data) for row in array_rows},
            created=utc(run.created),
        )

    def list(
        self,
        settings: Sequence[str] = DEFAULT_SETTING_COLUMNS,
        statistics: Sequence[str] = DEFAULT_STATISTIC_COLUMNS,
        kind: str | None = None,
        batch: str | None = None,
    ) -> pd.DataFrame:
        """Summarise the stored runs, oldest first.

        Parameters
        ----------
        settings : sequence of str, optional
            Settings to show as columns; ``"a.b"`` reads ``settings["a"]["b"]``.
        statistics : sequence of str, optional
            Solver statistics to show as columns (dotted keys as for ``settings``).
        kind : str or None, optional
            Only runs of this kind.
        batch : str or None, optional
            Only the runs of this batch (an id or unique prefix).

        Returns
        -------
        pandas.DataFrame
            Columns ``run_id, created, kind``, then the requested settings and statistics
            (missing where a run lacks one), ``num_parameters`` and ``max_rel_error``, the
            largest ``|identified - known| / |known|`` over parameters with both values
            (NaN when there is none).

        Raises
        ------
        RunNotFoundError
            If ``batch`` names no recorded batch, or several.
        """
        query = select(schema.runs).order_by(schema.runs.c.created, schema.runs.c.run_id)
        if kind is not None:
            query = query.where(schema.runs.c.kind == kind)
        if batch is not None:
            query = query.where(schema.runs.c.run_id.in_(self.batches.run_ids(batch)))
        with self._engine.connect() as connection:
            runs = connection.execute(query).all()
            parameter_rows = connection.execute(
                select(
                    schema.parameters.c.run_id,
                    schema.parameters.c.known,
                    schema.parameters.c.identified,
                )
            ).all()
        counts: dict[str, int] = {}
        errors: dict[str, float] = {}
        for row in parameter_rows:
            counts[row.run_id] = counts.get(row.run_id, 0) + 1
            if row.known is not None and row.identified is not None and row.known != 0:
                error = abs(row.identified - row.known) / abs(row.known)
                errors[row.run_id] = max(errors.get(row.run_id, 0.0), error)
        columns = ["run_id", "created", "kind", *settings, *statistics]
        columns += ["num_parameters", "max_rel_error"]
        records = []
        for run in runs:
            run_settings = json.loads(run.settings)
            run_statistics = json.loads(run.statistics)
            records.append(
                [run.run_id, utc(run.created), run.kind]
                + [_dotted(run_settings, key) for key in settings]
                + [_dotted(run_statistics, key) for key in statistics]
                + [counts.get(run.run_id, 0), errors.get(run.run_id, float("nan"))]
            )
        return pd.DataFrame(records, columns=pd.Index(columns, dtype=object))

    def __len__(self) -> int:
        with self._engine.connect() as connection:
            return connection.execute(select(func.count()).select_from(schema.runs)).scalar_one()

    # ----------------------------------------------------------------------------- export

    def export(
        self, run_id: str, directory: str | Path, format: str = "csv", overwrite: bool = False
    ) -> builtins.list[Path]:
        """Write a run to files.

        Parameters
        ----------
        run_id : str
            Full id or unique prefix.
        directory : str or Path
            Target directory (created if missing).
        format : {"csv", "npz"}, optional
            ``"csv"``: one ``<array>.csv`` per array (0-, 1- or 2-D), ``parameters.csv`` and
            ``metadata.json``. ``"npz"``: ``<run_id>.npz`` with all arrays and
            ``<run_id>.json`` with metadata and parameters.
        overwrite : bool, optional
            Replace files of the same names already in ``directory`` (an error otherwise).

        Returns
        -------
        list of Path
            The files written.

        Raises
        ------
        ExportError
            If ``format`` is unknown, an array cannot be written as CSV, ``directory`` is
            not a directory, or (without ``overwrite``) holds files of the same names. No
            file is written or changed then.
        RunNotFoundError
            If no run or more than one run matches.
        """
        return export_record(self.get(run_id), directory, format, overwrite=overwrite)

    @staticmethod
    def export_formats() -> tuple[str, ...]:
        """Return the names accepted by :meth:`export`'s ``format``."""
        return tuple(EXPORTERS)


def _dotted(document: Any, key: str) -> Any:
    value = document
    for part in key.split("."):
        if not isinstance(value, dict) or part not in value:
            return None
        value = value[part]
    return value
