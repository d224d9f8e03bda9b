"""Running a batch on Dask distributed: a local cluster by default, or a running one.

Each task is one run (:func:`colloc.batch.tasks.run_task`); workers have one thread each
(IPOPT and MUMPS use one core here) and are not daemons, so a solve in a worker still runs
under the watchdog. The workers store their runs themselves, each in one transaction; this
process records the fate of every entry in the batch record as results arrive, so a batch
stopped at any point (Ctrl-C, a killed worker, a killed client) keeps every finished run, and
running it again skips them (same entry keys) and does the rest.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from distributed import as_completed

from colloc.batch.cluster import dask_client
from colloc.batch.tasks import Task, TaskResult, run_task
from colloc.store.ids import canonical_json
from colloc.store.runs import RunStore


@dataclass
class BatchOutcome:
    """What a batch did.

    Attributes
    ----------
    batch_id : str
    results : dict
        Position -> :class:`TaskResult`, for every entry that ended (skipped ones too).
    cancelled : bool
        True when the batch was interrupted; entries without a result were cancelled.
    workers : int
        How many workers ran it.
    """

    batch_id: str
    results: dict[int, TaskResult] = field(default_factory=dict)
    cancelled: bool = False
    workers: int = 0

    def count(self, status: str) -> int:
        """How many entries ended with ``status``."""
        return sum(r.status == status for r in self.results.values())


def batch_id_for(tasks: Sequence[Task]) -> str:
    """The id of a batch: a hash of its entries' kinds and keys, in order.

    Parameters
    ----------
    tasks : sequence of Task

    Returns
    -------
    str
        The same for the same batch file run again with the same package versions.
    """
    text = canonical_json([[t.kind, t.key] for t in tasks], "batch")
    return hashlib.sha256(text.encode()).hexdigest()


def run_batch(
    tasks: Sequence[Task],
    url: str,
    *,
    spec: Mapping[str, Any] | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    on_start: Callable[[int, int], None] | None = None,
    on_result: Callable[[TaskResult], None] | None = None,
    allow_other_tables: bool = False,
) -> BatchOutcome:
    """Run a batch of tasks on Dask and record it in the results store.

    Parameters
    ----------
    tasks : sequence of Task
        Positions ``0 .. len - 1`` in order; ``after`` names earlier positions only.
    url : str
        The results database (opened and checked writable before anything runs).
    spec : mapping, optional
        The batch as written, kept in its record.
    workers : int, optional
        Workers of the local cluster (default :func:`colloc.batch.cluster.default_workers`); ignored with
        ``scheduler``.
    scheduler : str, optional
        Address of a running Dask scheduler (``"tcp://host:8786"``); its workers must reach
        ``url`` and the files the tasks read and write.
    on_start : callable, optional
        ``on_start(to_run, skipped)`` once the skipped entries are known.
    on_result : callable, optional
        Called with each :class:`TaskResult` as it arrives (skipped entries first).
    allow_other_tables : bool, optional
        Let colloc's tables go into a database that holds other tables
        (:class:`colloc.store.RunStore`).

    Returns
    -------
    BatchOutcome

    Raises
    ------
    ValueError
        If the positions or dependencies are malformed.
    colloc.store.StoreURLError
        If the database cannot be opened or written (before anything runs).
    KeyboardInterrupt
        After cancelling the remaining tasks and recording the batch (and its unfinished
        entries) cancelled; the same for any other exception while waiting.
    """
    _check_tasks(tasks)
    say = on_result or (lambda result: None)
    store = RunStore(url, allow_other_tables=allow_other_tables)
    try:
        store.check_writable()
        batch_id = batch_id_for(tasks)
        log = store.batches
        log.start(
            batch_id,
            dict(spec or {}),
            [{"kind": t.kind, "entry_key": t.key, "settings": _plain(t.settings)} for t in tasks],
        )
        outcome = BatchOutcome(batch_id)
        done = log.done([t.key for t in tasks])
        for task in tasks:
            if task.key in done:
                found = done[task.key]
                result = TaskResult(
                    task.position, "skipped", run_id=found["run_id"], output=found["output"]
                )
                log.record(batch_id, task.position, "skipped", **found)
                outcome.results[task.position] = result
        remaining = [t for t in tasks if t.position not in outcome.results]
        if on_start is not None:
            on_start(len(remaining), len(outcome.results))
        for result in outcome.results.values():
            say(result)
        if remaining:
            _run_on_dask(remaining, outcome, url, workers, scheduler, log, say)
        log.finish(batch_id, "cancelled" if outcome.cancelled else "finished")
        return outcome
    finally:
        store.close()


def _run_on_dask(
    tasks: Sequence[Task],
    outcome: BatchOutcome,
    url: str,
    workers: int | None,
    scheduler: str | None,
    log: Any,
    say: Callable[[TaskResult], None],
) -> None:
    with dask_client(workers, scheduler) as client:
        outcome.workers = len(client.scheduler_info()["workers"])
        futures: dict[int, Any] = {}
        for task in tasks:
            needed = [futures[p] for p in task.after if p in futures]
            futures[task.position] = client.submit(
                run_task,
                task,
                url,
                *needed,
                batch_id=outcome.batch_id,
                key=f"colloc-{outcome.batch_id[:12]}-{task.position}",
                pure=False,
            )
        position_of = {future.key: position for position, future in futures.items()}
        try:
            for future in as_completed(list(futures.values())):
                position = position_of[future.key]
                try:
                    result = future.result()
                except Exception as error:  # noqa: BLE001 - e.g. KilledWorker: recorded
                    result = TaskResult(
                        position, "failed", error=f"{type(error).__name__}: {error}"
                    )
                log.record(
                    outcome.batch_id,
                    position,
                    result.status,
                    run_id=result.run_id,
                    output=result.output,
                    error=result.error,
                    seconds=result.seconds,
                )
                outcome.results[position] = result
                say(result)
        except BaseException:  # Ctrl-C, a kill turned into an exception, a store failure
            outcome.cancelled = True
            client.cancel(list(futures.values()))
            log.finish(outcome.batch_id, "cancelled")
            raise


def _check_tasks(tasks: Sequence[Task]) -> None:
    problems = []
    for expected, task in enumerate(tasks):
        if task.position != expected:
            problems.append(f"tasks[{expected}]: position {task.position}, expected {expected}")
        late = [p for p in task.after if not 0 <= p < expected]
        if late:
            problems.append(f"tasks[{expected}]: after {late} names no earlier entry")
    if problems:
        raise ValueError("tasks: " + "; ".join(problems))


def _plain(settings: Any) -> Any:
    """The settings as plain JSON-ready values."""
    return settings.to_dict() if hasattr(settings, "to_dict") else settings
