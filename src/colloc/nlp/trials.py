"""Several trials that share their unknown parameters, solved as one estimate.

A study rarely rests on one record: four perturbation trials of one subject, a walk cut into
strides, a pendulum pushed with two input signals. Each trial is a :class:`colloc.Problem`
of its own (its grid, known inputs, measurements, initial state, even its scheme); the
unknown parameters are shared where the trials name the same symbol, and estimated once from
all of them. Given the parameters, the trials are independent, and
:func:`colloc.parameter_uncertainty` knows it: the sandwich's blocks lie inside trials.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import sympy as sm

from colloc.model.errors import ProblemDefinitionError, raise_if_any
from colloc.model.symbols import name_of
from colloc.nlp.composite import CompositeNLP
from colloc.nlp.problem import Problem, solution_from_result
from colloc.nlp.solution import Solution, SolveStats
from colloc.nlp.solving import checked_guess, solve_watched
from colloc.solve.ipopt import STALL_SECONDS
from colloc.solve.result import NLP, SolveResult
from colloc.solve.status import SolveStatus


class Trials:
    """Several problems sharing their unknown parameters: one NLP, one estimate.

    The whole free vector is each trial's own variables (states, free inputs, interval
    variables: never shared), one trial after another, then the unknown parameters of all
    trials, each once, in order of first appearance. A parameter unknown in several trials is
    one variable; one unknown in a single trial (a trial's own offset, say) is that trial's.

    Parameters
    ----------
    problems : sequence of Problem
        The trials, each built as for a single fit (at least one unknown parameter among
        them). The same problem object may not appear twice.
    names : sequence of str, optional
        A name per trial for messages and results (default ``"trial 0"``, ``"trial 1"``, ...).

    Raises
    ------
    ProblemDefinitionError
        Listing every inconsistency: not a Problem, a problem given twice, names not unique
        or of the wrong count, a shared parameter bounded differently in two trials, no
        unknown parameter at all.

    Examples
    --------
    >>> trials = Trials([problem_a, problem_b])                       # doctest: +SKIP
    >>> z0 = trials.initial_guess([problem_a.initial_guess(...), problem_b.initial_guess(...)])
    >>> solution = trials.solve(z0)                                    # doctest: +SKIP
    >>> colloc.parameter_uncertainty(trials, solution)                # doctest: +SKIP
    """

    def __init__(self, problems: Sequence[Problem], names: Sequence[str] | None = None) -> None:
        found: list[str] = []
        if isinstance(problems, Problem) or not isinstance(problems, Sequence):
            raise TypeError(
                f"problems: expected a sequence of colloc.Problem, found {type(problems).__name__}"
            )
        problems = list(problems)
        if not problems:
            found.append("problems: expected at least one Problem, found none")
        for i, p in enumerate(problems):
            if not isinstance(p, Problem):
                found.append(f"problems[{i}]: expected a colloc.Problem, found {type(p).__name__}")
        seen: dict[int, int] = {}
        for i, p in enumerate(problems):
            if id(p) in seen:
                found.append(
                    f"problems[{i}]: the same Problem as problems[{seen[id(p)]}] (each trial "
                    "needs its own states: build one Problem per trial)"
                )
            seen.setdefault(id(p), i)
        names = [f"trial {i}" for i in range(len(problems))] if names is None else list(names)
        if len(names) != len(problems):
            found.append(f"names: expected {len(problems)} names, found {len(names)}")
        elif len(set(names)) != len(names) or not all(isinstance(n, str) and n for n in names):
            found.append(f"names: expected distinct non-empty strings, found {names!r}")
        raise_if_any(found, ProblemDefinitionError)
        self.problems: tuple[Problem, ...] = tuple(problems)
        self.names: tuple[str, ...] = tuple(names)
        unknown: list[sm.Symbol] = []
        for p in self.problems:
            unknown += [s for s in p.partition.unknown_parameters if s not in unknown]
        if not unknown:
            found.append("problems: none has an unknown parameter, so there is nothing to share")
        self.unknown_parameters: tuple[sm.Symbol, ...] = tuple(unknown)
        bounds: dict[sm.Symbol, tuple[float, ...]] = {}
        for name, p in zip(self.names, self.problems, strict=True):
            for s in p.partition.unknown_parameters:
                b = tuple(map(float, p.bounds.get(s, (-np.inf, np.inf))))
                if s in bounds and bounds[s] != b:
                    found.append(
                        f"bounds: {name_of(s)} is bounded {bounds[s]} in an earlier trial "
                        f"and {b} in {name}; a shared parameter has one range"
                    )
                bounds.setdefault(s, b)
        raise_if_any(found, ProblemDefinitionError)
        own = [p.layout.parameter_offset for p in self.problems]
        starts = np.concatenate([[0], np.cumsum(own)]).astype(np.int64)
        self.offsets: tuple[int, ...] = tuple(int(s) for s in starts[:-1])
        """Where each trial's own variables start in the whole free vector."""
        self.parameter_offset = int(starts[-1])
        """Where the shared unknown parameters start in the whole free vector."""
        self.num_variables = self.parameter_offset + len(unknown)
        position = {s: i for i, s in enumerate(unknown)}
        self.index: tuple[np.ndarray, ...] = tuple(
            np.concatenate(
                [
                    offset + np.arange(p.layout.parameter_offset),
                    self.parameter_offset
                    + np.array([position[s] for s in p.partition.unknown_parameters], np.int64),
                ]
            ).astype(np.int64)
            for p, offset in zip(self.problems, self.offsets, strict=True)
        )
        """Per trial: where its free variable ``j`` sits in the whole free vector."""
        # one trial is its own problem's NLP (no index tables to merge, however large)
        self._composite = (
            CompositeNLP(self.problems, self.index, self.num_variables)
            if len(self.problems) > 1
            else None
        )

    @property
    def nlp(self) -> NLP:
        """The callbacks of the whole NLP (a single trial's own, unchanged)."""
        if self._composite is None:
            return self.problems[0].nlp
        return self._composite

    @property
    def num_nodes(self) -> int:
        """Nodes of all trials together."""
        return sum(p.layout.num_nodes for p in self.problems)

    @property
    def build_time(self) -> float:
        """Seconds the trials' problems took to build, together."""
        return float(sum(p.build_time for p in self.problems))

    def split(self, z: np.ndarray) -> list[np.ndarray]:
        """Each trial's own free vector, taken from the whole ``z``."""
        z = np.asarray(z, dtype=float)
        return [z[idx] for idx in self.index]

    def split_rows(self, values: np.ndarray) -> list[np.ndarray]:
        """Each trial's share of a vector over the constraint rows (e.g. multipliers)."""
        if self._composite is None:
            return [np.asarray(values, dtype=float)]
        return self._composite.split_rows(values)

    def describe_variable(self, i: int) -> str:
        """What whole-vector entry ``i`` is, e.g. ``"trial 1: x at node 3 (t = 0.03)"``."""
        if not 0 <= i < self.num_variables:
            raise IndexError(f"i: expected 0..{self.num_variables - 1}, found {i}")
        if i >= self.parameter_offset:
            return f"parameter {name_of(self.unknown_parameters[i - self.parameter_offset])}"
        k = int(np.searchsorted(self.offsets, i, side="right") - 1)
        local = self.problems[k].layout.describe_variable(i - self.offsets[k])
        return f"{self.names[k]}: {local}"

    def variable_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the whole free vector (``±1e20`` where unbounded)."""
        lo, hi = np.empty(self.num_variables), np.empty(self.num_variables)
        for p, idx in zip(self.problems, self.index, strict=True):
            lo[idx], hi[idx] = p.variable_bounds()
        return lo, hi

    def variable_scale(self, scale: Mapping[sm.Basic, Any] | None) -> np.ndarray:
        """Typical magnitude of every whole-vector entry (see :meth:`Problem.variable_scale`).

        Raises
        ------
        ValueError
            When a key is a free quantity of no trial, or a value is not a positive number.
        """
        out = np.ones(self.num_variables)
        if scale is None:
            return out
        if not isinstance(scale, Mapping):
            raise ValueError(
                f"scale: expected a mapping symbol -> typical magnitude, found "
                f"{type(scale).__name__}"
            )
        used = set()
        for p, idx in zip(self.problems, self.index, strict=True):
            free = set(p.free_quantities)
            mine = {s: v for s, v in scale.items() if s in free}
            used |= set(mine)
            out[idx] = p.variable_scale(mine)
        stray = [name_of(s) for s in scale if s not in used]
        if stray:
            raise ValueError(
                f"scale: {stray} are not a state, free input or unknown parameter of any trial"
            )
        return out

    def initial_guess(
        self,
        guesses: Sequence[np.ndarray] | None = None,
        parameters: Mapping[sm.Symbol, float] | None = None,
    ) -> np.ndarray:
        """The whole free vector from each trial's own.

        Parameters
        ----------
        guesses : sequence of ndarray, optional
            One free vector per trial (each from its problem's
            :meth:`~colloc.Problem.initial_guess`); default each problem's default guess.
        parameters : mapping, optional
            Unknown parameter -> starting value. Parameters not given start at their value in
            the first trial's guess that has them.

        Returns
        -------
        ndarray

        Raises
        ------
        ValueError
            When the count or a guess's shape is wrong, or a key is not an unknown parameter.
        """
        if guesses is None:
            guesses = [p.initial_guess() for p in self.problems]
        if len(guesses) != len(self.problems):
            raise ValueError(
                f"guesses: expected {len(self.problems)} free vectors (one per trial), "
                f"found {len(guesses)}"
            )
        z = np.zeros(self.num_variables)
        for k in reversed(range(len(self.problems))):  # the first trial's values written last
            p = self.problems[k]
            g = np.asarray(guesses[k], dtype=float)
            if g.shape != (p.layout.num_variables,):
                raise ValueError(
                    f"guesses[{k}]: expected shape ({p.layout.num_variables},) "
                    f"({self.names[k]}'s free vector), found {g.shape}"
                )
            z[self.index[k]] = g
        for s, value in (parameters or {}).items():
            if s not in self.unknown_parameters:
                raise ValueError(f"parameters: {name_of(s)} is not an unknown parameter")
            z[self.parameter_offset + self.unknown_parameters.index(s)] = float(value)
        return z

    def solve(
        self,
        initial_guess: np.ndarray,
        hessian: str = "exact",
        progress: Callable[[dict[str, float]], None] | None = None,
        log_path: str | None = None,
        scale: Mapping[sm.Basic, Any] | None = None,
        stall_seconds: float | None = STALL_SECONDS,
        **ipopt_options: Any,
    ) -> TrialsSolution:
        """Solve all trials at once with IPOPT, as :meth:`colloc.Problem.solve` does one.

        Parameters
        ----------
        initial_guess : ndarray
            The whole free vector (:meth:`initial_guess`).
        hessian, progress, log_path, stall_seconds, **ipopt_options
            As :meth:`colloc.Problem.solve`.
        scale : mapping, optional
            Symbol -> typical magnitude, applied in every trial where the symbol is free.

        Returns
        -------
        TrialsSolution
        """
        z0 = checked_guess(initial_guess, self.num_variables, self.describe_variable)
        magnitudes = self.variable_scale(scale)
        result = solve_watched(
            self.nlp,
            z0,
            self.variable_bounds(),
            hessian=hessian,
            describe=self.describe_variable,
            cache_hit=all(p.cache_hit for p in self.problems),
            progress=progress,
            log_path=log_path,
            variable_scale=None if scale is None else magnitudes,
            stall_seconds=stall_seconds,
            options=ipopt_options,
        )
        solution = TrialsSolution.from_result(self, result)
        solution.stats["scale"] = {name_of(k): float(v) for k, v in (scale or {}).items()}
        return solution

    def __len__(self) -> int:
        return len(self.problems)

    def __repr__(self) -> str:
        names = [name_of(s) for s in self.unknown_parameters]
        return (
            f"Trials({len(self.problems)} trials, nodes={self.num_nodes}, "
            f"variables={self.num_variables}, shared parameters={names})"
        )


@dataclass
class TrialsSolution:
    """The solve of :class:`Trials`: one estimate, each trial's trajectories.

    Attributes
    ----------
    trials : tuple of Solution
        Each trial's own solution (its trajectories, its share of the objective and its
        notes), with the shared estimate among its parameters.
    names : tuple of str
    parameters : dict
        Unknown parameter -> estimate.
    unknown_parameters : tuple
    status : SolveStatus
        The solve's; ``at_bounds`` over all parameters, and each trial's notes prefixed by
        its name.
    stats : SolveStats
        As :attr:`colloc.Solution.stats`, for the whole NLP.
    z, multipliers : ndarray
        The whole free vector and constraint multipliers.
    """

    trials: tuple[Solution, ...]
    names: tuple[str, ...]
    parameters: dict[sm.Symbol, float]
    unknown_parameters: tuple[sm.Symbol, ...]
    status: SolveStatus
    stats: SolveStats
    z: np.ndarray
    multipliers: np.ndarray

    @classmethod
    def from_result(cls, trials: Trials, result: SolveResult) -> TrialsSolution:
        """Unpack a solve of ``trials``' NLP into each trial's :class:`Solution`."""
        own = []
        for p, z, mu in zip(
            trials.problems,
            trials.split(result.x),
            trials.split_rows(result.multipliers),
            strict=True,
        ):
            defects = p.nlp.constraints(z)
            local = replace(
                result,
                x=z,
                objective=float(p.nlp.objective(z)),
                constraint_violation=float(np.max(np.abs(defects), initial=0.0)),
                multipliers=mu,
            )
            own.append(solution_from_result(p, local))
        held = {name for s in own for name in s.status.at_bounds}
        at_bounds = tuple(name_of(s) for s in trials.unknown_parameters if name_of(s) in held)
        notes = tuple(
            f"{name}: {note}"
            for name, s in zip(trials.names, own, strict=True)
            for note in s.status.notes[len(result.status.notes) :]
        )
        status = replace(result.status, at_bounds=at_bounds, notes=result.status.notes + notes)
        estimate = result.x[trials.parameter_offset :]
        stats = SolveStats.from_result(
            result,
            status,
            trials.build_time,
            float(sum(p.derive_time for p in trials.problems)),
            all(p.cache_hit for p in trials.problems),
            trials=list(trials.names),
            num_variables=trials.num_variables,
            num_constraints=trials.nlp.m,
        )
        return cls(
            tuple(own),
            trials.names,
            dict(zip(trials.unknown_parameters, map(float, estimate), strict=True)),
            trials.unknown_parameters,
            status,
            stats,
            result.x.copy(),
            result.multipliers,
        )

    @property
    def success(self) -> bool:
        """Whether IPOPT reported an optimum."""
        return self.status.success

    def __getitem__(self, key: int | str) -> Solution:
        """A trial's solution, by position or name."""
        if isinstance(key, str):
            if key not in self.names:
                raise KeyError(f"{key!r}: expected one of {list(self.names)}")
            key = self.names.index(key)
        return self.trials[key]

    def __repr__(self) -> str:
        return (
            f"TrialsSolution(status={self.status.name}, trials={len(self.trials)}, "
            f"iterations={self.stats['iterations']}, objective={self.stats['objective']:.6g}, "
            f"unknown parameters={len(self.unknown_parameters)})"
        )


def as_trials(
    problem: Problem | Trials, solution: Solution | TrialsSolution | None = None
) -> Trials:
    """The design as trials (a single problem is one trial), checked against ``solution``.

    Parameters
    ----------
    problem : Problem or Trials
    solution : Solution or TrialsSolution, optional

    Returns
    -------
    Trials

    Raises
    ------
    ValueError
        When a single problem has no unknown parameters, or ``solution``'s free vector is
        not of this design's length.
    """
    if not isinstance(problem, Trials) and not problem.partition.unknown_parameters:
        raise ValueError("problem: has no unknown parameters, so there is nothing to estimate")
    design = problem if isinstance(problem, Trials) else Trials([problem])
    if solution is not None:
        z = np.asarray(solution.z)
        if z.shape != (design.num_variables,):
            raise ValueError(
                f"solution: its free vector has shape {z.shape}, the problem's "
                f"({design.num_variables},): not a solve of this problem"
            )
    return design
