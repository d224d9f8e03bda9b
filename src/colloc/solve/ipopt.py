"""Drive IPOPT (with MUMPS) on an assembled NLP.

IPOPT's C interface (:mod:`colloc.solve.ipopt_capi`, the library ``cyipopt-wheels`` ships)
calls our vectorised evaluators, and each result reaches IPOPT's buffer in one memmove; a
CasADi ``Callback`` inside ``nlpsol`` would route the same arrays through more layers.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from colloc.solve.ipopt_capi import CProblem
from colloc.solve.result import NLP, SolveResult
from colloc.solve.scaling import ScaledNLP
from colloc.solve.status import status_from_code
from colloc.solve.watchdog import run_watched, watch_available

HESSIAN_CHOICES = ("exact", "limited-memory", "gauss-newton")

#: Default watchdog limit: no solve sits longer than this without finishing an iteration.
STALL_SECONDS = 60.0

DEFAULT_OPTIONS: dict[str, Any] = {
    "tol": 1e-8,
    "max_iter": 3000,
    "mu_strategy": "adaptive",
    "linear_solver": "mumps",
}


class _Callbacks:
    """Adapts an :class:`NLP` to IPOPT's callbacks, recording the iteration history."""

    def __init__(
        self,
        nlp: NLP,
        progress: Callable[[dict[str, float]], object] | None,
        gauss_newton: bool = False,
    ) -> None:
        self.nlp = nlp
        self.progress = progress
        self.history: list[dict[str, float]] = []
        self.objective = nlp.objective
        self.gradient = nlp.gradient
        self.constraints = nlp.constraints
        self.jacobian = nlp.jacobian
        self.jacobianstructure = nlp.jacobianstructure
        self.hessian = self._objective_hessian if gauss_newton else nlp.hessian
        self.hessianstructure = nlp.hessianstructure

    def _objective_hessian(
        self, z: np.ndarray, lagrange: np.ndarray, obj_factor: float
    ) -> np.ndarray:
        # Gauss-Newton: tracking terms by J^T W J, the constraints' curvature left out
        return obj_factor * self.nlp.gauss_newton_hessian(z)

    def intermediate(
        self,
        alg_mod: int,
        iter_count: int,
        obj_value: float,
        inf_pr: float,
        inf_du: float,
        mu: float,
        d_norm: float,
        regularization_size: float,
        alpha_du: float,
        alpha_pr: float,
        ls_trials: int,
    ) -> bool:
        row = {
            "iteration": float(iter_count),
            "objective": float(obj_value),
            "infeasibility": float(inf_pr),
            "dual_infeasibility": float(inf_du),
        }
        self.history.append(row)
        if self.progress is not None:
            return self.progress(row) is not False
        return True


