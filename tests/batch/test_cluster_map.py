"""client_map: a task the workers lose is reported as such, not as distributed's bare error."""

from __future__ import annotations

import os

import dask
import pytest

from colloc.batch.cluster import WorkersLostError, client_map, dask_client


def _square(x: int) -> int:
    return x * x


def _dies(x: int) -> int:
    os._exit(1)  # the worker process ends in the middle of the task


def test_a_worker_that_dies_is_named_and_the_results_of_a_sound_map_come_in_order():
    # the scheduler gives up on a task after its first lost worker (default: 3 retries)
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        with dask_client(workers=1) as client:
            run = client_map(client)
            assert run(_square, [3, 1, 2]) == [9, 1, 4]
            with pytest.raises(WorkersLostError, match=r"lost a task of _dies .*KilledWorker"):
                run(_dies, [1])
