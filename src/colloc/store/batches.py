"""The record of batches: what a batch asked for, and what became of each of its entries.

A batch row holds the (expanded) specification; one entry row per run it asked for holds the
entry's kind, its settings, a key that says whether two entries would compute the same run,
and its fate: ``pending``, ``done`` (with the run id and/or output folder), ``failed`` (with
the error), ``skipped`` (done by an earlier batch) or ``cancelled``. A run stored by a worker
is marked ``done`` (or ``failed``) in the same transaction that stores it
(:meth:`colloc.store.RunStore.add` with ``batch_entry``), so whatever becomes of the batch
afterwards (Ctrl-C, a killed parent) a stored run is never computed again. The process that
runs a batch is recorded; a batch still ``running`` whose process is gone is marked ``dead``
by the next batch started against the database.
"""

from __future__ import annotations

import builtins
import json
from collections.abc import Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import pandas as pd
from sqlalchemy import Connection, Engine, delete, insert, inspect, select, update

from colloc.store import schema
from colloc.store.errors import RecordError, RunNotFoundError
from colloc.store.ids import canonical_json
from colloc.store.owner import ProcessOwner
from colloc.store.queries import resolve_id
from colloc.store.record import utc

#: What an entry can become.
ENTRY_STATUSES = ("pending", "done", "failed", "skipped", "cancelled")

#: What a batch can be.
BATCH_STATUSES = ("running", "finished", "cancelled", "dead")

_BATCH_TABLES = (schema.batches, schema.batch_entries, schema.batch_owners)

ENTRY_COLUMNS = (
    "position",
    "kind",
    "entry_key",
    "status",
    "run_id",
    "output",
    "error",
    "seconds",
    "settings",
)


