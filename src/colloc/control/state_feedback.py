"""Full or partial state feedback ``r = K (x_eq - x)``."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import sympy as sm

from colloc.model.symbols import as_tuple, name_of

if TYPE_CHECKING:
    from colloc.model.model import Model


class StateFeedback:
    """State feedback ``r = K (x_eq - x)`` for a model's controlled inputs.

    Parameters
    ----------
    K : sympy.Matrix, array_like or None
        Gain matrix, one row per controlled input and one column per fed-back state;
        entries may be numbers or SymPy symbols. ``None`` makes a matrix of symbols named
        ``k_{i}_{j}`` sized from the model when the loop is closed.
    x_eq : sequence, optional
        The equilibrium (set point) of the fed-back states; numbers or symbols. Default 0.
    states : sequence of functions of time, optional
        The fed-back states, in the column order of ``K``. Default: all model states.
    inputs : sequence of functions of time, optional
        The driven inputs, in the row order of ``K``. Default: all controlled inputs.

    Examples
    --------
    >>> fb = StateFeedback.symbolic(1, 4)       # doctest: +SKIP
    >>> closed = model.close_loop(fb)           # doctest: +SKIP
    """

    def __init__(
        self,
        K: sm.MatrixBase | np.ndarray | Sequence[Sequence[Any]] | None = None,
        x_eq: Sequence[Any] | None = None,
        *,
        states: Sequence[sm.Basic] | None = None,
        inputs: Sequence[sm.Basic] | None = None,
        name: str = "k",
    ) -> None:
        self._K = None if K is None else _as_matrix(K)
        if self._K is not None and (self._K.rows == 0 or self._K.cols == 0):
            raise ValueError(
                f"K: expected a non-empty 2-D gain matrix, found shape {self._K.shape}"
            )
        self._x_eq = None if x_eq is None else tuple(_as_expr(e, "x_eq") for e in x_eq)
        self._states = None if states is None else as_tuple(states)
        self._inputs = None if inputs is None else as_tuple(inputs)
        self._name = name

    @classmethod
    def symbolic(
        cls, num_inputs: int, num_states: int, name: str = "k", **kwargs: Any
    ) -> StateFeedback:
        """Feedback with a ``num_inputs x num_states`` matrix of symbols ``{name}_{i}_{j}``."""
        for label, value in (("num_inputs", num_inputs), ("num_states", num_states)):
            if not isinstance(value, int | np.integer) or value < 1:
                raise ValueError(f"{label}: expected a positive integer, found {value!r}")
        return cls(gain_symbols(num_inputs, num_states, name), **kwargs)

    @property
    def K(self) -> sm.Matrix | None:
        """The gain matrix (``None`` until sized when constructed without one)."""
        return self._K

    @property
    def parameters(self) -> tuple[sm.Symbol, ...]:
        """The symbols in ``K`` and ``x_eq`` (the constants that close_loop adds)."""
        found: list[sm.Symbol] = []
        pieces: list[Any] = list(self._K) if self._K is not None else []
        pieces += list(self._x_eq or ())
        for e in pieces:
            for s in sorted(getattr(e, "free_symbols", set()), key=str):
                if s not in found:
                    found.append(s)
        return tuple(found)

    def control_law(self, model: Model) -> Mapping[sm.Basic, sm.Expr]:
        """Return ``{input: expression}`` for ``r = K (x_eq - x)`` on ``model``.

        Raises
        ------
        ValueError
            When the shapes of ``K``, ``x_eq``, states or inputs disagree, naming each.
        """
        xs = self._states if self._states is not None else model.states
        rs = self._inputs if self._inputs is not None else model.controlled_inputs
        if self._K is None:
            self._K = gain_symbols(len(rs), len(xs), self._name)
        problems = []
        if self._K.shape != (len(rs), len(xs)):
            problems.append(
                f"K: expected shape ({len(rs)}, {len(xs)}) = (inputs "
                f"{[name_of(r) for r in rs]}, states {[name_of(x) for x in xs]}), "
                f"found {self._K.shape}"
            )
        missing = [name_of(x) for x in xs if x not in model.states]
        if missing:
            problems.append(f"states: {missing} are not states of the model")
        x_eq = self._x_eq if self._x_eq is not None else (0,) * len(xs)
        if len(x_eq) != len(xs):
            problems.append(f"x_eq: expected {len(xs)} values, found {len(x_eq)}")
        if problems:
            raise ValueError("StateFeedback: " + "; ".join(problems))
        error = sm.Matrix([e - x for e, x in zip(x_eq, xs, strict=True)])
        law = self._K * error
        return dict(zip(rs, law, strict=True))

    def __repr__(self) -> str:
        shape = None if self._K is None else self._K.shape
        return f"StateFeedback(K shape={shape}, x_eq={self._x_eq})"


def gain_symbols(num_inputs: int, num_states: int, name: str = "k") -> sm.Matrix:
    """A matrix of gain symbols ``{name}_{i}_{j}`` (row = input, column = state)."""
    return sm.Matrix(num_inputs, num_states, lambda i, j: sm.Symbol(f"{name}_{i}_{j}"))


def _as_expr(value: Any, label: str) -> sm.Expr:
    # Text is never parsed: only numbers and SymPy objects are accepted.
    if isinstance(value, sm.Basic):
        return value  # type: ignore[return-value]
    if isinstance(value, bool) or not isinstance(value, int | float | np.number):
        raise TypeError(f"{label}: expected numbers or SymPy expressions, found {value!r}")
    return sm.Integer(int(value)) if float(value).is_integer() else sm.Float(float(value))


def _as_matrix(K: Any) -> sm.Matrix:
    if isinstance(K, sm.MatrixBase):
        if K.rows == 0 or K.cols == 0:
            raise ValueError(f"K: expected a non-empty 2-D gain matrix, found shape {K.shape}")
        arr = np.asarray(K.tolist(), dtype=object)
    else:
        arr = np.asarray(K, dtype=object)
    if arr.ndim != 2:
        raise ValueError(f"K: expected a 2-D gain matrix, found {arr.ndim} dimension(s)")
    return sm.Matrix([[_as_expr(v, "K") for v in row] for row in arr])
