"""Errors raised by the results database."""

from __future__ import annotations

from collections.abc import Iterable


class StoreError(ValueError):
    """Base class of every error the results database raises on bad input."""


class RecordError(StoreError):
    """A run record (or an input to its id) has one or more problems, all listed."""

    def __init__(self, problems: Iterable[str], what: str = "run record") -> None:
        self.problems = list(problems)
        lines = "\n".join(f"  - {p}" for p in self.problems)
        super().__init__(f"the {what} has {len(self.problems)} problem(s):\n{lines}")


class StoreURLError(StoreError):
    """The database URL cannot be parsed, has no driver, or the database cannot be opened."""


class StoreDamagedError(StoreURLError):
    """The database file is damaged (SQLite reports a malformed image or no database)."""


class ForeignDatabaseError(StoreURLError):
    """The database holds other applications' tables and no colloc runs; nothing was added."""


class StoreWriteError(StoreError):
    """The database refused a write (read-only, locked past the busy timeout, damaged)."""


class RunNotFoundError(StoreError, LookupError):
    """No run matches the given id or id prefix, or the prefix matches several runs."""


class DuplicateRunError(StoreError):
    """A run with the same id is already stored and ``replace`` was not requested."""


class ExportError(StoreError):
    """A run cannot be exported in the requested format or to the requested place."""
