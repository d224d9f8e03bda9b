"""Objective terms: tracking of measured outputs, integral and terminal costs.

Every term is written as a sum over nodes ``sum_k c_k * phi(x_k, r_k, p, t_k, d_k)`` with
per-node data ``d_k`` (measurements, weights) and per-node factors ``c_k`` (quadrature
weights). Data are inputs of the built functions, so new measurements need no rebuild.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np
import sympy as sm

from colloc.model.model import Model
from colloc.model.symbols import name_of
from colloc.numeric.real import real_array


@dataclass(frozen=True)
class NodeTerm:
    """One objective term in node form.

    Attributes
    ----------
    expr : sympy.Expr
        ``phi`` in the model's states, inputs, parameters, ``t`` and ``data_symbols``.
    data_symbols : tuple of sympy.Symbol
        Placeholders for per-node data.
    data : ndarray, shape (N, len(data_symbols))
        The values of the placeholders at each node.
    factors : ndarray, shape (N,)
        ``c_k``.
    least_squares : tuple of (residual, weight) pairs
        When ``phi = sum weight * residual**2`` (a tracking term): its pieces, from which the
        Gauss-Newton Hessian ``2 sum weight grad(residual) grad(residual)^T`` is built.
        Empty for other terms.
    signals : tuple of str
        For a tracking term of ``m`` signals: their names. Its first ``m`` data columns are
        then the measurements (``residual_j = y_j - data_j``) and the next ``m`` the weights,
        which :func:`colloc.nlp.residuals.tracking_residuals` relies on.
    kind : str
        What a least-squares term's signals are (:func:`colloc.nlp.residuals.tracking_residuals`):
        ``"tracking"`` (default) or ``"parameter prior"``.
    """

    expr: sm.Expr
    data_symbols: tuple[sm.Symbol, ...]
    data: np.ndarray
    factors: np.ndarray
    least_squares: tuple[tuple[sm.Expr, sm.Basic], ...] = ()
    signals: tuple[str, ...] = ()
    kind: str = "tracking"


class ObjectiveTerm(ABC):
    """A term of the objective; subclasses turn themselves into a :class:`NodeTerm`."""

    @abstractmethod
    def node_term(self, model: Model, times: np.ndarray, index: int) -> NodeTerm:
        """The term as a weighted sum over the nodes of ``times``.

        ``index`` makes the data placeholder names of this term unique in the objective.
        """

    @abstractmethod
    def fingerprint(self) -> str:
        """Text that identifies the term's structure (not its data), for build caches."""


