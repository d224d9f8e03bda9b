"""The collocation problem: model + grid + scheme + data + unknowns + objective."""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
import sympy as sm

from colloc.model.errors import ProblemDefinitionError, raise_if_any
from colloc.model.inertia import inertia_problems
from colloc.model.model import Model
from colloc.model.symbols import name_of
from colloc.nlp.assembly import AssembledNLP
from colloc.nlp.build import build_templates
from colloc.nlp.free_vector import UNBOUNDED, FreeVector
from colloc.nlp.known import KnownTrajectory
from colloc.nlp.layout import Layout
from colloc.nlp.objective import DisturbancePrior, NodeTerm, ObjectiveTerm, Tracking
from colloc.nlp.placement import GridData, assemble
from colloc.nlp.residuals import systematic_misfit
from colloc.nlp.solution import Solution, SolveStats
from colloc.nlp.solving import checked_guess, solve_watched
from colloc.nlp.spec import (
    Bounds,
    check_bounds,
    check_measured_inputs,
    check_node_terms,
    check_objective,
    check_parameters,
    check_process_noise,
    check_schedules,
    check_trajectories,
    model_instance_constraints,
    parse_instance_constraints,
    same_keys,
)
from colloc.nlp.templates import Partition
from colloc.solve.gauss_newton import ChainStructure, GaussNewtonOptions, solve_gauss_newton
from colloc.solve.ipopt import STALL_SECONDS
from colloc.solve.result import SolveResult
from colloc.transcription.base import Scheme, TimeGrid
from colloc.transcription.interpolation import Interpolation
from colloc.transcription.midpoint import Midpoint