class BatchLog:
    """The batches of one database (through :attr:`colloc.store.RunStore.batches`).

    Parameters
    ----------
    engine : sqlalchemy.Engine
        The store's engine.
    """

    def __init__(self, engine: Engine) -> None:
        self._engine = engine

    def _has_tables(self) -> bool:
        found = set(inspect(self._engine).get_table_names())
        return {schema.batches.name, schema.batch_entries.name} <= found

    def mark_dead(self) -> builtins.list[str]:
        """Mark ``dead`` every running batch whose process is gone (on this host).

        Its pending entries become ``cancelled``; entries whose run was stored are ``done``
        already. A batch run from another host, or recorded by a colloc that did not name
        its process, is left as it is: nothing here can tell.

        Returns
        -------
        list of str
            The ids of the batches marked.
        """
        if not self._has_tables():
            return []
        schema.metadata.create_all(self._engine, tables=list(_BATCH_TABLES))
        owners = schema.batch_owners
        with self._engine.connect() as connection:
            rows = connection.execute(
                select(owners)
                .join(schema.batches, schema.batches.c.batch_id == owners.c.batch_id)
                .where(schema.batches.c.status == "running")
            ).all()
        dead = [
            row.batch_id
            for row in rows
            if ProcessOwner(row.host, row.pid, row.process_start).alive() is False
        ]
        for batch_id in dead:
            self.finish(batch_id, "dead")
        return dead

    def start(
        self, batch_id: str, spec: Mapping[str, Any], entries: Sequence[Mapping[str, Any]]
    ) -> None:
        """Record a batch as running in this process; a batch with this id already recorded
        is taken up again (after :meth:`mark_dead`).

        Parameters
        ----------
        batch_id : str
        spec : mapping
            JSON-ready description of the batch (stored as canonical JSON).
        entries : sequence of mapping
            One per run: ``kind``, ``entry_key`` and ``settings`` (JSON-ready). Entries of a
            batch taken up again keep their ``done`` and ``skipped`` rows; the others become
            ``pending``.

        Raises
        ------
        RecordError
            If ``batch_id`` is empty, a recorded batch with this id has other entries, or it
            is running now in another live process of this host.
        """
        if not isinstance(batch_id, str) or not batch_id:
            raise RecordError([f"batch_id: expected a non-empty str, found {batch_id!r}"], "batch")
        schema.metadata.create_all(self._engine, tables=list(_BATCH_TABLES))
        self.mark_dead()
        me = ProcessOwner.this_process()
        now = datetime.now(UTC)
        rows = [
            {
                "batch_id": batch_id,
                "position": i,
                "kind": str(entry["kind"]),
                "entry_key": str(entry["entry_key"]),
                "settings": canonical_json(entry["settings"]),
                "status": "pending",
            }
            for i, entry in enumerate(entries)
        ]
        with self._engine.begin() as connection:
            known = connection.execute(
                select(schema.batch_entries.c.position, schema.batch_entries.c.entry_key)
                .where(schema.batch_entries.c.batch_id == batch_id)
                .order_by(schema.batch_entries.c.position)
            ).all()
            if known:
                if [row.entry_key for row in known] != [row["entry_key"] for row in rows]:
                    raise RecordError(
                        [f"batch_id: batch {batch_id!r} is recorded with other entries"], "batch"
                    )
                _refuse_if_running_elsewhere(connection, batch_id, me)
                _set_owner(connection, batch_id, me, now)
                connection.execute(
                    update(schema.batches)
                    .where(schema.batches.c.batch_id == batch_id)
                    .values(status="running", finished=None)
                )
                connection.execute(
                    update(schema.batch_entries)
                    .where(schema.batch_entries.c.batch_id == batch_id)
                    .where(schema.batch_entries.c.status.not_in(("done", "skipped")))
                    .values(status="pending", error=None)
                )
                return
            connection.execute(
                insert(schema.batches).values(
                    batch_id=batch_id,
                    created=now,
                    status="running",
                    spec=canonical_json(dict(spec)),
                )
            )
            if rows:
                connection.execute(insert(schema.batch_entries), rows)
            _set_owner(connection, batch_id, me, now)

    def record(
        self,
        batch_id: str,
        position: int,
        status: str,
        *,
        run_id: str | None = None,
        output: str | None = None,
        error: str | None = None,
        seconds: float | None = None,
    ) -> None:
        """Record what became of one entry.

        Parameters
        ----------
        batch_id : str
        position : int
            The entry's index in the batch.
        status : str
            One of :data:`ENTRY_STATUSES`.
        run_id, output, error : str or None
            The stored run, the folder written, the error of a failed entry.
        seconds : float or None
            Wall time of the entry in its worker.

        Raises
        ------
        RecordError
            If ``status`` is not one of :data:`ENTRY_STATUSES`.
        """
        with self._engine.begin() as connection:  # set_entry checks the status
            set_entry(
                connection,
                batch_id,
                position,
                status,
                run_id=run_id,
                output=output,
                error=error,
                seconds=seconds,
            )

    def finish(self, batch_id: str, status: str = "finished") -> None:
        """Mark the batch ended; entries still pending become ``cancelled``.

        Parameters
        ----------
        batch_id : str
        status : str
            ``"finished"``, ``"cancelled"`` or ``"dead"``.
        """
        if status not in BATCH_STATUSES:
            raise RecordError(
                [f"status: expected one of {list(BATCH_STATUSES)}, found {status!r}"], "batch"
            )
        with self._engine.begin() as connection:
            connection.execute(
                update(schema.batch_entries)
                .where(schema.batch_entries.c.batch_id == batch_id)
                .where(schema.batch_entries.c.status == "pending")
                .values(status="cancelled")
            )
            connection.execute(
                update(schema.batches)
                .where(schema.batches.c.batch_id == batch_id)
                .values(status=status, finished=datetime.now(UTC))
            )

    def done(self, entry_keys: Sequence[str]) -> dict[str, dict[str, Any]]:
        """Entries already done, by key, whose run is still stored (or that store none).

        Parameters
        ----------
        entry_keys : sequence of str

        Returns
        -------
        dict
            ``entry_key -> {"run_id", "output"}`` of an entry with that key done (or found
            done) in any batch; an entry whose run has since been deleted, or whose output folder
            is gone, is not done.
        """
        if not entry_keys or not self._has_tables():
            return {}
        wanted = set(entry_keys)
        entries = schema.batch_entries
        with self._engine.connect() as connection:
            rows = connection.execute(
                select(entries.c.entry_key, entries.c.run_id, entries.c.output)
                .where(entries.c.status.in_(("done", "skipped")))
                .where(entries.c.entry_key.in_(wanted))
            ).all()
            stored = set(
                connection.execute(
                    select(schema.runs.c.run_id).where(
                        schema.runs.c.run_id.in_([r.run_id for r in rows if r.run_id])
                    )
                ).scalars()
            )
        out: dict[str, dict[str, Any]] = {}
        for row in rows:
            if row.run_id is not None and row.run_id not in stored:
                continue
            if row.run_id is None and not (row.output and Path(row.output).is_dir()):
                continue
            out[row.entry_key] = {"run_id": row.run_id, "output": row.output}
        return out

    def resolve(self, batch_id: str) -> str:
        """The full id of the batch that ``batch_id`` (an id or unique prefix) names.

        Raises
        ------
        RunNotFoundError
            If no batch, or more than one, matches.
        """
        if not self._has_tables():
            raise RunNotFoundError(f"batch_id: no batch is recorded (looked for {batch_id!r})")
        with self._engine.connect() as connection:
            return resolve_id(connection, schema.batches.c.batch_id, batch_id, "batch")

    def get(self, batch_id: str) -> dict[str, Any]:
        """One batch: its row and its entries.

        Parameters
        ----------
        batch_id : str
            Full id or unique prefix.

        Returns
        -------
        dict
            ``batch_id``, ``created``, ``finished``, ``status``, ``spec`` (the stored
            mapping) and ``entries`` (a DataFrame with :data:`ENTRY_COLUMNS`, settings
            parsed).

        Raises
        ------
        RunNotFoundError
            If no batch, or more than one, matches.
        """
        full_id = self.resolve(batch_id)
        with self._engine.connect() as connection:
            row = connection.execute(
                select(schema.batches).where(schema.batches.c.batch_id == full_id)
            ).one()
            entries = connection.execute(
                select(*(schema.batch_entries.c[c] for c in ENTRY_COLUMNS))
                .where(schema.batch_entries.c.batch_id == full_id)
                .order_by(schema.batch_entries.c.position)
            ).all()
        frame = pd.DataFrame([tuple(e) for e in entries], columns=pd.Index(ENTRY_COLUMNS))
        frame["settings"] = [json.loads(text) for text in frame["settings"]]
        return {
            "batch_id": row.batch_id,
            "created": utc(row.created),
            "finished": utc(row.finished) if row.finished is not None else None,
            "status": row.status,
            "spec": json.loads(row.spec),
            "entries": frame,
        }

    def list(self) -> pd.DataFrame:
        """Every recorded batch, oldest first, with its entry counts by status.

        Returns
        -------
        pandas.DataFrame
            Columns ``batch_id, created, finished, status, entries`` and one per entry
            status.
        """
        columns = ["batch_id", "created", "finished", "status", "entries", *ENTRY_STATUSES]
        if not self._has_tables():
            return pd.DataFrame([], columns=pd.Index(columns))
        with self._engine.connect() as connection:
            batches = connection.execute(
                select(schema.batches).order_by(schema.batches.c.created)
            ).all()
            entries = connection.execute(
                select(schema.batch_entries.c.batch_id, schema.batch_entries.c.status)
            ).all()
        counts: dict[str, dict[str, int]] = {}
        for entry in entries:
            by_status = counts.setdefault(entry.batch_id, dict.fromkeys(ENTRY_STATUSES, 0))
            by_status[entry.status] = by_status.get(entry.status, 0) + 1
        records = []
        for batch in batches:
            by_status = counts.get(batch.batch_id, dict.fromkeys(ENTRY_STATUSES, 0))
            records.append(
                [
                    batch.batch_id,
                    utc(batch.created),
                    utc(batch.finished) if batch.finished is not None else None,
                    batch.status,
                    sum(by_status.values()),
                    *(by_status[s] for s in ENTRY_STATUSES),
                ]
            )
        return pd.DataFrame(records, columns=pd.Index(columns))

    def run_ids(self, batch_id: str) -> builtins.list[str]:
        """The ids of the runs a batch stored or found stored, in entry order.

        Parameters
        ----------
        batch_id : str
            Full id or unique prefix.
        """
        entries = self.get(batch_id)["entries"]
        return [r for r in entries["run_id"] if isinstance(r, str)]


