"""One run of a batch, as a worker carries it out: compute, store, write its outputs.

A :class:`Task` holds validated settings of one kind; :func:`run_task` runs it in whatever
process it lands in (a Dask worker, or this one), stores the run in the results database in
one transaction, writes the figures and summary it asks for, and returns a
:class:`TaskResult`. Every error of the run is caught and returned, so that a failed run is
recorded with its error and the batch goes on. The runners are found by kind in
:data:`RUNNERS`.
"""

from __future__ import annotations

import hashlib
import os
import time
import traceback
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from colloc.store.ids import canonical_json, package_versions


@dataclass(frozen=True)
class Task:
    """One run for a worker.

    Attributes
    ----------
    position : int
        The entry's index in the batch.
    kind : str
        A key of :data:`RUNNERS`.
    settings : object
        Validated settings of that kind (``PendulumSettings``, ``GaitIdentifySettings``,
        ``GaitSimulationSettings``).
    key : str
        Equal for two tasks that compute the same run (see :func:`task_key`).
    after : tuple of int
        Positions of the entries this one needs first (the simulation that writes its trial).
    out : Path or None
        Folder for figures (and the summary) when ``plot`` or ``animate``.
    plot, animate : bool
        Write the run's figures / animation into ``out``.
    json : Path or None
        Write the run's summary here.
    """

    position: int
    kind: str
    settings: Any
    key: str
    after: tuple[int, ...] = ()
    out: Path | None = None
    plot: bool = False
    animate: bool = False
    json: Path | None = None


@dataclass(frozen=True)
class TaskResult:
    """What became of one task.

    Attributes
    ----------
    position : int
    status : str
        ``"done"``, ``"failed"`` or ``"skipped"`` (done before: nothing was run).
    run_id : str or None
        The stored run (None for a simulation, which stores no run, or a failure).
    output : str or None
        The folder written (a simulated trial, figures), if any.
    error : str or None
        Why it failed.
    seconds : float
        Wall time in the worker.
    cache_hit : bool or None
        Whether the collocation problem came from the build cache (None: not known).
    notes : tuple of str
        The run's notes (a fallback taken, a suspicious fit).
    pid : int or None
        The process that ran it (a Dask worker's).
    """

    position: int
    status: str
    run_id: str | None = None
    output: str | None = None
    error: str | None = None
    seconds: float = 0.0
    cache_hit: bool | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)
    pid: int | None = None


def folder_digest(folder: str | os.PathLike[str]) -> str | None:
    """A digest of a folder's file names, sizes and modification times (None if absent).

    Parameters
    ----------
    folder : path-like

    Returns
    -------
    str or None
    """
    path = Path(folder)
    if not path.is_dir():
        return None
    listing = sorted(
        (p.name, p.stat().st_size, p.stat().st_mtime_ns) for p in path.iterdir() if p.is_file()
    )
    return hashlib.sha256(repr(listing).encode()).hexdigest()


def task_key(kind: str, settings: Mapping[str, Any], inputs: Mapping[str, Any]) -> str:
    """The key under which a task's work is found done: a hash of what determines it.

    Parameters
    ----------
    kind : str
    settings : mapping
        The settings as plain values.
    inputs : mapping
        What else determines the run: e.g. the trial folder's :func:`folder_digest`, or the
        key of the batch entry that will write it.

    Returns
    -------
    str
        A SHA-256 hex digest, which also covers the package versions.
    """
    text = canonical_json(
        {"kind": kind, "settings": dict(settings), "inputs": dict(inputs)}, "task"
    ) + canonical_json(package_versions(), "versions")
    return hashlib.sha256(text.encode()).hexdigest()


def run_task(
    task: Task, url: str | None, *needed: TaskResult, batch_id: str | None = None
) -> TaskResult:
    """Run one task: compute, store (when ``url``), write outputs; never raise for the run.

    Parameters
    ----------
    task : Task
    url : str or None
        The results database; None stores nothing.
    *needed : TaskResult
        Results of the tasks in ``task.after`` (Dask passes them in once they are done); a
        failed one fails this task without running it.
    batch_id : str, optional
        The batch this task is an entry of: a stored run marks its entry in the same
        transaction (:meth:`colloc.store.RunStore.add`).

    Returns
    -------
    TaskResult
        ``"done"``, or ``"failed"`` with the error's type, message and last frame.
    """
    start = time.perf_counter()
    for before in needed:
        if before.status not in ("done", "skipped"):
            return TaskResult(
                task.position,
                "failed",
                error=f"entry {before.position}, which this one needs, failed: {before.error}",
            )
    try:
        result = RUNNERS[task.kind](task, url, batch_id)
    except Exception as error:  # noqa: BLE001 - a failed run is recorded, the batch goes on
        frame = traceback.extract_tb(error.__traceback__)[-1:]
        place = f" (at {frame[0].filename}:{frame[0].lineno})" if frame else ""
        return TaskResult(
            task.position,
            "failed",
            error=f"{type(error).__name__}: {error}{place}",
            seconds=time.perf_counter() - start,
            pid=os.getpid(),
        )
    return TaskResult(
        task.position,
        result.status,
        run_id=result.run_id,
        output=result.output,
        error=result.error,
        seconds=time.perf_counter() - start,
        cache_hit=result.cache_hit,
        notes=result.notes,
        pid=os.getpid(),
    )


