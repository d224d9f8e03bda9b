"""The linear state-space model returned by :func:`colloc.model.linearize.linearize`."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, TypeAlias

import numpy as np
import sympy as sm
from sympy.core.function import AppliedUndef

from colloc.model.op_point import OperatingPointError, resolve_mapping, variable_name
from colloc.model.symbols import TIME

__all__ = ["StateSpace", "is_numeric", "to_array"]

Matrix: TypeAlias = sm.MatrixBase | np.ndarray


def is_numeric(mat: Matrix) -> bool:
    """True when every entry of ``mat`` is a finite number (no symbols, no functions of time)."""
    if isinstance(mat, np.ndarray):
        return bool(np.all(np.isfinite(mat)))
    return all(
        sm.sympify(e, strict=True).is_number and sm.sympify(e, strict=True).is_finite for e in mat
    )


def to_array(mat: Matrix) -> np.ndarray:
    """Float array of a numeric matrix (real entries; imaginary parts are an error)."""
    if isinstance(mat, np.ndarray):
        return np.asarray(mat, dtype=float)
    return np.array(sm.Matrix(mat).evalf(), dtype=float).reshape(mat.shape)


@dataclass(frozen=True, eq=False)
class StateSpace:
    """Linear model ``dx/dt = A x + B r`` about an operating point.

    ``x`` and ``r`` are deviations from the operating point. ``A`` and ``B`` are NumPy
    arrays when every entry is a number, SymPy matrices otherwise (see :meth:`to_numpy`).

    Attributes
    ----------
    A : numpy.ndarray or sympy.Matrix, shape (n, n)
        State matrix.
    B : numpy.ndarray or sympy.Matrix, shape (n, s)
        Input matrix, one column per entry of ``inputs``.
    states, inputs : tuple
        The SymPy objects of the state vector (independent coordinates then independent
        speeds) and of the input vector.
    state_names, input_names : tuple of str
        Their names (``q1``, ``u1``, ``q1_dot`` for a Lagrange speed, ...).
    M, A_general, B_general : sympy.Matrix or numpy.ndarray, optional
        The general form ``M [dq/dt; du/dt; lam] = A_general [q_ind; u_ind] + B_general r``
        (SymPy's :class:`~sympy.physics.mechanics.linearize.Linearizer`), or
        ``M dx/dt = A_general x + B_general r`` with ``M = dF/dx'`` for a
        :class:`colloc.Model`; multipliers are already substituted.
    op_point : dict
        The complete operating point used (every coordinate, speed, speed derivative,
        input and substituted constant).
    """

    A: Matrix
    B: Matrix
    states: tuple[sm.Basic, ...]
    inputs: tuple[sm.Basic, ...]
    M: Matrix | None = None
    A_general: Matrix | None = None
    B_general: Matrix | None = None
    op_point: dict[sm.Basic, sm.Expr] = field(default_factory=dict)

    @property
    def state_names(self) -> tuple[str, ...]:
        """Names of the states."""
        return tuple(variable_name(x) for x in self.states)

    @property
    def input_names(self) -> tuple[str, ...]:
        """Names of the inputs."""
        return tuple(variable_name(r) for r in self.inputs)

    @property
    def is_numeric(self) -> bool:
        """True when ``A`` and ``B`` are NumPy arrays."""
        return isinstance(self.A, np.ndarray) and isinstance(self.B, np.ndarray)

    def free_symbols(self) -> set[sm.Basic]:
        """Symbols (and functions of time) left in ``A`` and ``B``."""
        found: set[sm.Basic] = set()
        for mat in (self.A, self.B):
            if isinstance(mat, sm.MatrixBase):
                found |= mat.free_symbols | mat.atoms(AppliedUndef)
        # Time only enters through leftover functions of time, which are listed themselves.
        found.discard(TIME)
        return found

    def to_numpy(self, subs: Mapping[Any, Any] | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Return ``(A, B)`` as float arrays, substituting values for remaining symbols.

        Parameters
        ----------
        subs : mapping, optional
            Values of the symbols left in ``A`` and ``B``, keyed by symbol or name.

        Returns
        -------
        A, B : numpy.ndarray

        Raises
        ------
        OperatingPointError
            If ``subs`` names unknown symbols or symbols remain after substitution.
        """
        if self.is_numeric and not subs:
            return np.array(self.A, dtype=float), np.array(self.B, dtype=float)
        left = sorted(self.free_symbols(), key=variable_name)
        problems: list[str] = []
        values = resolve_mapping(subs, left, "subs", problems)
        remaining = [variable_name(s) for s in left if s not in values]
        if remaining:
            problems.append(f"subs: missing values for {remaining}")
        if problems:
            raise OperatingPointError(problems)
        mats = [
            m if isinstance(m, np.ndarray) else sm.Matrix(m).xreplace(values)
            for m in (self.A, self.B)
        ]
        return to_array(mats[0]), to_array(mats[1])

    def __repr__(self) -> str:
        kind = "numeric" if self.is_numeric else "symbolic"
        with np.printoptions(precision=5, suppress=True):
            return (
                f"StateSpace({kind}, states={list(self.state_names)}, "
                f"inputs={list(self.input_names)},\nA=\n{self.A},\nB=\n{self.B})"
            )
