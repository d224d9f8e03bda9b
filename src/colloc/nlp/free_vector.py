"""The free vector of a collocation problem: its bounds, scales and starting guesses.

:class:`FreeVector` is the part of :class:`colloc.nlp.problem.Problem` that reads and fills
the vector the solver works on (the states and free inputs at the nodes, a scheme's interval
variables, the unknown parameters), given the problem's layout and partition.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import sympy as sm

from colloc.model.model import Model
from colloc.model.symbols import name_of
from colloc.nlp.layout import Layout
from colloc.nlp.spec import Bounds
from colloc.nlp.templates import Partition
from colloc.transcription.base import Scheme, TimeGrid

#: Bound standing for none: IPOPT treats ``|bound| >= 1e19`` as infinite.
UNBOUNDED = 1e20


class FreeVector:
    """Bounds, scales and guesses of a problem's free vector (a base of
    :class:`colloc.nlp.problem.Problem`, which sets the attributes below)."""

    model: Model
    scheme: Scheme
    grid: TimeGrid
    partition: Partition
    layout: Layout
    bounds: Bounds
    measured_inputs: dict[sm.Basic, tuple[np.ndarray, float]]

    @property
    def free_quantities(self) -> tuple[sm.Basic, ...]:
        """The states, free inputs and unknown parameters: what the solve determines."""
        part = self.partition
        return tuple(self.model.states) + part.free_inputs + part.unknown_parameters

    def variable_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the free vector (``±1e20`` where unbounded)."""
        lay = self.layout
        lo, hi = np.full(lay.num_variables, -UNBOUNDED), np.full(lay.num_variables, UNBOUNDED)
        for s, (a, b) in self.bounds.items():
            idx = self._free_indices(s)
            lo[idx], hi[idx] = a, b
        return np.maximum(lo, -UNBOUNDED), np.minimum(hi, UNBOUNDED)

    def variable_scale(self, scale: Mapping[sm.Basic, Any] | None) -> np.ndarray:
        """Typical magnitude of every free variable: those given, 1 elsewhere.

        Parameters
        ----------
        scale : mapping, optional
            State, free input or unknown parameter -> a positive typical magnitude.

        Returns
        -------
        ndarray, shape (num_variables,)

        Raises
        ------
        ValueError
            When a key is not a free quantity or a value is not a positive finite number.
        """
        out = np.ones(self.layout.num_variables)
        if scale is None:
            return out
        if not isinstance(scale, Mapping):
            raise ValueError(
                f"scale: expected a mapping symbol -> typical magnitude, found "
                f"{type(scale).__name__}"
            )
        free = set(self.free_quantities)
        problems = []
        for s, value in scale.items():
            try:
                v = float(value)
            except (TypeError, ValueError):
                v = float("nan")
            if s not in free:
                problems.append(f"{name_of(s)} is not a state, free input or unknown parameter")
            elif not (np.isfinite(v) and v > 0):
                problems.append(f"{name_of(s)}: expected a positive number, found {value!r}")
            else:
                out[self._free_indices(s)] = v
        if problems:
            raise ValueError("scale: " + "; ".join(problems))
        return out

    def _free_indices(self, s: sm.Basic) -> np.ndarray:
        """Where a state, free input or unknown parameter sits in the free vector (a state's
        interval copies included)."""
        lay, name = self.layout, name_of(s)
        if name not in lay.node_names:
            return np.array([lay.variable_index(name)])
        idx = np.asarray(lay.node_indices(name))
        mid = f"{name}_mid"
        if mid in lay.interval_names:
            j = lay.interval_names.index(mid)
            step = lay.num_interval_variables * np.arange(lay.num_nodes - 1)
            idx = np.concatenate([idx, lay.interval_offset + j + step])
        return idx

    def initial_guess(
        self,
        trajectories: Mapping[sm.Basic, np.ndarray | float] | np.ndarray | None = None,
        parameters: Mapping[sm.Symbol, float] | np.ndarray | Sequence[float] | None = None,
        default: float = 0.0,
    ) -> np.ndarray:
        """Build a free vector from trajectories and parameter values.

        Derivative variables (trapezoidal, Hermite-Simpson) are filled by finite differences
        of the state guesses and midpoint states by interpolation, so a good state guess
        gives a nearly feasible start. Measured inputs not given start at their measurement.

        Parameters
        ----------
        trajectories : mapping or ndarray, optional
            State or free-input symbol -> values at the nodes (shape ``(N,)``) or a constant;
            or an array of shape ``(N, n)`` whose columns are the model's states in order,
            or ``(N, n + m)``: the states, then the free inputs
            (``problem.partition.free_inputs``).
        parameters : mapping or array, optional
            Unknown parameter symbol -> value, or the values of every unknown parameter in
            the order of ``problem.layout.parameter_names``.
        default : float
            Value of everything not given.

        Returns
        -------
        ndarray
            The free vector, for :meth:`solve` or :meth:`solve_gauss_newton`.

        Raises
        ------
        ValueError
            When an array has another shape than those above, naming the expected one.
        KeyError
            When a mapping names a symbol that is not a state, free input or unknown
            parameter.
        """
        lay = self.layout
        trajectories = self._trajectories_by_symbol(trajectories)
        parameters = self._parameters_by_symbol(parameters)
        given = dict(trajectories or {})
        for r, (values, _) in self.measured_inputs.items():
            if r not in given:
                ok = ~np.isnan(values)
                given[r] = np.interp(self.grid.times, self.grid.times[ok], values[ok])
        nodes = {name_of(s): v for s, v in given.items()}
        params = {name_of(p): v for p, v in (parameters or {}).items()}
        z = lay.fill(nodes, params, default=default)
        X = lay.node_matrix(z)
        n = self.model.num_states
        states = X[:, :n]
        if self.scheme.node_derivatives:
            nf = len(self.partition.free_inputs)
            X[:, n + nf : 2 * n + nf] = np.gradient(states, self.grid.times, axis=0)
        if lay.num_interval_variables:
            lay.interval_matrix(z)[:] = self.scheme.interval_guess(states, self.grid)
        return z

    def _trajectories_by_symbol(
        self, trajectories: Mapping[sm.Basic, np.ndarray | float] | np.ndarray | None
    ) -> Mapping[sm.Basic, np.ndarray | float] | None:
        """An array of trajectories as a mapping by symbol (states, then free inputs)."""
        if trajectories is None or isinstance(trajectories, Mapping):
            return trajectories
        values = np.asarray(trajectories, dtype=float)
        states, free = list(self.model.states), list(self.partition.free_inputs)
        N = self.layout.num_nodes
        shapes = [(N, len(states))] + ([(N, len(states) + len(free))] if free else [])
        if values.shape not in shapes:
            raise ValueError(
                f"trajectories: expected a mapping by symbol or an array of shape "
                f"{' or '.join(map(str, shapes))} (columns: "
                f"{[name_of(x) for x in states + free]}), found shape {values.shape}"
            )
        return dict(zip(states + free, values.T, strict=False))

    def _parameters_by_symbol(
        self, parameters: Mapping[sm.Symbol, float] | np.ndarray | Sequence[float] | None
    ) -> Mapping[sm.Symbol, float] | None:
        """An array of parameter values as a mapping by symbol (the layout's order)."""
        if parameters is None or isinstance(parameters, Mapping):
            return parameters
        values = np.asarray(parameters, dtype=float)
        unknown = self.partition.unknown_parameters
        if values.shape != (len(unknown),):
            raise ValueError(
                f"parameters: expected a mapping by symbol or an array of shape "
                f"({len(unknown)},) in the order of layout.parameter_names, found shape "
                f"{values.shape}"
            )
        return dict(zip(unknown, values, strict=True))

    def parameters_at_bounds(self, estimates: np.ndarray) -> tuple[str, ...]:
        """The unknown parameters a bound holds.

        Parameters
        ----------
        estimates : ndarray
            The unknown parameters' values, in the layout's order.

        Returns
        -------
        tuple of str
            Names of those within ``1e-6 (1 + |bound|)`` of a finite bound.
        """
        lo, hi = self.variable_bounds()
        offset = self.layout.parameter_offset
        lo, hi = lo[offset:], hi[offset:]
        near = np.zeros(estimates.shape, bool)
        for bound in (lo, hi):
            finite = np.abs(bound) < 1e19  # unbounded is +-1e20
            near[finite] |= np.abs(estimates[finite] - bound[finite]) <= 1e-6 * (
                1.0 + np.abs(bound[finite])
            )
        return tuple(
            name_of(p)
            for p, flag in zip(self.partition.unknown_parameters, near, strict=True)
            if flag
        )
