"""The scheme's own error in the estimated parameters, from a solve on a grid twice as fine.

A collocation estimate is the optimum of the discretised problem, not of the continuous one:
its parameters carry the scheme's error, which no standard error counts (on noise-free data
the standard error falls to nothing while the scheme's error stays). :func:`refined_problem`
poses the same problem with a node inserted in the middle of every interval and the same
objective (every term keeps its data and quadrature factors at the original nodes; the
inserted nodes carry no measurement and no cost), so that only the dynamics' discretisation
changes. With the estimate ``p_h`` and the refined one ``p_h/2`` of a scheme of order ``k``,
Richardson's estimate of the error of ``p_h`` is

    e = (p_h - p_h/2) 2^k / (2^k - 1),

valid once the grid resolves the motion (the error then falls as ``h^k``).
:func:`discretisation_error` solves the refined problem from the estimate interpolated and
returns ``e`` per parameter.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import sympy as sm

from colloc.model.symbols import name_of
from colloc.nlp.known import KnownTrajectory
from colloc.nlp.objective import NodeTerm, ObjectiveTerm
from colloc.solve.watchdog import SolverCrashed, SolverStalled
from colloc.transcription.base import TimeGrid
from colloc.transcription.interpolation import CubicInterpolation

if TYPE_CHECKING:
    from colloc.nlp.problem import Problem
    from colloc.nlp.solution import Solution
    from colloc.nlp.trials import Trials, TrialsSolution


@dataclass(frozen=True)
class DiscretisationError:
    """Richardson's estimate of the scheme's error in each estimated parameter.

    Attributes
    ----------
    errors : dict
        Parameter symbol -> estimated error of the solve's value (its value minus the
        continuous problem's): NaN when not estimated (``note`` says why).
    refined : dict
        Parameter symbol -> the value on the grid twice as fine.
    order : int
        The scheme's order ``k`` used in the extrapolation.
    note : str
        How the estimate was made, or why it was not.
    """

    errors: dict[sm.Symbol, float]
    refined: dict[sm.Symbol, float]
    order: int
    note: str

    @property
    def estimated(self) -> bool:
        """Whether the refined solve ran and converged."""
        return all(np.isfinite(v) for v in self.errors.values())


class _GivenTerm(ObjectiveTerm):
    """An objective term already in node form (a refined problem's copy of a term)."""

    def __init__(self, term: NodeTerm, fingerprint: str) -> None:
        self.term, self._fingerprint = term, fingerprint

    def node_term(self, model: Any, times: np.ndarray, index: int) -> NodeTerm:
        """See :meth:`ObjectiveTerm.node_term`."""
        if self.term.data.shape[0] != times.size:
            raise ValueError(
                f"a refined term: expected {times.size} nodes, found {self.term.data.shape[0]}"
            )
        return self.term

    def fingerprint(self) -> str:
        """See :meth:`ObjectiveTerm.fingerprint`."""
        return self._fingerprint


def refined_times(times: np.ndarray) -> np.ndarray:
    """The node times with the middle of every interval inserted (``2N - 1`` of them).

    Parameters
    ----------
    times : ndarray, shape (N,)

    Returns
    -------
    ndarray, shape (2N - 1,)
        The original times at the even indices.
    """
    t = np.asarray(times, dtype=float)
    out = np.empty(2 * t.size - 1)
    out[0::2] = t
    out[1::2] = 0.5 * (t[:-1] + t[1:])
    return out


def _interleaved(nodes: np.ndarray, middles: np.ndarray) -> np.ndarray:
    """Node rows at the even indices, interval rows at the odd ones."""
    out = np.empty((nodes.shape[0] + middles.shape[0],) + nodes.shape[1:], dtype=float)
    out[0::2], out[1::2] = nodes, middles
    return out


def _refined_term(term: NodeTerm, count: int) -> NodeTerm:
    """The same term on the refined grid: no data and no weight at the inserted nodes."""
    data = np.zeros((count, term.data.shape[1]))
    data[0::2] = term.data
    factors = np.zeros(count)
    factors[0::2] = term.factors
    return dataclasses.replace(term, data=data, factors=factors)


def refined_problem(problem: Problem) -> Problem:
    """``problem`` on a grid with a node in the middle of every interval, the same objective.

    Every objective term keeps its data and quadrature factors at the original nodes and has
    none at the inserted ones; a known trajectory is evaluated at the inserted nodes by its
    own rule between nodes (so the refined input is the one the scheme already used); a
    measured input is tracked at the original nodes only. Model, scheme, known and unknown
    parameters, bounds, instance constraints and cache are the problem's.

    Parameters
    ----------
    problem : Problem

    Returns
    -------
    Problem

    Raises
    ------
    ValueError
        For a problem with ``process_noise``: its disturbances are penalised per node, so a
        finer grid changes their prior, not only the discretisation.
    """
    from colloc.nlp.problem import Problem  # the refined problem is built here

    if problem.process_noise:
        raise ValueError(
            "problem: has process_noise, whose prior is per node: a finer grid would change "
            "the disturbances' prior as well as the discretisation"
        )
    grid = problem.grid
    times = refined_times(grid.times)
    known = {}
    for r, values in problem.known_trajectories.items():
        rule = problem.interpolations.get(r, CubicInterpolation())
        middles = rule.midpoint_values(grid, np.asarray(values, dtype=float))
        known[r] = KnownTrajectory(_interleaved(np.asarray(values, dtype=float), middles), rule)
    measured = {}
    for r, (values, sigma) in problem.measured_inputs.items():
        fine = np.full(times.size, np.nan)
        fine[0::2] = values
        measured[r] = (fine, sigma)
    own = len(problem.measured_inputs) > 0  # the constructor rebuilds the measured inputs' term
    user_terms = problem.node_terms[: len(problem.node_terms) - int(own)]
    objective = [
        _GivenTerm(_refined_term(term, times.size), f"refined {i}")
        for i, term in enumerate(user_terms)
    ]
    return Problem(
        problem.model,
        times,
        problem.scheme,
        known_trajectories=known,
        known_parameters=dict(problem.known_parameters),
        objective=objective or None,
        unknown_parameters=list(problem.partition.unknown_parameters),
        bounds=dict(problem.bounds),
        instance_constraints=list(problem.instance_constraints),
        cache=problem.cache,
        measured_inputs=measured or None,
    )


def refined_guess(problem: Problem, solution: Solution, refined: Problem) -> np.ndarray:
    """``solution`` interpolated onto ``refined``'s grid: the nodes kept, the inserted ones
    by the cubic through the four surrounding nodes; the parameters as estimated.

    Parameters
    ----------
    problem : Problem
        The problem ``solution`` solved.
    solution : Solution
    refined : Problem
        :func:`refined_problem` of it.

    Returns
    -------
    ndarray
        A free vector of ``refined``.
    """
    grid = TimeGrid(problem.grid.times)
    free = list(problem.model.states) + list(problem.partition.free_inputs)
    trajectories = {}
    for s in free:
        values = np.asarray(solution.trajectories[s], dtype=float)
        trajectories[s] = _interleaved(values, grid.midpoint_values(values))
    parameters = {p: solution.parameters[p] for p in problem.partition.unknown_parameters}
    return refined.initial_guess(trajectories, parameters)


def discretisation_error(
    problem: Problem | Trials,
    solution: Solution | TrialsSolution,
    scale: Mapping[sm.Basic, Any] | None = None,
    **ipopt_options: Any,
) -> DiscretisationError:
    """Richardson's estimate of the scheme's error in each estimated parameter.

    Solves :func:`refined_problem` from ``solution`` interpolated (IPOPT, with the options
    and scaling ``solution`` was found with unless given) and extrapolates with the scheme's
    order (module description). Costs one solve on twice the nodes, usually in a few
    iterations.

    Parameters
    ----------
    problem : Problem or Trials
        Several trials are refined together (every trial's grid twice as fine) and solved
        again as one.
    solution : Solution or TrialsSolution
        A converged solve of ``problem``.
    scale : mapping, optional
        As :meth:`Problem.solve`; default the one ``solution`` records.
    **ipopt_options
        Over the options ``solution`` was solved with.

    Returns
    -------
    DiscretisationError
        NaN errors, with the reason in ``note``, when the problem cannot be refined
        (process noise) or the refined solve does not converge (or is stopped).
    """
    from colloc.nlp.trials import Trials  # trials build on this module's problems

    design = problem if isinstance(problem, Trials) else Trials([problem])
    own = getattr(solution, "trials", (solution,))  # each trial's solution
    unknown = design.unknown_parameters
    orders = sorted({int(p.scheme.order) for p in design.problems})
    order = orders[0]

    def not_estimated(why: str) -> DiscretisationError:
        nan = dict.fromkeys(unknown, float("nan"))
        return DiscretisationError(nan, dict(nan), order, f"not estimated: {why}")

    if len(orders) > 1:
        return not_estimated(f"the trials' schemes are of different orders {orders}")
    try:
        fine = Trials([refined_problem(p) for p in design.problems], design.names)
    except ValueError as exc:
        return not_estimated(str(exc))
    options = dict(solution.stats.get("ipopt_options") or {})
    options.pop("watchdog_seconds", None)  # colloc's, not IPOPT's
    hessian = (
        "limited-memory"
        if options.pop("hessian_approximation", "") == "limited-memory"
        else "exact"
    )
    options.update(ipopt_options)
    if scale is None:
        by_name = {name_of(s): s for p in design.problems for s in p.free_quantities}
        recorded = solution.stats.get("scale") or {}
        scale = {by_name[k]: v for k, v in recorded.items() if k in by_name}
    guesses = [
        refined_guess(p, s, f) for p, s, f in zip(design.problems, own, fine.problems, strict=True)
    ]
    # a cubic between nodes may overshoot a bound the solution touches: start inside them
    guess = np.clip(fine.initial_guess(guesses), *fine.variable_bounds())
    try:
        answer = fine.solve(guess, hessian, scale=scale or None, **options)
    except (SolverStalled, SolverCrashed) as exc:
        return not_estimated(f"the solve on the refined grid failed: {exc}")
    if not answer.success:
        return not_estimated(f"the solve on the refined grid ended {answer.status.name}")
    factor = 2.0**order / (2.0**order - 1.0)
    errors = {p: factor * (solution.parameters[p] - answer.parameters[p]) for p in unknown}
    return DiscretisationError(
        errors,
        {p: float(answer.parameters[p]) for p in unknown},
        order,
        f"Richardson, order {order}: the change on a grid twice as fine "
        f"({fine.num_nodes} nodes, {answer.stats['iterations']} iterations) "
        f"times {factor:.4g}",
    )
