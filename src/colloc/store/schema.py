"""Tables of the results database.

One row per run in ``colloc_runs``; its parameter table and its arrays live in child tables
keyed by ``run_id``. JSON documents are kept as text (canonical JSON written by
:mod:`colloc.store.ids`) rather than a backend JSON type, so every SQLAlchemy backend stores
them the same way, and arrays are ``.npy`` bytes (never pickles).
"""

from __future__ import annotations

from sqlalchemy import (
    Column,
    DateTime,
    Double,
    ForeignKey,
    Integer,
    LargeBinary,
    MetaData,
    String,
    Table,
    Text,
)

#: Bumped whenever a table changes in a way an older database cannot be read with.
SCHEMA_VERSION = 1

metadata = MetaData()

schema_info = Table(
    "colloc_schema",
    metadata,
    Column("version", Integer, primary_key=True, autoincrement=False),
)

runs = Table(
    "colloc_runs",
    metadata,
    Column("run_id", String(128), primary_key=True),
    Column("created", DateTime(timezone=True), nullable=False, index=True),
    Column("kind", String(64), nullable=False, index=True),
    Column("settings", Text, nullable=False),
    Column("versions", Text, nullable=False),
    Column("statistics", Text, nullable=False),
    Column("ipopt_log", Text, nullable=False),
)

parameters = Table(
    "colloc_parameters",
    metadata,
    Column(
        "run_id",
        String(128),
        ForeignKey("colloc_runs.run_id", ondelete="CASCADE"),
        primary_key=True,
    ),
    Column("position", Integer, primary_key=True, autoincrement=False),
    Column("name", String(256), nullable=False),
    Column("known", Double, nullable=True),
    Column("identified", Double, nullable=True),
    Column("std_error", Double, nullable=True),
)

arrays = Table(
    "colloc_arrays",
    metadata,
    Column(
        "run_id",
        String(128),
        ForeignKey("colloc_runs.run_id", ondelete="CASCADE"),
        primary_key=True,
    ),
    Column("position", Integer, primary_key=True, autoincrement=False),
    Column("name", String(256), nullable=False),
    Column("data", LargeBinary, nullable=False),
)

# A batch (``colloc batch``): one row per batch, one per entry. The entry's run is named by
# id, not by foreign key: deleting a run leaves the batch's history, and the entry is redone
# when the batch runs again. Added after schema version 1 without changing it: the tables are
# created on first write in an older database, and readers treat them as optional.
batches = Table(
    "colloc_batches",
    metadata,
    Column("batch_id", String(128), primary_key=True),
    Column("created", DateTime(timezone=True), nullable=False, index=True),
    Column("finished", DateTime(timezone=True), nullable=True),
    Column("status", String(32), nullable=False),
    Column("spec", Text, nullable=False),
)

batch_entries = Table(
    "colloc_batch_entries",
    metadata,
    Column(
        "batch_id",
        String(128),
        ForeignKey("colloc_batches.batch_id", ondelete="CASCADE"),
        primary_key=True,
    ),
    Column("position", Integer, primary_key=True, autoincrement=False),
    Column("kind", String(64), nullable=False),
    Column("entry_key", String(128), nullable=False, index=True),
    Column("settings", Text, nullable=False),
    Column("status", String(32), nullable=False),
    Column("run_id", String(128), nullable=True),
    Column("output", Text, nullable=True),
    Column("error", Text, nullable=True),
    Column("seconds", Double, nullable=True),
)

# Which process runs a batch, so that a re-run can tell a batch that is running from one
# whose process was killed (SIGKILL, a lost machine). Added like the batch tables above.
batch_owners = Table(
    "colloc_batch_owners",
    metadata,
    Column(
        "batch_id",
        String(128),
        ForeignKey("colloc_batches.batch_id", ondelete="CASCADE"),
        primary_key=True,
    ),
    Column("host", String(255), nullable=False),
    Column("pid", Integer, nullable=False),
    Column("process_start", String(64), nullable=True),
    Column("started", DateTime(timezone=True), nullable=False),
)

#: Tables a database must hold to be read as colloc's (the batch tables are optional).
RUN_TABLES = ("colloc_schema", "colloc_runs", "colloc_parameters", "colloc_arrays")
