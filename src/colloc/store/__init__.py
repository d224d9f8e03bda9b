"""The results database: runs stored under a hash of everything that determines them."""

from colloc.store.errors import (
    DuplicateRunError,
    ExportError,
    RecordError,
    RunNotFoundError,
    StoreError,
    StoreURLError,
)
from colloc.store.ids import canonical_json, digest_arrays, package_versions, run_id_for
from colloc.store.record import ParameterRow, RunRecord
from colloc.store.runs import DEFAULT_URL, RunStore

__all__ = [
    "DEFAULT_URL",
    "DuplicateRunError",
    "ExportError",
    "ParameterRow",
    "RecordError",
    "RunNotFoundError",
    "RunRecord",
    "RunStore",
    "StoreError",
    "StoreURLError",
    "canonical_json",
    "digest_arrays",
    "package_versions",
    "run_id_for",
]
