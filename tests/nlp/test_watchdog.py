"""The solve watchdog (``colloc.solve.watchdog``): a stalled solve is stopped, not waited on.

The stall is made on purpose (a task that sleeps; a Hessian evaluation that sleeps in the
solver's process), so each test knows when the solver went quiet and checks that the
watchdog stopped it within its limit, relayed every report in order, and that
``Problem.solve`` falls back to the limited-memory Hessian and says so.
"""

from __future__ import annotations

import os
import tempfile
import time

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

import colloc
from colloc.solve.watchdog import SolverCrashed, SolverStalled, run_watched, watch_available

pytestmark = pytest.mark.skipif(not watch_available(), reason="needs fork")


def reporting_then_sleeping(report):
    for i in range(2):
        report({"iteration": float(i)})
    time.sleep(60)
    return "never"


def test_a_task_that_stops_reporting_is_killed_within_its_limit():
    t0 = time.perf_counter()
    with pytest.raises(SolverStalled, match="no iteration for 1 s after iteration 2") as err:
        run_watched(reporting_then_sleeping, None, stall_seconds=1.0)
    assert time.perf_counter() - t0 < 10.0  # not the task's 60 s
    assert err.value.iterations == 2


def counting(report):
    for i in range(200):
        time.sleep(0.005)
        if not report({"iteration": float(i)}):
            return i
    return 200


def test_reports_reach_the_progress_callback_in_order_and_false_stops_the_task():
    seen = []

    def progress(row):
        seen.append(row["iteration"])
        return len(seen) < 5

    stopped_at = run_watched(counting, progress, stall_seconds=10.0)
    assert 4 <= stopped_at < 200  # stopped at the first report after the parent said so
    assert seen == [float(i) for i in range(len(seen))]
    assert run_watched(counting, None, stall_seconds=10.0) == 200


def failing(report):
    raise ValueError("bad value in the child")


def test_errors_in_the_task_are_raised_here_with_the_childs_traceback():
    with pytest.raises(ValueError, match="bad value in the child") as err:
        run_watched(failing, None, stall_seconds=5.0)
    assert any("watched solver process" in note for note in err.value.__notes__)


def crashing(report):
    report({"iteration": 0.0})
    os.abort()  # as a segfault in the linear solver would end the process


def test_a_solver_that_crashes_leaves_this_process_running_with_a_clear_error():
    with pytest.raises(RuntimeError, match=r"ended without a result \(exit code -6"):
        run_watched(crashing, None, stall_seconds=5.0)


def decay_problem(cache=True):
    """``x' = -k x`` tracked on noisy data: k = 0.7."""
    xs = dynamicsymbols("x")
    k = sm.Symbol("k")
    model = colloc.Model.from_equations([xs.diff() + k * xs], [xs])
    times = np.linspace(0.0, 3.0, 61)
    data = np.exp(-0.7 * times) + np.random.default_rng(1).normal(0.0, 0.01, times.size)
    problem = colloc.Problem(model, times, objective=colloc.Tracking({xs: data}), cache=cache)
    return problem, problem.initial_guess({xs: data}, {k: 0.2}), k


@pytest.mark.parametrize("from_cache", [True, False])
def test_a_crash_after_a_cache_load_says_the_cache_may_be_at_fault(
    tmp_path, from_cache, monkeypatch
):
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    decay_problem(cache=tmp_path)  # the first build writes the entry
    problem, z0, _ = decay_problem(cache=tmp_path if from_cache else False)
    assert problem.cache_hit is from_cache
    parent = os.getpid()
    objective = problem.nlp.objective

    def crash_in_the_solver(z):
        if os.getpid() != parent:
            os.abort()  # as native code loaded from a bad entry would end the process
        return objective(z)

    problem.nlp.objective = crash_in_the_solver
    with pytest.raises(SolverCrashed, match=r"exit code -6") as err:
        problem.solve(z0, print_level=0, stall_seconds=10.0)
    notes = " ".join(getattr(err.value, "__notes__", []))
    assert ("colloc cache clear" in notes) is from_cache
    # the crashed child's IPOPT log folder does not stay behind (it did, one per crash)
    assert list(scratch.iterdir()) == []


def test_a_stalled_exact_solve_is_solved_again_with_the_limited_memory_hessian():
    problem, z0, k = decay_problem()
    # unwatched, the solve runs in this process and is not stopped
    unwatched = problem.solve(z0, print_level=0, stall_seconds=None)
    assert unwatched.status.notes == ()
    assert unwatched.stats["ipopt_options"]["watchdog_seconds"] is None
    assert unwatched.parameters[k] == pytest.approx(0.7, rel=0.05)

    exact_hessian = problem.nlp.hessian
    parent = os.getpid()

    def slow_in_the_solver(z, lagrange, obj_factor):
        if os.getpid() != parent:  # the watched child: the linear algebra "hangs"
            time.sleep(30)
        return exact_hessian(z, lagrange, obj_factor)

    problem.nlp.hessian = slow_in_the_solver
    t0 = time.perf_counter()
    solution = problem.solve(z0, print_level=0, stall_seconds=1.0)
    assert time.perf_counter() - t0 < 20.0
    assert solution.success
    assert solution.parameters[k] == pytest.approx(unwatched.parameters[k], rel=1e-6)
    assert len(solution.status.notes) == 1
    assert "exact-Hessian solve was stopped by the watchdog" in str(solution.status)
    assert solution.stats["ipopt_options"]["hessian_approximation"] == "limited-memory"
    assert solution.stats["ipopt_options"]["watchdog_seconds"] == 1.0


def test_stall_seconds_is_validated():
    problem, z0, _ = decay_problem()
    with pytest.raises(ValueError, match="stall_seconds: expected a positive number"):
        problem.solve(z0, stall_seconds=0.0)


ORPHAN_SCRIPT = """
import os, sys, time
from colloc.solve.watchdog import run_watched

def task(report):
    with open(sys.argv[1], "w") as f:
        f.write(str(os.getpid()))
    while True:  # reports far faster than anyone reads: blocks in the pipe write
        report({"iteration": 0.0, "padding": "x" * 100000})

run_watched(task, lambda row: time.sleep(3600), stall_seconds=3600)
"""


def test_the_solver_process_dies_with_a_killed_parent(tmp_path):
    import signal
    import subprocess
    import sys

    pid_file = tmp_path / "child.pid"
    parent = subprocess.Popen([sys.executable, "-c", ORPHAN_SCRIPT, str(pid_file)])
    try:
        deadline = time.monotonic() + 60
        while not (pid_file.is_file() and pid_file.read_text()) and time.monotonic() < deadline:
            time.sleep(0.05)
        child = int(pid_file.read_text())
        time.sleep(0.5)  # the child is now blocked writing to the pipe
        os.kill(child, 0)  # alive before
        parent.send_signal(signal.SIGKILL)
        parent.wait(timeout=10)
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline:
            try:
                os.kill(child, 0)
            except ProcessLookupError:
                break
            with open(f"/proc/{child}/stat") as stat:  # a zombie waiting for init is dead
                if stat.read().split(") ")[1].startswith("Z"):
                    break
            time.sleep(0.05)
        else:
            os.kill(child, signal.SIGKILL)
            pytest.fail("the solver process outlived its killed parent by 5 s")
    finally:
        if parent.poll() is None:
            parent.kill()