class Tracking(ObjectiveTerm):
    """Weighted least squares between model outputs and measurements.

    ``J = sum_k sum_j w_j (y_j(x_k, t_k) - y_m,jk)^2``; samples that are NaN are left out.
    With ``w_j = 1 / sigma_j^2`` (or all weights relative to one reference variance) and
    independent Gaussian noise of standard deviation ``sigma_j`` on signal ``j``, ``J`` is
    twice the negative log-likelihood, which is what the standard errors of
    :func:`colloc.parameter_uncertainty` assume.

    Parameters
    ----------
    measurements : mapping
        Output symbol (a key of ``model.outputs``) or input of the model (tracked directly,
        e.g. a measured force that is a free trajectory) -> measured values at the nodes.
    weights : float or mapping, optional
        One weight for all signals, or symbol -> weight. Default 1.
    integral : bool
        False (default): the plain sum over the nodes above. True: the trapezoidal
        integral ``sum_k c_k sum_j w_j (y_j - y_m,jk)^2`` with ``c_k`` the trapezoidal
        weights of the node times (``h / 2`` at the ends, ``h`` inside on a uniform grid),
        as tools that write the objective as an integral pose it; on a uniform grid it is
        the sum times ``h`` but for the two end samples' half weight.
        :func:`colloc.parameter_uncertainty` reads each sample's weight as ``c_k w_j``.
    """

    def __init__(
        self,
        measurements: Mapping[sm.Basic, np.ndarray],
        weights: float | Mapping[sm.Basic, float] | None = None,
        integral: bool = False,
    ) -> None:
        if not isinstance(integral, bool):
            raise TypeError(f"integral: expected True or False, found {integral!r}")
        self.integral = integral
        if not isinstance(measurements, Mapping) or not measurements:
            raise ValueError(
                "measurements: expected a non-empty mapping output symbol -> array, "
                f"found {type(measurements).__name__}"
            )
        self.measurements = {}
        unreadable = []
        for y, v in measurements.items():
            try:
                self.measurements[y] = real_array(v)
            except (TypeError, ValueError) as error:
                unreadable.append(f"{name_of(y)} ({type(v).__name__} {str(v)[:40]!r}: {error})")
        if unreadable:
            raise ValueError(
                f"measurements: expected numbers at the nodes (an array), found {unreadable}"
            )
        if weights is None or isinstance(weights, int | float):
            w = 1.0 if weights is None else float(weights)
            self.weights = dict.fromkeys(self.measurements, w)
        else:
            unknown = [name_of(y) for y in weights if y not in self.measurements]
            if unknown:
                raise ValueError(f"weights: outputs {unknown} have no measurements")
            self.weights = {y: float(weights.get(y, 1.0)) for y in self.measurements}
        bad = [f"{name_of(y)}: {w!r}" for y, w in self.weights.items() if not w >= 0]
        if bad:
            raise ValueError(f"weights: expected non-negative finite numbers, found {bad}")
        infinite = [name_of(y) for y, w in self.weights.items() if not np.isfinite(w)]
        if infinite:
            raise ValueError(f"weights: expected finite numbers, found infinite for {infinite}")

    def node_term(self, model: Model, times: np.ndarray, index: int) -> NodeTerm:
        """See :meth:`ObjectiveTerm.node_term`."""
        problems = []
        inputs = set(model.inputs)
        for y, values in self.measurements.items():
            if isinstance(y, str):
                problems.append(
                    f"the key {y!r} is a string: key measurements by the output or input "
                    f"itself, e.g. {y}(t) (outputs: {[name_of(o) for o in model.outputs]}, "
                    f"inputs: {[name_of(r) for r in model.inputs]})"
                )
            elif y not in model.outputs and y not in inputs:
                problems.append(
                    f"{name_of(y)} is not an output or input of the model (outputs: "
                    f"{[name_of(o) for o in model.outputs]}, inputs: "
                    f"{[name_of(r) for r in model.inputs]})"
                )
            elif values.shape != times.shape:
                problems.append(
                    f"measurements of {name_of(y)}: expected shape {times.shape} (one per node), "
                    f"found {values.shape}"
                )
            elif np.all(np.isnan(values)):
                problems.append(f"measurements of {name_of(y)}: every sample is NaN")
            elif np.any(np.isinf(values)):
                bad = np.flatnonzero(np.isinf(values))
                problems.append(
                    f"measurements of {name_of(y)}: {bad.size} infinite value(s), first at "
                    f"sample {int(bad[0])}; mark a missing sample with NaN"
                )
        if problems:
            raise ValueError("Tracking: " + "; ".join(problems))
        outputs = list(self.measurements)
        measured = np.column_stack([self.measurements[y] for y in outputs])
        missing = np.isnan(measured)
        weights = np.column_stack(
            [np.where(missing[:, j], 0.0, self.weights[y]) for j, y in enumerate(outputs)]
        )
        return least_squares_term(
            index,
            [model.outputs.get(y, y) for y in outputs],
            np.where(missing, 0.0, measured),
            weights,
            tuple(name_of(y) for y in outputs),
            trapezoid_weights(times) if self.integral else np.ones(times.size),
        )

    def fingerprint(self) -> str:
        """See :meth:`ObjectiveTerm.fingerprint`."""
        return "Tracking(" + ",".join(sm.srepr(y) for y in self.measurements) + ")"