def _scaled_bound(bound: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """``bound / scale`` where finite; IPOPT's infinite bounds (``|b| >= 1e19``) stay so."""
    b = np.asarray(bound, dtype=float)
    return np.where(np.abs(b) >= 1e19, b, b / scale)


def solve_nlp(
    nlp: NLP,
    x0: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    *,
    hessian: str = "exact",
    progress: Callable[[dict[str, float]], object] | None = None,
    log_path: str | os.PathLike[str] | None = None,
    options: Mapping[str, Any] | None = None,
    variable_scale: np.ndarray | None = None,
    stall_seconds: float | None = STALL_SECONDS,
) -> SolveResult:
    """Solve ``min f(z) s.t. g(z) = 0, lower <= z <= upper`` with IPOPT.

    Parameters
    ----------
    nlp : NLP
    x0, lower, upper : ndarray
    hessian : {"exact", "limited-memory", "gauss-newton"}
        ``"gauss-newton"`` passes IPOPT the objective's Gauss-Newton Hessian only (tracking
        terms by ``2 J^T W J``, the constraints' curvature left out).
    progress : callable, optional
        Called after every iteration; returning ``False`` stops the solve.
    log_path : path, optional
        Where to keep IPOPT's log (a temporary file otherwise; its text is returned).
    options : mapping, optional
        IPOPT options, overriding :data:`DEFAULT_OPTIONS`.
    variable_scale : ndarray, optional
        Typical magnitude of each variable (positive): IPOPT then works in ``z / scale``
        (see :mod:`colloc.solve.scaling`). The result is in ``z``.
    stall_seconds : float or None
        Watchdog: the solve runs in a forked child that is stopped when it reports no
        iteration for this long (or ten times its slowest iteration, if longer), since
        nothing stops IPOPT inside one linear-solver call (:mod:`colloc.solve.watchdog`).
        None, or where ``fork`` is unavailable or in a daemonic process, solves in this
        process, unwatched.

    Returns
    -------
    SolveResult
        ``options["watchdog_seconds"]`` records the watchdog's limit (None: unwatched).

    Raises
    ------
    SolverStalled
        When the watchdog stopped the solve.
    """
    if hessian not in HESSIAN_CHOICES:
        raise ValueError(f"hessian: expected one of {HESSIAN_CHOICES}, found {hessian!r}")
    if stall_seconds is not None and not stall_seconds > 0:
        raise ValueError(
            f"stall_seconds: expected a positive number or None, found {stall_seconds!r}"
        )

    # the temporary log's folder belongs to this process: a watched child that is killed
    # (stalled, crashed) cannot clean up after itself
    scratch = None
    if log_path is None:
        sweep_scratch_folders()
        scratch = tempfile.TemporaryDirectory(prefix=f"{SCRATCH_PREFIX}{os.getpid()}-")
        log_file = Path(scratch.name) / "ipopt.log"
    else:
        log_file = Path(log_path)

    def task(report: Callable[[dict[str, float]], object] | None) -> SolveResult:
        return _solve(nlp, x0, lower, upper, hessian, report, log_file, options, variable_scale)

    try:
        if stall_seconds is None or not watch_available():
            result = task(progress)
            result.options["watchdog_seconds"] = None
            return result
        result = run_watched(task, progress, float(stall_seconds))
        result.options["watchdog_seconds"] = float(stall_seconds)
        return result
    finally:
        if scratch is not None:
            scratch.cleanup()


#: A solve's temporary log folder is named ``colloc-ipopt-<pid>-<random>`` after its process.
SCRATCH_PREFIX = "colloc-ipopt-"


def sweep_scratch_folders(root: str | os.PathLike[str] | None = None) -> list[Path]:
    """Remove the temporary log folders of solves whose process is gone.

    A process killed mid-solve (a Dask worker lost, ``SIGKILL``) cannot remove its folder,
    and a killed solve's log can be large. Each folder names its process; one whose process
    no longer exists is removed by the next solve. A folder of a live process, of another
    user, or without a process id in its name is left alone.

    Parameters
    ----------
    root : path, optional
        Where the folders are; default the temporary directory.

    Returns
    -------
    list of Path
        The folders removed.
    """
    if os.name != "posix":  # os.kill(pid, 0) asks about a process only on POSIX
        return []
    base = Path(tempfile.gettempdir() if root is None else root)
    removed = []
    for folder in base.glob(f"{SCRATCH_PREFIX}*-*"):
        pid_text = folder.name[len(SCRATCH_PREFIX) :].split("-", 1)[0]
        if not pid_text.isdigit() or not folder.is_dir() or folder.stat().st_uid != os.getuid():
            continue
        try:
            os.kill(int(pid_text), 0)
        except ProcessLookupError:
            shutil.rmtree(folder, ignore_errors=True)
            removed.append(folder)
        except PermissionError:
            continue  # a live process of someone else
    return removed


def _solve(
    nlp: NLP,
    x0: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    hessian: str,
    progress: Callable[[dict[str, float]], object] | None,
    log_path: str | os.PathLike[str],
    options: Mapping[str, Any] | None,
    variable_scale: np.ndarray | None,
) -> SolveResult:
    """One IPOPT solve in this process (see :func:`solve_nlp`), its log written to ``log_path``."""
    approximation = "limited-memory" if hessian == "limited-memory" else "exact"
    opts = {**DEFAULT_OPTIONS, "hessian_approximation": approximation, **dict(options or {})}
    scale = np.ones(nlp.n) if variable_scale is None else np.asarray(variable_scale, float)
    inner: NLP = nlp if variable_scale is None else ScaledNLP(nlp, scale)
    lower, upper = _scaled_bound(lower, scale), _scaled_bound(upper, scale)
    callbacks = _Callbacks(inner, progress, gauss_newton=hessian == "gauss-newton")
    problem = CProblem(nlp.n, nlp.m, callbacks, lower, upper, np.zeros(nlp.m), np.zeros(nlp.m))
    log_file = Path(log_path)
    log_file.parent.mkdir(parents=True, exist_ok=True)
    opts.setdefault("print_level", 0)
    opts.setdefault("file_print_level", 5)
    opts["output_file"] = str(log_file)
    opts.setdefault("sb", "yes")
    try:
        for key, value in opts.items():
            try:
                problem.add_option(key, value)
            except TypeError as exc:
                raise ValueError(f"ipopt option {key}={value!r} was refused: {exc}") from exc
        t0 = time.perf_counter()
        x, info = problem.solve(np.asarray(x0, dtype=float) / scale)
        elapsed = time.perf_counter() - t0
        log = log_file.read_text(errors="replace") if log_file.is_file() else ""
    finally:
        problem.close()
    g = np.asarray(info["g"], dtype=float)
    iterations = int(callbacks.history[-1]["iteration"]) if callbacks.history else 0
    return SolveResult(
        x=scale * np.asarray(x, dtype=float),
        status=status_from_code(int(info["status"])),
        objective=float(info["obj_val"]),
        constraint_violation=float(np.max(np.abs(g))) if g.size else 0.0,
        iterations=iterations,
        solve_time=elapsed,
        multipliers=np.asarray(info["mult_g"], dtype=float),
        log=log,
        history=callbacks.history,
        options={k: v for k, v in opts.items() if k != "output_file"},
    )
