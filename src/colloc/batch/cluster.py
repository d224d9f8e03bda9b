"""A Dask client: a local cluster of one-thread worker processes, or a running scheduler.

Workers have one thread each (IPOPT and MUMPS use one core here) and are not daemons, so a
solve in a worker can still fork the watched IPOPT child (:mod:`colloc.solve.watchdog`).
"""

from __future__ import annotations

import logging
import os
import warnings
from collections.abc import Callable, Iterator
from concurrent.futures import CancelledError
from contextlib import contextmanager
from typing import Any

import dask
from distributed import Client, KilledWorker, LocalCluster

#: Seconds to reach a scheduler before its address is reported as unusable.
CONNECT_TIMEOUT = 20


class SchedulerError(ConnectionError):
    """A Dask scheduler address that could not be used (named in the message)."""


class WorkersLostError(RuntimeError):
    """The workers lost a task's data or process before it finished (named in the message)."""


def default_workers() -> int:
    """Workers of the local cluster by default: one per core."""
    return max(1, os.cpu_count() or 1)


@contextmanager
def dask_client(workers: int | None = None, scheduler: str | None = None) -> Iterator[Client]:
    """A Dask client, closed (with its local cluster) on leaving.

    Parameters
    ----------
    workers : int, optional
        Worker processes of the local cluster (default :func:`default_workers`); ignored
        with ``scheduler``.
    scheduler : str, optional
        Address of a running Dask scheduler (``"tcp://host:8786"``); its workers must have
        colloc installed.

    Yields
    ------
    distributed.Client
    """
    cluster = None
    if scheduler is None:
        # The scheduler's HTTP endpoint moves off a busy port 8787 with a warning that means
        # nothing here (two clusters at once); the dashboard itself is off.
        with (
            dask.config.set({"distributed.worker.daemon": False}),
            warnings.catch_warnings(),
        ):
            warnings.filterwarnings("ignore", message="Port .* is already in use")
            cluster = LocalCluster(
                n_workers=workers or default_workers(),
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.ERROR,
            )
    try:
        client = Client(cluster if cluster is not None else scheduler, timeout=CONNECT_TIMEOUT)
    except Exception as error:  # a wrong address fails in many ways inside distributed
        if cluster is not None:
            cluster.close()
            raise
        raise SchedulerError(
            f"scheduler: could not use the Dask scheduler at {scheduler!r} "
            f"({type(error).__name__}: {str(error).splitlines()[0] if str(error) else 'no answer'}"
            "); check the address (tcp://host:8786) and that the scheduler is running"
        ) from error
    try:
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def client_map(client: Client) -> Callable[[Callable[[Any], Any], list[Any]], list[Any]]:
    """``map(function, items) -> results`` on the client's workers, in the items' order.

    Parameters
    ----------
    client : distributed.Client

    Returns
    -------
    callable
        Scatters the items to the workers, submits one task per item (``pure=False``: every
        item runs) and gathers them; a task's exception is raised here, and a task the
        workers lost (a worker that died or was removed) as :class:`WorkersLostError`.
    """

    def run(function: Callable[[Any], Any], items: list[Any]) -> list[Any]:
        # the items travel to the workers as data of their own, not inside the task graph
        # (a trial's windows are about 0.4 MB each: in the graph Dask warns of its size)
        futures = client.map(function, client.scatter(items), pure=False)
        try:
            return list(client.gather(futures))
        except (CancelledError, KilledWorker) as error:
            # a worker that died, or stopped answering long enough to be removed (measured:
            # a run suspended for 22 minutes lost its scattered windows), takes its tasks'
            # data with it; distributed reports a cancelled future, not the cause
            client.cancel(futures)
            name = getattr(function, "__name__", repr(function))
            raise WorkersLostError(
                f"workers: the Dask workers lost a task of {name} before it finished "
                f"({type(error).__name__}: {error}); a worker died or stopped "
                "answering (out of memory, killed or suspended). Nothing was written: run "
                "again, with fewer workers if memory ran short"
            ) from error
        except BaseException:
            client.cancel(futures)
            raise

    return run