def least_squares_term(
    index: int,
    outputs: list[sm.Expr],
    measured: np.ndarray,
    weights: np.ndarray,
    names: tuple[str, ...],
    factors: np.ndarray,
    extra_symbols: tuple[sm.Symbol, ...] = (),
    extra_data: np.ndarray | None = None,
) -> NodeTerm:
    """``sum_j w_j (y_j - d_j)^2`` in node form, with the data layout the residuals rely on
    (:func:`colloc.nlp.residuals.signal_columns`): ``m`` measurement columns, ``m`` weight
    columns, then any further node data the outputs use.

    Parameters
    ----------
    index : int
        The term's index in the objective (its placeholders' names).
    outputs : list of sympy.Expr
        ``y_j`` in the model's states, inputs, parameters and ``extra_symbols``.
    measured, weights : ndarray, shape (N, m)
        ``d_j`` and ``w_j`` per node (0 where a sample is left out).
    names : tuple of str
        The signals' names.
    factors : ndarray, shape (N,)
        Quadrature factors ``c_k``.
    extra_symbols : tuple of sympy.Symbol
    extra_data : ndarray, shape (N, len(extra_symbols)), optional

    Returns
    -------
    NodeTerm
    """
    m = len(outputs)
    ym = sm.symbols(f"ym{index}_0:{m}")
    wm = sm.symbols(f"wm{index}_0:{m}")
    pieces = tuple((y - d, w) for y, d, w in zip(outputs, ym, wm, strict=True))
    expr = sum((w * r**2 for r, w in pieces), sm.S.Zero)
    columns = [measured, weights] + ([] if extra_data is None else [extra_data])
    return NodeTerm(
        expr,
        tuple(ym) + tuple(wm) + tuple(extra_symbols),
        np.hstack(columns),
        factors,
        pieces,
        names,
    )


def trapezoid_weights(times: np.ndarray) -> np.ndarray:
    """``c_k`` with ``sum_k c_k f(t_k)`` the trapezoidal rule's integral of ``f`` over ``times``.

    Parameters
    ----------
    times : ndarray, shape (N,)

    Returns
    -------
    ndarray, shape (N,)
    """
    h = np.diff(times)
    factors = np.zeros(times.size)
    factors[:-1] += h / 2
    factors[1:] += h / 2
    return factors


def _in_model_terms(expr: sm.Expr, model: Model) -> sm.Expr:
    """``expr`` with the model's output symbols replaced by their expressions (an output
    named like a state or input, ``omega: l * omega``, stays the state or input here)."""
    own = set(model.states) | set(model.inputs)
    outputs = {y: g for y, g in model.outputs.items() if y != g and y not in own}
    return expr.xreplace(outputs) if outputs else expr


class IntegralCost(ObjectiveTerm):
    """``integral of L(y, x, r, p, t) dt`` over the grid, by the trapezoidal rule.

    Parameters
    ----------
    integrand : sympy.Expr
        ``L`` in the model's outputs (keys of ``model.outputs``, replaced by their
        expressions), states, inputs, parameters and time: any SymPy expression, e.g. a
        control effort ``T**2``, a smoothness penalty ``u.diff(t)**2`` (schemes with
        derivative variables), or a regularisation of parameters toward a prior
        ``(k - 100)**2`` (constant in time: divide by the duration).
    """

    def __init__(self, integrand: sm.Expr) -> None:
        if not isinstance(integrand, sm.Basic):
            raise TypeError(f"integrand: expected a SymPy expression, found {integrand!r}")
        self.integrand = integrand

    def node_term(self, model: Model, times: np.ndarray, index: int) -> NodeTerm:
        """See :meth:`ObjectiveTerm.node_term`."""
        integrand = _in_model_terms(self.integrand, model)
        return NodeTerm(integrand, (), np.zeros((times.size, 0)), trapezoid_weights(times))

    def fingerprint(self) -> str:
        """See :meth:`ObjectiveTerm.fingerprint`."""
        return f"IntegralCost({sm.srepr(self.integrand)})"


