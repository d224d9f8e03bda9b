"""Other starts: whether a solve stopped at a worse local optimum.

Systematic residuals (:func:`colloc.nlp.residuals.systematic_misfit`) follow a worse local
optimum and a disturbance the model misses alike, so they cannot tell the two apart. Solving
again from scattered starts can: a start that ends at a lower objective is the evidence of a
worse local optimum, and none doing so from several is evidence against it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from colloc.nlp.problem import Problem

if TYPE_CHECKING:
    from colloc.nlp.solution import Solution

#: Relative objective decrease that counts as a better optimum (IPOPT's tolerance leaves
#: optima of one basin equal to far fewer digits than this).
BETTER = 1e-6


@dataclass
class StartsReport:
    """What the other starts found.

    Attributes
    ----------
    best : Solution
        The start's solution with the lowest objective when one improved on the given
        solution; the given solution otherwise (a start that ends at the same optimum does
        not replace it).
    improved : bool
        Whether a start ended at a lower objective than the given solution (by more than
        :data:`BETTER`, relatively): the given one is a worse local optimum.
    objectives : list of float
        Each start's final objective (NaN when its solve failed), in the starts' order.
    parameters : list of dict
        Each start's initial parameter values.
    note : str
        One sentence saying which of the two it is, with the objectives.
    """

    best: Solution
    improved: bool
    objectives: list[float]
    parameters: list[dict[Any, float]]
    note: str


#: Most starts one call runs (each is a whole solve; 10**9 ran on with no end in sight).
MAX_STARTS = 100
#: Largest log-scale scatter (e^10 either way already spans nine decades; 1e6 overflowed).
MAX_SPREAD = 10.0


def other_starts(
    problem: Problem,
    solution: Solution,
    count: int = 4,
    spread: float = 1.0,
    seed: int = 0,
    **solve_options: Any,
) -> StartsReport:
    """Solve again from ``count`` starts with the parameters scattered around the solution's.

    Each start keeps the solution's trajectories and draws every unknown parameter as
    ``p * exp(spread * e)`` with a standard normal ``e`` (a parameter at zero is drawn as
    ``spread * e``), clipped into its bounds.

    Parameters
    ----------
    problem : Problem
        The problem ``solution`` solves.
    solution : Solution
    count : int
        Starts to try, >= 1.
    spread : float
        Standard deviation of the log-scale scatter, > 0 (1: a factor of e either way).
    seed : int
        Seeds the draws (recorded in the note).
    **solve_options
        Passed to :meth:`Problem.solve`.

    Returns
    -------
    StartsReport

    Raises
    ------
    TypeError
        When ``problem`` is not a :class:`Problem` (e.g. several trials).
    ValueError
        When ``count``, ``spread`` or ``seed`` is not usable, or the problem has no unknown
        parameters to scatter.
    """
    if not isinstance(problem, Problem):
        raise TypeError(
            f"problem: expected a Problem (for several trials, call other_starts on each "
            f"trial's problem), found {type(problem).__name__}"
        )
    if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= MAX_STARTS:
        raise ValueError(
            f"count: expected a whole number from 1 to {MAX_STARTS} (each start is a whole "
            f"solve), found {count!r}"
        )
    if not (isinstance(spread, int | float) and np.isfinite(spread) and 0 < spread <= MAX_SPREAD):
        raise ValueError(
            f"spread: expected a number in (0, {MAX_SPREAD:g}] (a log-scale scatter: "
            f"{MAX_SPREAD:g} is a factor of e^{MAX_SPREAD:g} either way), found {spread!r}"
        )
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed: expected an integer >= 0, found {seed!r}")
    lay = problem.layout
    if not lay.parameter_names:
        raise ValueError("problem: has no unknown parameters to start elsewhere")
    rng = np.random.default_rng(seed)
    lo, hi = problem.variable_bounds()
    p0 = lay.parameter_offset
    base = np.asarray(solution.z, dtype=float)
    reference = float(solution.stats["objective"])
    lowest, lowest_solution = reference, solution
    objectives: list[float] = []
    starts: list[dict[Any, float]] = []
    for _ in range(count):
        z = base.copy()
        values = z[p0:]
        draw = rng.standard_normal(values.size)
        scattered = np.where(values != 0.0, values * np.exp(spread * draw), spread * draw)
        z[p0:] = np.clip(scattered, lo[p0:], hi[p0:])
        starts.append(
            dict(zip(problem.partition.unknown_parameters, map(float, z[p0:]), strict=True))
        )
        other = problem.solve(z, **solve_options)
        value = float(other.stats["objective"]) if other.success else float("nan")
        objectives.append(value)
        if other.success and value < lowest:
            lowest, lowest_solution = value, other
    improved = lowest < reference * (1.0 - BETTER)
    best = lowest_solution if improved else solution
    shown = ", ".join(f"{v:.6g}" for v in objectives)
    if improved:
        note = (
            f"a worse local optimum: from {count} other starts (seed {seed}) the objective fell "
            f"from {reference:.6g} to {lowest:.6g} (each: {shown}); use the best one"
        )
    else:
        note = (
            f"no lower optimum from {count} other starts (seed {seed}; objectives {shown} "
            f"against {reference:.6g}): systematic residuals here are the model's, not the "
            "start's"
        )
    return StartsReport(best, improved, objectives, starts, note)
