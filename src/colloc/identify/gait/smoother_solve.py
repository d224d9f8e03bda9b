"""One stage of the gait smoother solved and recorded: IPOPT watched for divergence and the
stage's figures kept (:class:`SmootherStage`)."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from colloc.identify.gait.smoother_results import SmootherStage
from colloc.identify.gait.smoother_settings import (
    DIVERGED_DUAL_INFEASIBILITY,
    DIVERGED_OBJECTIVE_FACTOR,
    SmootherSettings,
)


def stage_record(
    name: str,
    problem: Any,
    z: np.ndarray,
    v_s: float,
    status: str,
    success: bool,
    iterations: int,
    clock: float,
) -> SmootherStage:
    """What a stage did, read from its problem at its solution.

    Parameters
    ----------
    name : str
        The stage.
    problem : Problem
        Its collocation problem.
    z : ndarray
        Its solution (or start).
    v_s : float
        The contact's slip scale [m/s].
    status : str
        The solver's status.
    success : bool
    iterations : int
    clock : float
        :func:`time.perf_counter` when the stage began.

    Returns
    -------
    SmootherStage
    """
    defects = problem.defects(z)
    return SmootherStage(
        name,
        problem.scheme.name,
        float(v_s),
        status,
        success,
        iterations,
        time.perf_counter() - clock,
        float(problem.nlp.objective(z)),
        float(np.max(np.abs(defects))) if defects.size else 0.0,
    )


def attempt_stage(
    problem: Any,
    z: np.ndarray,
    name: str,
    v_s: float,
    settings: SmootherSettings,
    max_iter: int | None = None,
    ceiling_factor: float | None = None,
) -> tuple[SmootherStage, np.ndarray]:
    """One stage's solve from ``z``, stopped as diverging when its objective passes
    ``ceiling_factor`` (default :data:`DIVERGED_OBJECTIVE_FACTOR`) times its start's or its
    dual infeasibility passes :data:`DIVERGED_DUAL_INFEASIBILITY`.

    Parameters
    ----------
    problem : Problem
    z : ndarray
        The start.
    name : str
    v_s : float
        The contact's slip scale [m/s].
    settings : SmootherSettings
        The iteration limit and IPOPT's options.
    max_iter : int, optional
        Instead of the settings' limit.
    ceiling_factor : float, optional

    Returns
    -------
    stage : SmootherStage
    z : ndarray
        Where the solve stopped.
    """
    clock = time.perf_counter()
    limit = settings.max_iter if max_iter is None else max_iter
    factor = DIVERGED_OBJECTIVE_FACTOR if ceiling_factor is None else ceiling_factor
    ceiling = factor * max(float(problem.nlp.objective(z)), 1.0)

    def converging(row: dict[str, float]) -> bool:  # False stops the solve
        dual = row.get("dual_infeasibility", 0.0)
        return bool(row["objective"] <= ceiling and dual <= DIVERGED_DUAL_INFEASIBILITY)

    solution = problem.solve(
        z, progress=converging, **{"max_iter": limit, **settings.ipopt_options}
    )
    st = solution.stats
    stage = stage_record(
        name,
        problem,
        solution.z,
        v_s,
        str(st["status"]),
        bool(st["success"]),
        int(st["iterations"]),
        clock,
    )
    return stage, np.asarray(solution.z)
