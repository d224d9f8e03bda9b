"""Numeric callables ``M(x, t)`` and ``f(x, t)`` from a symbolic implicit model."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import sympy as sm
from sympy.core.function import AppliedUndef

from colloc.simulate.integrate import (
    Array,
    ForcingFunction,
    MassFunction,
    check_integration_args,
    integrate_implicit,
)

__all__ = ["ImplicitODE"]

ArrayLike = npt.ArrayLike


@dataclass(frozen=True, eq=False)
class ImplicitODE:
    """Numeric form ``M(x, t) x' = f(x, t)`` of an implicit model with all inputs given.

    Attributes
    ----------
    states : tuple
        The model's states, in the order of the numeric state vector.
    mass : callable
        ``mass(x, t) -> (n, n)`` array.
    forcing : callable
        ``forcing(x, t) -> (n,)`` array.
    """

    states: tuple[sm.Basic, ...]
    mass: MassFunction
    forcing: ForcingFunction
    _evaluate: Callable[[Array, float], tuple[Array, Array]]

    @classmethod
    def from_model(
        cls,
        model: Any,
        parameter_values: Mapping[sm.Symbol, float],
        known_inputs: Mapping[sm.Basic, Callable[[float], float]] | None = None,
    ) -> ImplicitODE:
        """Build the numeric callables of a (closed-loop) :class:`colloc.model.model.Model`.

        Parameters
        ----------
        model : Model
            Its ``residual`` must be linear in ``state_derivatives`` and as long as ``states``.
        parameter_values : mapping
            A number for every symbol in ``model.parameters`` (and no others).
        known_inputs : mapping, optional
            A callable ``r(t)`` for every input left in ``model.inputs`` (after
            ``close_loop`` these are the known and unknown exogenous inputs).

        Raises
        ------
        ValueError
            Listing every missing or unexpected parameter and input.
        """
        inputs = dict(known_inputs or {})
        problems = []
        expected_p, expected_r = set(model.parameters), set(model.inputs)
        missing_p = [str(p) for p in model.parameters if p not in parameter_values]
        extra_p = sorted(str(p) for p in parameter_values if p not in expected_p)
        missing_r = [str(r) for r in model.inputs if r not in inputs]
        extra_r = sorted(str(r) for r in inputs if r not in expected_r)
        if missing_p:
            problems.append(f"parameter_values lacks {missing_p}")
        if extra_p:
            problems.append(f"parameter_values has unknown parameter(s) {extra_p}")
        if missing_r:
            problems.append(f"known_inputs lacks a function for {missing_r}")
        if extra_r:
            problems.append(f"known_inputs has input(s) the model does not have: {extra_r}")
        if problems:
            raise ValueError("ImplicitODE.from_model: " + "; ".join(problems))
        return cls.from_residual(
            model.residual,
            model.states,
            model.state_derivatives,
            parameter_values,
            inputs,
            t=model.t,
        )

    @classmethod
    def from_residual(
        cls,
        residual: sm.MatrixBase | Sequence[sm.Expr],
        states: Sequence[sm.Basic],
        state_derivatives: Sequence[sm.Basic],
        parameter_values: Mapping[sm.Symbol, float],
        inputs: Mapping[sm.Basic, Callable[[float], float]],
        *,
        t: sm.Symbol,
    ) -> ImplicitODE:
        """Build the numeric callables from ``residual = M x' - f = 0`` directly.

        ``M`` is the Jacobian of ``residual`` with respect to ``state_derivatives`` and
        ``f = -residual`` at ``x' = 0``; both are lambdified with common subexpression
        elimination.

        Raises
        ------
        ValueError
            When the residual is not square, not linear in ``x'``, contains symbols or
            functions of time that are neither states, inputs nor given parameters, or an
            input has no callable.
        """
        res = sm.Matrix(residual)
        n = len(states)
        xs = sm.symbols(f"x0:{n}", cls=sm.Dummy)
        xds = sm.symbols(f"xd0:{n}", cls=sm.Dummy)
        input_syms = tuple(inputs)
        rs = sm.symbols(f"r0:{len(input_syms)}", cls=sm.Dummy)
        problems = []
        if res.shape != (n, 1):
            problems.append(
                f"residual must be a column of length {n} (one per state), found {res.shape}"
            )
        if len(state_derivatives) != n:
            problems.append(
                f"state_derivatives must have {n} entries, found {len(state_derivatives)}"
            )
        not_callable = [str(r) for r, fn in inputs.items() if not callable(fn)]
        if not_callable:
            problems.append(f"inputs for {not_callable} are not callable")
        if problems:
            raise ValueError("ImplicitODE: " + "; ".join(problems))

        # One xreplace: derivative nodes match before their inner state function is replaced.
        replace: dict[sm.Basic, sm.Basic] = dict(zip(state_derivatives, xds, strict=True))
        replace.update(zip(states, xs, strict=True))
        replace.update(zip(input_syms, rs, strict=True))
        replace.update({p: sm.Float(v) for p, v in parameter_values.items()})
        plain = res.xreplace(replace)

        left_derivatives = plain.atoms(sm.Derivative)
        left_functions = plain.atoms(AppliedUndef)
        left_symbols = plain.free_symbols - set(xs) - set(xds) - set(rs) - {t}
        if left_derivatives:
            problems.append(
                f"derivatives that are not state derivatives: {sorted(map(str, left_derivatives))}"
            )
        if left_functions:
            problems.append(
                f"functions of time that are neither states nor given inputs: "
                f"{sorted(map(str, left_functions))}"
            )
        if left_symbols:
            problems.append(
                f"symbols without a value in parameter_values: {sorted(map(str, left_symbols))}"
            )
        mass_expr = plain.jacobian(xds)
        if mass_expr.free_symbols & set(xds):
            problems.append(
                "residual is not linear in the state derivatives; cannot split M x' = f"
            )
        if problems:
            raise ValueError("ImplicitODE: " + "; ".join(problems))
        forcing_expr = -plain.xreplace(dict.fromkeys(xds, sm.Integer(0)))

        both = sm.lambdify((t, xs, rs), (mass_expr, forcing_expr), modules="numpy", cse=True)
        funcs = tuple(inputs[r] for r in input_syms)

        def evaluate(x: Array, time: float) -> tuple[Array, Array]:
            m, f = both(time, x, [fn(time) for fn in funcs])
            return np.asarray(m, dtype=float), np.asarray(f, dtype=float).reshape(n)

        def mass(x: Array, time: float) -> Array:
            return evaluate(x, time)[0]

        def forcing(x: Array, time: float) -> Array:
            return evaluate(x, time)[1]

        return cls(tuple(states), mass, forcing, evaluate)

    def rhs(self, t: float, x: ArrayLike) -> Array:
        """``x' = M^-1 f`` at one point (solved numerically), in SciPy's ``fun(t, y)`` order."""
        m, f = self._evaluate(np.asarray(x, dtype=float), t)
        return np.asarray(np.linalg.solve(m, f), dtype=float)

    def simulate(
        self,
        x0: ArrayLike,
        times: ArrayLike,
        *,
        method: str = "LSODA",
        rtol: float = 1e-10,
        atol: float = 1e-10,
    ) -> Array:
        """Integrate from ``x0``; see :func:`simulate` for the arguments and errors."""
        x0_arr, t_arr = check_integration_args(x0, times, method, rtol, atol)
        if x0_arr.size != len(self.states):
            raise ValueError(
                f"simulate: x0 must have {len(self.states)} entries (one per state), "
                f"found {x0_arr.size}"
            )
        return integrate_implicit(self._evaluate, x0_arr, t_arr, method, rtol, atol)