def set_entry(
    connection: Connection,
    batch_id: str,
    position: int,
    status: str,
    *,
    run_id: str | None = None,
    output: str | None = None,
    error: str | None = None,
    seconds: float | None = None,
) -> None:
    """Record an entry's fate inside the caller's transaction (a worker storing its run).

    Parameters
    ----------
    connection : sqlalchemy.Connection
        In a transaction.
    batch_id : str
    position : int
    status : str
        One of :data:`ENTRY_STATUSES`.
    run_id, output, error : str or None
    seconds : float or None
        None keeps what is recorded.

    Raises
    ------
    RecordError
        If ``status`` is not one of :data:`ENTRY_STATUSES`.
    """
    if status not in ENTRY_STATUSES:
        raise RecordError(
            [f"status: expected one of {list(ENTRY_STATUSES)}, found {status!r}"], "entry"
        )
    values: dict[str, Any] = {"status": status, "run_id": run_id, "output": output, "error": error}
    if seconds is not None:
        values["seconds"] = seconds
    connection.execute(
        update(schema.batch_entries)
        .where(schema.batch_entries.c.batch_id == batch_id)
        .where(schema.batch_entries.c.position == position)
        .values(**values)
    )


def _set_owner(connection: Connection, batch_id: str, owner: ProcessOwner, now: datetime) -> None:
    connection.execute(
        delete(schema.batch_owners).where(schema.batch_owners.c.batch_id == batch_id)
    )
    connection.execute(
        insert(schema.batch_owners).values(
            batch_id=batch_id,
            host=owner.host,
            pid=owner.pid,
            process_start=owner.process_start,
            started=now,
        )
    )


def _refuse_if_running_elsewhere(connection: Connection, batch_id: str, me: ProcessOwner) -> None:
    """A batch that is running in another live process of this host is not taken up twice."""
    row = connection.execute(
        select(schema.batches.c.status, schema.batch_owners)
        .join(schema.batch_owners, schema.batch_owners.c.batch_id == schema.batches.c.batch_id)
        .where(schema.batches.c.batch_id == batch_id)
    ).first()
    if row is None or row.status != "running":
        return
    owner = ProcessOwner(row.host, row.pid, row.process_start)
    if owner != me and owner.alive():
        raise RecordError(
            [
                f"batch_id: batch {batch_id[:12]} is running now in process {owner.pid} on "
                "this machine; wait for it to end, or stop it, before running it again"
            ],
            "batch",
        )