class TerminalCost(ObjectiveTerm):
    """``Phi(y(t_f), x(t_f), p)``, evaluated at the last node.

    Parameters
    ----------
    expr : sympy.Expr
        ``Phi`` in the model's outputs (replaced by their expressions), states, inputs,
        parameters and time.
    """

    def __init__(self, expr: sm.Expr) -> None:
        if not isinstance(expr, sm.Basic):
            raise TypeError(f"expr: expected a SymPy expression, found {expr!r}")
        self.expr = expr

    def node_term(self, model: Model, times: np.ndarray, index: int) -> NodeTerm:
        """See :meth:`ObjectiveTerm.node_term`."""
        factors = np.zeros(times.size)
        factors[-1] = 1.0
        return NodeTerm(_in_model_terms(self.expr, model), (), np.zeros((times.size, 0)), factors)

    def fingerprint(self) -> str:
        """See :meth:`ObjectiveTerm.fingerprint`."""
        return f"TerminalCost({sm.srepr(self.expr)})"


class ParameterPrior(ObjectiveTerm):
    """A Gaussian prior on unknown parameters: ``sum_j (p_j - m_j)^2 / s_j^2``, counted once.

    With tracking weights ``1 / sigma^2`` the objective is then twice the negative log
    posterior, and the estimate the maximum a posteriori one. Use it for parameters the data
    may leave undetermined along some direction (a marker's place in its segment trades with
    the segment's pose where no neighbouring joint ties it): the prior settles such a
    direction where it was started, and :func:`colloc.cramer_rao_bound` then shows, per
    parameter, how much narrower than the prior the data make it. The term's signals are named
    ``"prior <parameter>"``; :func:`colloc.nlp.residuals.tracking_residuals` gives them the
    kind ``"parameter prior"``.

    Parameters
    ----------
    means : mapping
        Unknown parameter symbol -> the prior's mean ``m_j``.
    std : float or mapping
        One standard deviation ``s_j`` for all, or symbol -> its own (> 0, finite).

    Raises
    ------
    ValueError
        When ``means`` is empty, a mean is not a finite number, or a standard deviation is
        not a positive finite number or names a parameter without a mean.
    """

    def __init__(self, means: Mapping[sm.Symbol, float], std: float | Mapping[sm.Symbol, float]):
        if not isinstance(means, Mapping) or not means:
            raise ValueError(
                f"means: expected a non-empty mapping parameter -> value, found {means!r}"
            )
        bad = [f"{name_of(p)}: {v!r}" for p, v in means.items() if not _finite_number(v)]
        if isinstance(std, Mapping):
            unknown = [name_of(p) for p in std if p not in means]
            if unknown:
                raise ValueError(f"std: parameters {unknown} have no prior mean")
            spread = {p: std.get(p) for p in means}
        else:
            spread = dict.fromkeys(means, std)
        bad_std = [
            f"{name_of(p)}: {v!r}"
            for p, v in spread.items()
            if not (_finite_number(v) and v > 0)  # type: ignore[operator]
        ]
        if bad or bad_std:
            raise ValueError(
                "ParameterPrior: expected finite means and positive finite standard deviations, "
                f"found {'; '.join(bad + bad_std)}"
            )
        self.means = {p: float(v) for p, v in means.items()}
        self.std = {p: float(v) for p, v in spread.items()}  # type: ignore[arg-type]

    def node_term(self, model: Model, times: np.ndarray, index: int) -> NodeTerm:
        """See :meth:`ObjectiveTerm.node_term`: the prior's pseudo-measurements at the first
        node, weight zero at the others."""
        unknown = [name_of(p) for p in self.means if p not in model.parameters]
        if unknown:
            raise ValueError(
                f"ParameterPrior: {unknown} are not parameters of the model "
                f"({[name_of(p) for p in model.parameters]})"
            )
        symbols = list(self.means)
        count = times.size
        measured = np.zeros((count, len(symbols)))
        measured[0] = [self.means[p] for p in symbols]
        weights = np.zeros((count, len(symbols)))
        weights[0] = [1.0 / self.std[p] ** 2 for p in symbols]
        factors = np.zeros(count)
        factors[0] = 1.0
        term = least_squares_term(
            index,
            symbols,
            measured,
            weights,
            tuple(f"prior {name_of(p)}" for p in symbols),
            factors,
        )
        return replace(term, kind="parameter prior")

    def fingerprint(self) -> str:
        """See :meth:`ObjectiveTerm.fingerprint`."""
        return "ParameterPrior(" + ",".join(sm.srepr(p) for p in self.means) + ")"


