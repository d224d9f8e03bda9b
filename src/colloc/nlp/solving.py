"""One watched IPOPT solve of an assembled NLP, with the fallback and notes a user needs.

Shared by :meth:`colloc.Problem.solve` and :meth:`colloc.Trials.solve`: the start is checked
(shape, finite, inside the bounds), an objective whose curvature is far above the
constraints' is scaled down for IPOPT (:func:`objective_scaling`), a solve the watchdog
stops is solved again with the limited-memory Hessian (and says so), and a crash of
functions loaded from the build cache says how to clear it.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from colloc.solve.ipopt import solve_nlp
from colloc.solve.result import NLP, SolveResult
from colloc.solve.watchdog import SolverCrashed, SolverStalled


def checked_guess(
    initial_guess: np.ndarray, size: int, describe: Callable[[int], str]
) -> np.ndarray:
    """``initial_guess`` as a float vector of ``size`` finite values.

    Parameters
    ----------
    initial_guess : array_like
    size : int
    describe : callable
        Index -> the variable's name, for the error.

    Returns
    -------
    ndarray

    Raises
    ------
    ValueError
        Naming the expected shape, or the first value that is not finite and its variable.
    """
    z0 = np.asarray(initial_guess, dtype=float)
    if z0.shape != (size,):
        raise ValueError(f"initial_guess: expected shape ({size},), found {z0.shape}")
    if not np.all(np.isfinite(z0)):
        bad = int(np.flatnonzero(~np.isfinite(z0))[0])
        raise ValueError(
            f"initial_guess: expected finite values, found {z0[bad]} at index {bad} "
            f"({describe(bad)})"
        )
    return z0


#: How many times the objective's curvature (the largest diagonal entry of its Gauss-Newton
#: Hessian at the start) may exceed the defects' largest Jacobian entry before
#: :func:`objective_scaling` scales the objective down to the defects' scale. Tracking weights
#: of ``1 / sigma^2`` for precise sensors pass it: on the own-model example (a mass on a
#: hardening spring, its position tracked at 1001 nodes; Jacobian entries up to about 100,
#: curvature twice the weight) a weight of 1e8 made MUMPS reallocate its workspace twice
#: (0.31 s against 0.04 s), 1e10 five times (10.8 s against 0.05 s); up to 1e7 it solved as
#: fast unscaled. Measured far below the limit, and left as they were: the pendulum study
#: (ratio 0.007) and the gait smoother (12).
CURVATURE_RATIO_LIMIT = 1e4


def objective_scaling(nlp: NLP, z0: np.ndarray) -> float | None:
    """IPOPT's ``obj_scaling_factor`` for ``nlp`` started at ``z0``, or None to leave it be.

    IPOPT's own gradient-based scaling looks at the gradient at the start, which vanishes when
    the start fits the data (a start at the measurements); the Hessian ``2 w J^T J`` then
    still dwarfs the defects' Jacobian in the KKT matrix, whose factorisation MUMPS must
    redo with more memory. Scaling the objective by ``max |dc/dz| / max diag`` puts both on
    one scale; the minimiser is the same (the reported objective is IPOPT's unscaled one).

    Parameters
    ----------
    nlp : NLP
    z0 : ndarray
        The start.

    Returns
    -------
    float or None
        The factor when the curvature exceeds :data:`CURVATURE_RATIO_LIMIT` times the
        largest Jacobian entry; None otherwise, or without constraints.
    """
    if nlp.m == 0:
        return None
    rows, cols = nlp.hessianstructure()
    values = nlp.gauss_newton_hessian(z0)
    curvature = float(np.abs(values[np.asarray(rows) == np.asarray(cols)]).max(initial=0.0))
    defects = float(np.abs(nlp.jacobian(z0)).max(initial=0.0))
    if not (np.isfinite(curvature) and np.isfinite(defects) and defects > 0):
        return None
    if curvature <= CURVATURE_RATIO_LIMIT * defects:
        return None
    return defects / curvature


def solve_watched(
    nlp: NLP,
    z0: np.ndarray,
    bounds: tuple[np.ndarray, np.ndarray],
    *,
    hessian: str,
    describe: Callable[[int], str],
    cache_hit: bool,
    progress: Callable[[dict[str, float]], None] | None = None,
    log_path: str | None = None,
    variable_scale: np.ndarray | None = None,
    stall_seconds: float | None = None,
    options: Mapping[str, Any] | None = None,
) -> SolveResult:
    """Solve ``nlp`` from ``z0`` with IPOPT (:func:`colloc.solve.ipopt.solve_nlp`).

    Parameters
    ----------
    nlp : NLP
    z0 : ndarray
        A checked start (:func:`checked_guess`).
    bounds : (ndarray, ndarray)
        Lower and upper bounds of the free vector.
    hessian : str
        As :meth:`colloc.Problem.solve`.
    describe : callable
        Index -> the variable's name, for the warning about a start outside the bounds.
    cache_hit : bool
        Whether the functions came from the build cache (a crash then says how to clear it).
    progress, log_path, variable_scale, stall_seconds, options
        As :func:`colloc.solve.ipopt.solve_nlp`.

    Returns
    -------
    SolveResult
        With a note when the limited-memory solve stood in for a stopped one;
        ``options["obj_scaling_factor"]`` when the objective was scaled
        (:func:`objective_scaling`, unless ``options`` set it).

    Raises
    ------
    SolverStalled
        When the limited-memory solve was stopped too.
    SolverCrashed
        When the solver's process died without a result.

    Warns
    -----
    UserWarning
        When ``z0`` lies outside the bounds.
    """
    lo, hi = bounds
    outside = np.flatnonzero((z0 < lo) | (z0 > hi))
    if outside.size:
        i = int(outside[0])
        warnings.warn(
            f"initial_guess: {outside.size} value(s) outside the bounds, first "
            f"{describe(i)} = {z0[i]:.6g} not in [{lo[i]:.6g}, {hi[i]:.6g}]; IPOPT moves "
            "them inside before its first iteration",
            UserWarning,
            stacklevel=3,
        )

    options = dict(options or {})
    if "obj_scaling_factor" not in options:
        factor = objective_scaling(nlp, z0)
        if factor is not None:
            options["obj_scaling_factor"] = factor

    def run(approximation: str) -> SolveResult:
        return solve_nlp(
            nlp,
            z0,
            lo,
            hi,
            hessian=approximation,
            progress=progress,
            log_path=log_path,
            options=options,
            variable_scale=variable_scale,
            stall_seconds=stall_seconds,
        )

    try:
        return run(hessian)
    except SolverCrashed as crashed:
        if cache_hit:
            crashed.add_note(
                "this problem's functions were loaded from the build cache: if an entry is "
                "at fault, clear it (`colloc cache clear`, or BuildCache().clear()) or build "
                "with cache=False, and report the crash"
            )
        raise
    except SolverStalled as stalled:
        if hessian == "limited-memory":
            raise
        result = run("limited-memory")
        note = (
            f"the {hessian}-Hessian solve was stopped by the watchdog after "
            f"{stalled.iterations} iterations (no iteration for {stalled.seconds:.0f} s); "
            "this is the limited-memory solve from the same initial guess"
        )
        result.status = replace(result.status, notes=result.status.notes + (note,))
        return result