class Problem(FreeVector):
    """A direct-collocation NLP for a model on a time grid.

    Parameters
    ----------
    model : Model
        Usually closed loop (:meth:`Model.close_loop`).
    times : array_like
        Strictly increasing node times (``N`` of them).
    scheme : Scheme, optional
        A scheme object such as ``Midpoint()`` (default) or ``HermiteSimpson()``.
    known_trajectories : mapping, optional
        Input symbol -> values at the nodes, or a :class:`colloc.KnownTrajectory` that also
        says how the input is evaluated between the nodes (plain arrays: a cubic through
        the four surrounding nodes; ``KnownTrajectory(values, "linear")``: the mean of
        the two, as tools that average the nodes do). Every known input of the model needs
        one; other inputs without one (controlled or unknown inputs) become free
        trajectories.
    known_parameters : mapping, optional
        Parameter symbol -> value.
    objective : ObjectiveTerm or sequence, optional
        ``Tracking``, ``IntegralCost``, ``TerminalCost`` terms, summed. None: feasibility.
    unknown_parameters : sequence, optional
        The parameters to estimate. Default, as in opty: every parameter without a known value.
    bounds : mapping, optional
        State, free input or unknown parameter -> (lower, upper).
    instance_constraints : sequence of sympy.Expr, optional
        Expressions equal to zero in ``x(t_k)`` values (e.g. ``q.func(0.0) - 1``, or
        ``q.func(tf) - q.func(0.0)`` for periodicity) and parameters. The model's own
        :attr:`~colloc.Model.initial_constraints` are added at the first node; with a
        scheme without node equations (midpoint, backward Euler), so is a zero second
        difference over the first three nodes of each algebraic state (a Lagrange
        multiplier), which the interval defects see only through neighbouring nodes.
    cache : bool, str or Path
        Cache built functions on disk (default directory, or the one given); False: never.
    process_noise : mapping, optional
        Disturbance (an unknown input added by :meth:`Model.with_disturbances`) -> its
        standard deviation per node. Each disturbance is estimated at every node and
        penalised by ``sum_k w_k^2 / sigma^2`` beside the tracking terms: the maximum a
        posteriori estimate when the tracking weights are ``1 / sigma_y^2`` (scale every
        standard deviation by the same reference when the weights are relative). A tuple of
        disturbances -> their covariance matrix per node (symmetric positive definite)
        penalises them jointly by ``sum_k w_k^T S^-1 w_k``: noise correlated between them, as
        noise on the states a controller reads reaches its torques (``K n``: ``S = K
        Sigma_n K^T``); see :class:`colloc.nlp.objective.DisturbancePrior`.
    measured_inputs : mapping, optional
        Input -> ``(values, sigma)``: an input measured with noise of standard deviation
        ``sigma`` (errors in variables). It becomes a free trajectory tracked to ``values``
        (one per node, NaN where missing) with weight ``1 / sigma^2``, instead of a known
        trajectory taken as exact; :meth:`initial_guess` starts it at its measurement.

    Raises
    ------
    ProblemDefinitionError
        Listing every inconsistency at once.
    """

    def __init__(
        self,
        model: Model,
        times: Sequence[float] | np.ndarray,
        scheme: Scheme | None = None,
        known_trajectories: Mapping[sm.Basic, Any] | None = None,
        known_parameters: Mapping[sm.Symbol, Any] | None = None,
        objective: ObjectiveTerm | Sequence[ObjectiveTerm] | None = None,
        unknown_parameters: Sequence[sm.Symbol] | None = None,
        bounds: Bounds | None = None,
        instance_constraints: Sequence[sm.Expr] | None = None,
        cache: bool | str | Any = True,
        process_noise: Mapping[sm.Basic, Any] | None = None,
        measured_inputs: Mapping[sm.Basic, Any] | None = None,
    ) -> None:
        t_start = time.perf_counter()
        if not isinstance(model, Model):
            raise TypeError(f"model: expected a colloc.Model, found {type(model).__name__}")
        scheme = Midpoint() if scheme is None else scheme
        if not isinstance(scheme, Scheme):
            raise TypeError(
                f"scheme: expected a scheme object such as Midpoint(), found {scheme!r}"
            )
        problems: list[str] = []
        try:
            grid = TimeGrid(np.asarray(times, dtype=float))
        except (ValueError, TypeError) as exc:
            problems.append(str(exc))
            grid = TimeGrid(np.arange(2.0))  # placeholder so every other check still runs
        self.model, self.scheme, self.grid = model, scheme, grid
        self.instance_constraints = tuple(instance_constraints or ())
        self.cache = cache
        N = self.grid.num_nodes
        self.measured_inputs = check_measured_inputs(
            model, measured_inputs or {}, known_trajectories or {}, N, problems
        )
        self.process_noise = check_process_noise(model, process_noise or {}, problems)
        self.interpolations: dict[sm.Basic, Interpolation] = {}
        self.known_trajectories = check_trajectories(
            model,
            known_trajectories or {},
            N,
            problems,
            tuple(measured_inputs or {}),
            self.interpolations,
        )
        self.known_parameters, unknown = check_parameters(
            model, known_parameters or {}, unknown_parameters, problems
        )
        terms = check_objective(objective, problems) + self._noise_terms(N)
        free_inputs = tuple(r for r in model.inputs if r not in self.known_trajectories)
        unknown_set = set(unknown)
        self.partition = Partition(
            model,
            free_inputs,
            tuple(r for r in model.inputs if r in self.known_trajectories),
            unknown,
            tuple(p for p in model.parameters if p not in unknown_set),
        )
        node_funcs = list(model.states) + list(free_inputs)
        self.bounds = check_bounds(bounds or {}, node_funcs + list(unknown), problems)
        ic_exprs, ic_vars, ic_locs = parse_instance_constraints(
            list(instance_constraints or [])
            + model_instance_constraints(model, scheme.node_derivatives, self.grid.times),
            node_funcs,
            model.parameters,
            self.grid.times,
            problems,
        )
        node_terms = []
        for i, term in enumerate(terms):
            try:
                node_terms.append(term.node_term(model, self.grid.times, i))
            except ValueError as exc:
                problems.append(str(exc))
        check_node_terms(node_terms, model, scheme.node_derivatives, problems)
        check_schedules(model, self.known_parameters, unknown, self.known_trajectories, problems)
        if not problems:
            problems += inertia_problems(model, self.known_parameters)
        raise_if_any(problems, ProblemDefinitionError)

        self.layout = self._make_layout()
        t_derive = time.perf_counter()
        templates, self.cache_hit = build_templates(
            self.partition, scheme, node_terms, ic_exprs, ic_vars, cache
        )
        self.derive_time = time.perf_counter() - t_derive
        self._templates = templates
        self._node_terms = node_terms
        self._ic_locs = ic_locs
        self.nlp = self._assemble(templates, node_terms, ic_locs)
        self.build_time = time.perf_counter() - t_start
        """Seconds to construct the problem, including :attr:`derive_time`."""

    def _noise_terms(
        self,
        num_nodes: int,
        measured_inputs: Mapping[sm.Basic, tuple[np.ndarray, float]] | None = None,
        process_noise: Mapping[Any, Any] | None = None,
    ) -> list[ObjectiveTerm]:
        """The tracking terms of the measured inputs and the disturbance penalty (the
        problem's own, or the ones given)."""
        measured = self.measured_inputs if measured_inputs is None else measured_inputs
        noise = self.process_noise if process_noise is None else process_noise
        terms: list[ObjectiveTerm] = []
        if measured:
            terms.append(
                Tracking(
                    {r: v for r, (v, _) in measured.items()},
                    {r: 1.0 / s**2 for r, (_, s) in measured.items()},
                )
            )
        if noise:
            terms.append(DisturbancePrior(noise))
        return terms

    @property
    def node_terms(self) -> tuple[NodeTerm, ...]:
        """The objective's terms in node form: the user's, then the measured inputs' tracking
        and the process-noise penalty (see :class:`colloc.nlp.objective.NodeTerm`)."""
        return tuple(self._node_terms)

    @property
    def size(self) -> dict[str, int]:
        """``nodes``, ``variables``, ``constraints``, ``nnz_jacobian``, ``nnz_hessian``."""
        lay = self.layout
        return {
            "nodes": int(lay.num_nodes),
            "variables": int(lay.num_variables),
            "constraints": int(lay.num_constraints),
            "nnz_jacobian": int(self.nlp.nnz_jacobian),
            "nnz_hessian": int(self.nlp.nnz_hessian),
        }

    # ---------------------------------------------------------------- layout
    def _make_layout(self) -> Layout:
        names = [name_of(x) for x in self.model.states]
        node = names + [name_of(r) for r in self.partition.free_inputs]
        if self.scheme.node_derivatives:
            node += [f"{s}'" for s in names]
        return Layout(
            self.grid.times,
            node,
            self.scheme.interval_variable_names(names),
            [name_of(p) for p in self.partition.unknown_parameters],
        )

    def _assemble(self, templates: dict, node_terms: list, ic_locs: list) -> AssembledNLP:
        return assemble(
            self.partition,
            self.scheme,
            self.grid,
            self.layout,
            templates,
            node_terms,
            ic_locs,
            GridData(self.known_trajectories, self.known_parameters, self.interpolations),
        )

    def replace_data(
        self,
        objective: ObjectiveTerm | Sequence[ObjectiveTerm] | None = None,
        known_trajectories: Mapping[sm.Basic, Any] | None = None,
        known_parameters: Mapping[sm.Symbol, Any] | None = None,
        measured_inputs: Mapping[sm.Basic, Any] | None = None,
        process_noise: Mapping[sm.Basic, Any] | None = None,
    ) -> None:
        """Swap in new measurements, known trajectories or known values without rebuilding.

        The new objective terms must have the same structure (the same outputs tracked),
        and the same parameters must be known; only their data change, which the built
        functions take as inputs (e.g. a continuation in a contact stiffness). A known
        trajectory given as a plain array keeps the rule between the nodes it was built
        with; a :class:`colloc.KnownTrajectory` sets its own. ``measured_inputs`` (new
        values and standard deviations) and ``process_noise`` (new standard deviations) must
        name the same inputs as the built problem's: a Monte Carlo over noisy measured
        inputs swaps them like any measurement.

        Raises
        ------
        ProblemDefinitionError
            When the new data do not fit the built problem.
        """
        problems: list[str] = []
        N = self.grid.num_nodes
        if known_trajectories is not None:
            chosen: dict[sm.Basic, Interpolation] = {}
            new = check_trajectories(self.model, known_trajectories, N, problems, (), chosen)
            check_schedules(
                self.model, self.known_parameters, self.partition.unknown_parameters, new, problems
            )
            if set(new) != set(self.known_trajectories) and not problems:
                problems.append(
                    "known_trajectories: expected the same inputs as the built problem "
                    f"{[name_of(r) for r in self.known_trajectories]}, found {[name_of(r) for r in new]}"
                )
        values = self.known_parameters
        if known_parameters is not None:
            values, _ = check_parameters(
                self.model, known_parameters, self.partition.unknown_parameters, problems
            )
            if set(values) != set(self.known_parameters) and not problems:
                problems.append(
                    "known_parameters: expected values for the same parameters as the built "
                    f"problem ({len(self.known_parameters)}), found {len(values)}"
                )
        measured = self.measured_inputs
        if measured_inputs is not None:
            measured = check_measured_inputs(
                self.model, measured_inputs, self.known_trajectories, N, problems
            )
            same_keys("measured_inputs", "inputs", self.measured_inputs, measured, problems)
        noise = self.process_noise
        if process_noise is not None:
            noise = check_process_noise(self.model, process_noise, problems)
            same_keys("process_noise", "disturbances", self.process_noise, noise, problems)
        terms = self._node_terms
        if objective is not None or measured_inputs is not None or process_noise is not None:
            if objective is not None:  # every term built anew
                kept, new_terms = [], check_objective(objective, problems)
            else:  # the user's terms kept, the measured inputs' and disturbances' rebuilt
                own = bool(self.measured_inputs) + bool(self.process_noise)
                kept, new_terms = self._node_terms[: len(self._node_terms) - own], []
            new_terms = new_terms + self._noise_terms(N, measured, noise)
            terms = list(kept)
            for i, term in enumerate(new_terms, start=len(kept)):
                try:
                    terms.append(term.node_term(self.model, self.grid.times, i))
                except ValueError as exc:
                    problems.append(str(exc))
            old = [(t.expr, t.data_symbols) for t in self._node_terms]
            if not problems and [(t.expr, t.data_symbols) for t in terms] != old:
                problems.append(
                    "objective: the new terms differ in structure from the built problem's; "
                    "build a new Problem instead"
                )
        raise_if_any(problems, ProblemDefinitionError)
        if known_trajectories is not None:
            self.known_trajectories = new
            # a plain array keeps the rule the input was built with
            self.interpolations.update(
                {
                    r: rule
                    for r, rule in chosen.items()
                    if isinstance(known_trajectories[r], KnownTrajectory)
                }
            )
        self.known_parameters = values
        self.measured_inputs, self.process_noise = measured, noise
        self._node_terms = terms
        self.nlp = self._assemble(self._templates, terms, self._ic_locs)

    # ---------------------------------------------------------------- solve
    def solve(
        self,
        initial_guess: np.ndarray,
        hessian: str = "exact",
        progress: Callable[[dict[str, float]], None] | None = None,
        log_path: str | None = None,
        scale: Mapping[sm.Basic, Any] | None = None,
        stall_seconds: float | None = STALL_SECONDS,
        **ipopt_options: Any,
    ) -> Solution:
        """Solve with IPOPT (MUMPS).

        Parameters
        ----------
        initial_guess : ndarray
            Free vector (see :meth:`initial_guess`).
        hessian : {"exact", "limited-memory", "gauss-newton"}
            Exact Hessian by AD (default), IPOPT's L-BFGS approximation, or the objective's
            Hessian only (the constraints' curvature left out).
        progress : callable, optional
            Called after each iteration with ``iteration``, ``objective``,
            ``infeasibility`` (primal), ``dual_infeasibility``.
        log_path : str, optional
            Keep IPOPT's log at this path (it is also in ``stats["ipopt_log"]``).
        scale : mapping, optional
            State, free input or unknown parameter -> its typical magnitude: IPOPT then
            solves for ``value / magnitude``, so that gains of 1e3 and of 1e-1 take steps
            and barrier terms on one scale (IPOPT's own scaling acts on the objective and
            constraints only). Unscaled by default; the solution is the same problem's.
        stall_seconds : float or None
            Watchdog (default 60 s): IPOPT runs in a forked child process that is stopped
            when it finishes no iteration for this long (or ten times its slowest one),
            since nothing else can stop it inside one linear-solver call. A stopped
            exact or Gauss-Newton solve is solved again from ``initial_guess`` with
            ``hessian="limited-memory"``, and ``solution.status.notes`` says so. None
            solves in this process, unwatched.
        **ipopt_options
            Passed to IPOPT (e.g. ``tol=1e-8``, ``max_iter=500``), over colloc's defaults
            :data:`colloc.solve.ipopt.DEFAULT_OPTIONS`: ``tol=1e-8``, ``max_iter=3000``,
            ``mu_strategy="adaptive"`` (IPOPT's own default is ``"monotone"``; pass it to
            pose another tool's problem exactly), ``linear_solver="mumps"``.

        Returns
        -------
        Solution
            Parameters that end at one of their bounds are named in
            ``solution.status.at_bounds`` (and its message); ``stats["scale"]`` records the
            scaling used.

        Raises
        ------
        SolverStalled
            When the limited-memory solve was stopped by the watchdog too.
        SolverCrashed
            When the solver's process died without a result; when the problem's functions
            came from the build cache, a note says how to clear it.

        Warns
        -----
        UserWarning
            When the initial guess lies outside the bounds: IPOPT moves such values inside
            before its first iteration, so the solve does not start where it was asked to.
        """
        z0 = self._checked_guess(initial_guess)
        magnitudes = self.variable_scale(scale)
        result = solve_watched(
            self.nlp,
            z0,
            self.variable_bounds(),
            hessian=hessian,
            describe=self.layout.describe_variable,
            cache_hit=self.cache_hit,
            progress=progress,
            log_path=log_path,
            variable_scale=None if scale is None else magnitudes,
            stall_seconds=stall_seconds,
            options=ipopt_options,
        )
        solution = solution_from_result(self, result)
        # what determined the solve's path, beside IPOPT's options
        solution.stats["scale"] = {name_of(k): float(v) for k, v in (scale or {}).items()}
        return solution

    def _checked_guess(self, initial_guess: np.ndarray) -> np.ndarray:
        return checked_guess(
            initial_guess, self.layout.num_variables, self.layout.describe_variable
        )

    def chain_structure(self) -> ChainStructure:
        """Where states, unknown parameters and defects sit, for :meth:`solve_gauss_newton`.

        Raises
        ------
        ProblemDefinitionError
            When the problem is not a one-step chain: a scheme with interval or derivative
            variables (Hermite-Simpson, trapezoidal), node or instance constraints, or
            bounds. Free input trajectories (disturbances, measured inputs) are node
            variables of the chain.
        """
        lay, problems = self.layout, []
        n = self.model.num_states
        if lay.num_interval_variables or self.scheme.node_derivatives:
            problems.append(
                f"scheme: the Gauss-Newton solver needs a one-step scheme with states only at "
                f"the nodes (BackwardEuler, Midpoint), found {self.scheme!r}"
            )
        others = [b.name for b in lay.blocks if b.item != "interval"]
        if others:
            problems.append(
                f"constraints {others}: the Gauss-Newton solver takes only the interval defects"
            )
        lo, hi = self.variable_bounds()
        if np.any(lo > -UNBOUNDED) or np.any(hi < UNBOUNDED):
            problems.append("bounds: the Gauss-Newton solver does not take bounds")
        raise_if_any(problems, ProblemDefinitionError)
        N = lay.num_nodes
        block = lay.blocks[0]
        first = np.arange(N)[:, None] * lay.num_node_variables
        return ChainStructure(
            node_index=first + np.arange(n),
            parameter_index=np.arange(lay.parameter_offset, lay.num_variables),
            interval_rows=block.offset + np.arange(block.size).reshape(N - 1, n),
            input_index=first + n + np.arange(len(self.partition.free_inputs)),
        )

    def solve_gauss_newton(
        self,
        initial_guess: np.ndarray,
        options: GaussNewtonOptions | None = None,
        progress: Callable[[dict[str, float]], None] | None = None,
    ) -> Solution:
        """Solve by constrained Gauss-Newton with condensing (many unknown parameters).

        Each iteration's cost grows linearly with the number of nodes and quadratically with
        the number of unknown parameters, independently of a sparse solver's fill-in order;
        suited to least-squares identification of thousands of parameters (gain schedules)
        on long records. See :mod:`colloc.solve.gauss_newton`.

        Parameters
        ----------
        initial_guess : ndarray
            Free vector (see :meth:`initial_guess`).
        options : GaussNewtonOptions, optional
            Segment length, iteration and wall-time limits, tolerances.
        progress : callable, optional
            As for :meth:`solve`; returning ``False`` stops the solve.

        Returns
        -------
        Solution
            ``stats["ipopt_log"]`` holds the solver's own iteration log.

        Raises
        ------
        ProblemDefinitionError
            When the problem is not a one-step chain (see :meth:`chain_structure`).
        """
        z0 = self._checked_guess(initial_guess)
        result = solve_gauss_newton(self.nlp, z0, self.chain_structure(), options, progress)
        return solution_from_result(self, result)

    def defects(self, z: np.ndarray) -> np.ndarray:
        """Constraint values at ``z`` (row order as in :attr:`layout`)."""
        return self.nlp.constraints(np.asarray(z, dtype=float))

    def __repr__(self) -> str:
        lay = self.layout
        names = lay.parameter_names
        shown = repr(names) if len(names) <= 10 else f"{len(names)} ({names[0]} ... {names[-1]})"
        return (
            f"Problem({self.scheme!r}, N={lay.num_nodes}, variables={lay.num_variables}, "
            f"constraints={lay.num_constraints}, unknown parameters={shown})"
        )