def _finite_number(value: object) -> bool:
    return (
        isinstance(value, int | float | np.floating | np.integer)
        and not isinstance(value, bool)
        and bool(np.isfinite(value))
    )


class DisturbancePrior(ObjectiveTerm):
    """The penalty of estimated disturbances (process noise): ``sum_k w_k^T S^-1 w_k``.

    A disturbance alone (``w -> sigma``) contributes ``w_k^2 / sigma^2`` at every node; a
    group of disturbances with a covariance ``S`` (``(w1, w2) -> S``: noise on the states a
    controller reads enters its torques as ``K n``, correlated between them) contributes
    ``|L^-1 w_k|^2`` with ``S = L L^T``: each row of ``L^-1 w`` is a signal of unit weight
    (named ``"(w1, w2) whitened j"``), whose entries are node data, so new covariances of the
    same groups need no rebuild. :class:`colloc.Problem` builds this term from its
    ``process_noise``.

    Parameters
    ----------
    noise : mapping
        Disturbance -> standard deviation, or tuple of disturbances -> covariance matrix (as
        checked by :class:`colloc.Problem`).
    """

    def __init__(self, noise: Mapping[object, object]) -> None:
        self.noise = dict(noise)

    def node_term(self, model: Model, times: np.ndarray, index: int) -> NodeTerm:
        """See :meth:`ObjectiveTerm.node_term`."""
        residuals: list[sm.Expr] = []
        weights: list[float] = []
        names: list[str] = []
        coefficients: list[tuple[sm.Symbol, float]] = []
        for key, value in self.noise.items():
            if not isinstance(key, tuple):
                residuals.append(key)
                weights.append(1.0 / float(value) ** 2)  # type: ignore[arg-type]
                names.append(name_of(key))
                continue
            whitening = np.linalg.inv(np.linalg.cholesky(np.asarray(value, dtype=float)))
            label = "(" + ", ".join(map(name_of, key)) + ")"
            for j in range(len(key)):
                row = []
                for i, w in enumerate(key[: j + 1]):  # L^-1 is lower triangular
                    c = sm.Symbol(f"cw{index}_{len(names)}_{i}")
                    coefficients.append((c, float(whitening[j, i])))
                    row.append(c * w)
                residuals.append(sm.Add(*row))
                weights.append(1.0)
                names.append(f"{label} whitened {j}")
        count = times.size
        return least_squares_term(
            index,
            residuals,
            np.zeros((count, len(residuals))),
            np.tile(weights, (count, 1)),
            tuple(names),
            np.ones(count),
            tuple(c for c, _ in coefficients),
            np.tile([v for _, v in coefficients], (count, 1)),
        )

    def fingerprint(self) -> str:
        """See :meth:`ObjectiveTerm.fingerprint`."""
        keys = [k if isinstance(k, tuple) else (k,) for k in self.noise]
        return "DisturbancePrior(" + ";".join(",".join(map(sm.srepr, k)) for k in keys) + ")"
