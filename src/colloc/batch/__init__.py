"""Many runs at once: batch files, their tasks, their execution on Dask, their report.

Names load on first use (``colloc._lazy``), so the command line's help does not import Dask.
"""

# ruff: noqa: F401  (the TYPE_CHECKING imports are re-exported by __all__, built from _EXPORTS)
from typing import TYPE_CHECKING

from colloc._lazy import lazy_exports

_EXPORTS = {
    "BatchOutcome": "colloc.batch.execute",
    "batch_id_for": "colloc.batch.execute",
    "default_workers": "colloc.batch.cluster",
    "run_batch": "colloc.batch.execute",
    "gait_table": "colloc.batch.report",
    "pendulum_table": "colloc.batch.report",
    "write_batch_report": "colloc.batch.report",
    "BatchSpec": "colloc.batch.spec",
    "BatchSpecError": "colloc.batch.spec",
    "Entry": "colloc.batch.spec",
    "expand_batch": "colloc.batch.spec",
    "read_batch_spec": "colloc.batch.spec",
    "RUNNERS": "colloc.batch.tasks",
    "Task": "colloc.batch.tasks",
    "TaskResult": "colloc.batch.tasks",
    "folder_digest": "colloc.batch.tasks",
    "run_task": "colloc.batch.tasks",
    "task_key": "colloc.batch.tasks",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())

if TYPE_CHECKING:  # for type checkers; re-exported through __all__
    from colloc.batch.cluster import default_workers
    from colloc.batch.execute import BatchOutcome, batch_id_for, run_batch
    from colloc.batch.report import gait_table, pendulum_table, write_batch_report
    from colloc.batch.spec import BatchSpec, BatchSpecError, Entry, expand_batch, read_batch_spec
    from colloc.batch.tasks import RUNNERS, Task, TaskResult, folder_digest, run_task, task_key

__all__ = list(_EXPORTS)