def solution_from_result(problem: Problem, result: SolveResult) -> Solution:
    """A :class:`Solution` from a solve's raw result, named with the problem's layout: the
    trajectories, the estimates beside the known values, the parameters a bound holds, the
    tracked signals whose residuals are systematic (``status.notes``), and the statistics.

    Parameters
    ----------
    problem : Problem
        The problem that was solved.
    result : SolveResult
        Its solve (IPOPT's or the Gauss-Newton solver's).

    Returns
    -------
    Solution
    """
    lay = problem.layout
    X = lay.node_matrix(result.x)
    node_funcs = list(problem.model.states) + list(problem.partition.free_inputs)
    traj: dict[sm.Basic, np.ndarray] = {s: X[:, j].copy() for j, s in enumerate(node_funcs)}
    traj.update({r: v.copy() for r, v in problem.known_trajectories.items()})
    params: dict[sm.Symbol, float] = dict(problem.known_parameters)
    est = result.x[lay.parameter_offset :]
    params.update(zip(problem.partition.unknown_parameters, map(float, est), strict=True))
    status = replace(
        result.status,
        at_bounds=problem.parameters_at_bounds(est),
        notes=result.status.notes + tuple(systematic_misfit(problem, result.x)),
    )
    stats = SolveStats.from_result(
        result,
        status,
        problem.build_time,
        problem.derive_time,
        problem.cache_hit,
        num_variables=lay.num_variables,
        num_constraints=lay.num_constraints,
        nnz_jacobian=problem.nlp.nnz_jacobian,
        nnz_hessian=problem.nlp.nnz_hessian,
        scheme=problem.scheme.name,
    )
    return Solution(
        problem.grid.times.copy(),
        traj,
        params,
        problem.partition.unknown_parameters,
        status,
        stats,
        result.x.copy(),
        result.multipliers,
    )
