"""The results database: runs stored under a hash of everything that determines them.

Names load on first use (``colloc._lazy``), so reading :data:`DEFAULT_URL` for a command's
help does not import SQLAlchemy or pandas.
"""

# ruff: noqa: F401  (the TYPE_CHECKING imports are re-exported by __all__, built from _EXPORTS)
from typing import TYPE_CHECKING

from colloc._lazy import lazy_exports

_EXPORTS = {
    "DEFAULT_URL": "colloc.store.url",
    "DuplicateRunError": "colloc.store.errors",
    "ExportError": "colloc.store.errors",
    "ForeignDatabaseError": "colloc.store.errors",
    "RecordError": "colloc.store.errors",
    "RunNotFoundError": "colloc.store.errors",
    "StoreDamagedError": "colloc.store.errors",
    "StoreError": "colloc.store.errors",
    "StoreURLError": "colloc.store.errors",
    "StoreWriteError": "colloc.store.errors",
    "canonical_json": "colloc.store.ids",
    "digest_arrays": "colloc.store.ids",
    "package_versions": "colloc.store.ids",
    "run_id_for": "colloc.store.ids",
    "ParameterRow": "colloc.store.record",
    "RunRecord": "colloc.store.record",
    "RunStore": "colloc.store.runs",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())

if TYPE_CHECKING:  # for type checkers; re-exported through __all__
    from colloc.store.errors import (
        DuplicateRunError,
        ExportError,
        ForeignDatabaseError,
        RecordError,
        RunNotFoundError,
        StoreDamagedError,
        StoreError,
        StoreURLError,
        StoreWriteError,
    )
    from colloc.store.ids import canonical_json, digest_arrays, package_versions, run_id_for
    from colloc.store.record import ParameterRow, RunRecord
    from colloc.store.runs import RunStore
    from colloc.store.url import DEFAULT_URL

__all__ = list(_EXPORTS)