def _store(url: str | None, record: Any, entry: tuple[str, int, str] | None) -> None:
    """Store the run; with ``entry`` (batch id, position, status), mark the entry with it."""
    if url is None:
        return
    from colloc.store import RunStore

    with RunStore(url) as store:
        store.add(record, replace=True, batch_entry=entry)


def _entry(task: Task, batch_id: str | None, success: bool) -> tuple[str, int, str] | None:
    return None if batch_id is None else (batch_id, task.position, "done" if success else "failed")


def _run_pendulum(task: Task, url: str | None, batch_id: str | None) -> TaskResult:
    from colloc.identify.pendulum.outputs import (
        pendulum_record,
        pendulum_run_id,
        pendulum_summary,
        save_pendulum_animation,
        save_pendulum_plots,
    )
    from colloc.identify.pendulum.workflow import run_pendulum
    from colloc.identify.summaries import write_json_atomic

    run = run_pendulum(task.settings)
    run_id = pendulum_run_id(run)
    success = bool(run.solution.stats["success"])
    _store(url, pendulum_record(run, run_id), _entry(task, batch_id, success))
    if task.out is not None and task.plot:
        save_pendulum_plots(run, task.out)
    if task.out is not None and task.animate:
        save_pendulum_animation(run, task.out / "pendulum.gif")
    if task.json is not None:
        write_json_atomic(pendulum_summary(run, run_id), task.json)
    written = task.out is not None and (task.plot or task.animate)
    return TaskResult(
        task.position,
        "done" if success else "failed",
        run_id=run_id,
        output=os.fspath(task.out) if written and task.out is not None else None,
        error=None if success else f"IPOPT: {run.solution.stats['message']}",
        cache_hit=bool(run.problem.cache_hit),
        notes=tuple(run.notes),
    )


def _run_gait_identify(task: Task, url: str | None, batch_id: str | None) -> TaskResult:
    from colloc.identify.gait.outputs import gait_record, gait_run_id, gait_summary, save_gait_plots
    from colloc.identify.gait.workflow import identify_gait
    from colloc.identify.summaries import write_json_atomic

    run = identify_gait(task.settings)
    run_id = gait_run_id(run)
    success = bool(run.solver["success"])
    _store(url, gait_record(run, run_id), _entry(task, batch_id, success))
    if task.out is not None and task.plot:
        save_gait_plots(run, task.out)
    if task.json is not None:
        write_json_atomic(gait_summary(run, run_id), task.json)
    return TaskResult(
        task.position,
        "done" if success else "failed",
        run_id=run_id,
        output=os.fspath(task.out) if task.out is not None and task.plot else None,
        error=None if success else f"solver: {run.solver['status']}",
        notes=tuple(run.notes),
    )


def _run_gait_simulate(task: Task, url: str | None, batch_id: str | None) -> TaskResult:
    from colloc.gait.workflow import simulate_trial

    result = simulate_trial(task.settings)
    folder = os.fspath(task.settings.out)
    if result.fell:
        outcome = TaskResult(
            task.position,
            "failed",
            output=folder,
            error=f"the walker fell ({result.summary['message']}); the trial in {folder} is short",
        )
    else:
        outcome = TaskResult(task.position, "done", output=folder, notes=tuple(result.notes))
    if url is not None and batch_id is not None:  # the folder is whole: the entry is done
        from colloc.store import RunStore

        with RunStore(url) as store:
            store.batches.record(
                batch_id, task.position, outcome.status, output=folder, error=outcome.error
            )
    return outcome


RUNNERS: dict[str, Callable[[Task, str | None, str | None], TaskResult]] = {
    "pendulum": _run_pendulum,
    "gait-identify": _run_gait_identify,
    "gait-simulate": _run_gait_simulate,
}
"""The runner of each kind of task."""
