"""A solve that cannot hang: IPOPT in a forked child, killed when it stops reporting.

IPOPT's ``max_wall_time`` and a ``False`` from the iteration callback act between
iterations only. Inside one linear-solver call nothing in the process can stop it: on an
ill-conditioned KKT matrix MUMPS can refactorise with twice the workspace up to twenty
times in one call, each factorisation slower than the last (measured on a constrained
pendulum from an inconsistent guess: 2 s, 9 s, 29 s, ...). So the solve runs in a child
process made by ``fork`` (it shares the built functions; nothing is pickled on the way in),
which reports every iteration through a pipe; the parent hands each report to the progress
callback and kills the child when no report has come for the stall limit. The result comes
back pickled.
"""

from __future__ import annotations

import contextlib
import ctypes
import multiprocessing
import os
import signal
import sys
import time
import traceback
from collections.abc import Callable
from typing import Any, TypeVar

T = TypeVar("T")
Report = Callable[[dict[str, float]], object]

#: The stall limit grows with the slowest iteration seen: at least this many times it.
SLOWEST_ITERATION_FACTOR = 10.0


class SolverStalled(RuntimeError):
    """The solver reported no iteration for longer than the stall limit and was stopped.

    Attributes
    ----------
    seconds : float
        The limit that was exceeded.
    iterations : int
        Iterations reported before the stall.
    """

    def __init__(self, seconds: float, iterations: int) -> None:
        super().__init__(
            f"the solver reported no iteration for {seconds:.0f} s after iteration "
            f"{iterations} (most likely inside one linear-solver call on an ill-conditioned "
            "KKT matrix) and was stopped; try hessian='limited-memory', a start consistent "
            "with the equations, or scaling"
        )
        self.seconds = seconds
        self.iterations = iterations


class SolverCrashed(RuntimeError):
    """The solver's process ended without a result (killed by a signal or a native crash).

    Attributes
    ----------
    exitcode : int or None
        The child's exit code (negative: the signal that ended it).
    """

    def __init__(self, exitcode: int | None) -> None:
        super().__init__(
            f"the solver process ended without a result (exit code {exitcode}: it crashed, "
            "e.g. in the linear solver); this process is unharmed"
        )
        self.exitcode = exitcode


def watch_available() -> bool:
    """Whether solves can run in a watched child here (``fork`` exists; not a daemon).

    Returns
    -------
    bool
    """
    return (
        "fork" in multiprocessing.get_all_start_methods()
        and not multiprocessing.current_process().daemon
    )


def run_watched(
    task: Callable[[Report], T],
    progress: Report | None,
    stall_seconds: float,
) -> T:
    """Run ``task(report)`` in a forked child; stop it when it stops reporting.

    Parameters
    ----------
    task : callable
        Runs the solve, calling ``report(row)`` after each iteration and stopping when it
        returns False. Its return value must pickle.
    progress : callable, optional
        Called in this process with each reported row; returning ``False`` stops the solve
        (at the child's next iteration).
    stall_seconds : float
        Longest wait for a report, raised to ``SLOWEST_ITERATION_FACTOR`` times the slowest
        interval between reports seen so far (so slow but steady solves are not stopped).

    Returns
    -------
    The task's return value.

    Raises
    ------
    SolverStalled
        When no report came in time (the child is killed).
    Exception
        Whatever the task raised, with the child's traceback as a note.
    """
    context = multiprocessing.get_context("fork")
    parent_end, child_end = context.Pipe(duplex=True)
    child = context.Process(
        target=_child, args=(task, child_end, parent_end, os.getpid()), daemon=True
    )
    child.start()
    child_end.close()
    limit, slowest, iterations, stopping = stall_seconds, 0.0, 0, False
    try:
        while True:
            waited = _wait(parent_end, limit)
            if waited is None:
                raise SolverStalled(limit, iterations)
            try:
                kind, payload = parent_end.recv()
            except EOFError:
                child.join(timeout=5)
                raise SolverCrashed(child.exitcode) from None
            if kind == "row":
                iterations += 1
                slowest = max(slowest, waited)
                limit = max(stall_seconds, SLOWEST_ITERATION_FACTOR * slowest)
                go_on = progress is None or progress(payload) is not False
                if not go_on and not stopping:
                    stopping = True
                    with contextlib.suppress(OSError):  # the child may be done already
                        parent_end.send("stop")
                continue
            if kind == "error":
                raise payload
            return payload  # type: ignore[no-any-return]
    finally:
        if child.is_alive():
            child.kill()
        child.join()
        parent_end.close()


def _wait(connection: Any, seconds: float) -> float | None:
    """Seconds waited until ``connection`` had something, or None after ``seconds``."""
    start = time.perf_counter()
    if connection.poll(seconds):
        return time.perf_counter() - start
    return None


#: ``prctl`` option that sends the calling process a signal when its parent dies (Linux).
_PR_SET_PDEATHSIG = 1


def _die_with_parent(parent: int) -> None:
    """Have the kernel SIGKILL this process when ``parent`` dies (Linux), and leave at once
    if it already has: a solver orphaned by a killed colloc must not run on, or block for
    good writing to a pipe nobody reads."""
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL))
    if os.getppid() != parent:
        os._exit(1)


def _child(task: Callable[[Report], Any], connection: Any, parent_end: Any, parent: int) -> None:
    """The child's side: run the task, reporting each iteration and then the outcome.

    The fork copied the parent's end of the pipe into the child; it is closed first, so that
    the parent's death closes the pipe for good (the child's writes then fail instead of
    waiting for a reader that is its own copy).
    """
    parent_end.close()
    _die_with_parent(parent)

    def report(row: dict[str, float]) -> bool:
        connection.send(("row", row))
        return not (connection.poll() and connection.recv() == "stop")

    try:
        outcome: tuple[str, Any] = ("result", task(report))
    except BaseException as exc:  # noqa: BLE001 - every failure goes back to the parent
        exc.add_note("in the watched solver process:\n" + traceback.format_exc())
        outcome = ("error", exc)
    try:
        connection.send(outcome)
    except Exception as exc:  # noqa: BLE001 - an outcome that does not pickle
        connection.send(("error", RuntimeError(f"the solver's outcome did not pickle: {exc}")))
    connection.close()
