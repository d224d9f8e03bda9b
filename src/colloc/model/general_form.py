"""From SymPy's linearized general form to a :class:`StateSpace`, with the linear solves it needs.

Numeric matrices are solved with NumPy; symbolic ones with SymPy's LU after making floats
exact. Also the small tests of "is this value zero" used by the operating-point checks.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import sympy as sm
from sympy.physics.mechanics import msubs

from colloc.model.op_point import OperatingPointError, variable_name
from colloc.model.state_space import StateSpace, is_numeric, to_array

__all__ = [
    "format_value",
    "is_nonzero",
    "is_singular",
    "solve_linear",
    "stack",
    "symbolic_solve",
    "to_state_space",
]


def solve_linear(
    rows: sm.Matrix, unknowns: tuple[sm.Basic, ...], point: dict[sm.Basic, sm.Expr], what: str
) -> dict[sm.Basic, sm.Expr]:
    """Solve ``rows = 0``, linear in ``unknowns``, at the operating point ``point``.

    Parameters
    ----------
    rows : sympy.Matrix
        Equations linear in ``unknowns``.
    unknowns : tuple
        The unknowns, one per row.
    point : dict
        Values substituted for everything else.
    what : str
        Name of the equations, for the error message.

    Returns
    -------
    dict
        ``{unknown: value}``; floats when everything is numeric.

    Raises
    ------
    OperatingPointError
        When the coefficient matrix is singular at the point.
    """
    zero = dict.fromkeys(unknowns, 0)
    jac = msubs(rows.jacobian(unknowns), point)
    rhs = -msubs(msubs(rows, zero), point)
    problem = (
        f"op_point: the {what} cannot be solved for "
        f"{[variable_name(v) for v in unknowns]} here (singular matrix)"
    )
    if is_numeric(jac) and is_numeric(rhs):
        if is_singular(jac):
            raise OperatingPointError([problem])
        sol = np.linalg.solve(to_array(jac), to_array(rhs)).ravel()
        return {v: sm.Float(s) for v, s in zip(unknowns, sol, strict=True)}
    try:
        return dict(zip(unknowns, symbolic_solve(jac, rhs), strict=True))
    except ValueError as exc:  # SymPy's NonInvertibleMatrixError is a ValueError
        raise OperatingPointError([problem]) from exc


def to_state_space(
    m_eq: sm.Matrix,
    a_gen: sm.Matrix,
    b_gen: sm.Matrix,
    select: sm.Matrix,
    states: tuple[sm.Basic, ...],
    inputs: tuple[sm.Basic, ...],
    point: dict[sm.Basic, sm.Expr],
    options: dict[str, Any],
) -> StateSpace:
    """Solve the general form ``M z' = A_general x + B_general r`` for ``A`` and ``B``.

    Parameters
    ----------
    m_eq, a_gen, b_gen : sympy.Matrix
        The general form at the operating point (multipliers substituted).
    select : sympy.Matrix
        Picks the state derivatives out of ``z'`` (SymPy's ``perm_mat.T``).
    states, inputs : tuple
        Objects of the state and input vectors.
    point : dict
        The complete operating point, stored on the result.
    options : dict
        ``numeric`` (bool or None) and ``simplify`` (bool) as in ``linearize``.

    Returns
    -------
    StateSpace
    """
    numeric = options["numeric"]
    mats = (m_eq, a_gen, b_gen)
    if any(e.has(sm.nan, sm.zoo, sm.oo, -sm.oo) for mat in mats for e in mat):
        raise OperatingPointError(
            [
                "op_point: the linearized matrices are undefined (division by zero) here; choose "
                "other dependent coordinates/speeds or another operating point"
            ]
        )
    if all(is_numeric(mat) for mat in mats) and numeric is not False:
        if is_singular(m_eq):
            raise OperatingPointError(["op_point: the mass matrix M is singular here"])
        sel = to_array(select)
        sol = np.linalg.solve(to_array(m_eq), np.hstack([to_array(a_gen), to_array(b_gen)]))
        n = a_gen.shape[1]
        return StateSpace(
            sel @ sol[:, :n],
            sel @ sol[:, n:],
            states,
            inputs,
            to_array(m_eq),
            to_array(a_gen),
            to_array(b_gen),
            point,
        )
    try:
        sol = symbolic_solve(m_eq, a_gen.row_join(b_gen))
    except ValueError as exc:  # SymPy's NonInvertibleMatrixError is a ValueError
        raise OperatingPointError(["op_point: the mass matrix M is singular here"]) from exc
    a, b = select * sol[:, : a_gen.shape[1]], select * sol[:, a_gen.shape[1] :]
    if options["simplify"]:
        a, b = sm.simplify(a), sm.simplify(b)
    # Symbols of M and A_general may cancel (a mass dividing out), leaving numbers.
    if numeric is not False and is_numeric(a) and is_numeric(b):
        return StateSpace(to_array(a), to_array(b), states, inputs, m_eq, a_gen, b_gen, point)
    if numeric is True:
        left = StateSpace(a, b, states, inputs).free_symbols()
        raise OperatingPointError(
            [
                f"numeric: expected numbers only in A and B, found symbols "
                f"{sorted(map(variable_name, left))}; give their values in constants or op_point"
            ]
        )
    return StateSpace(a, b, states, inputs, m_eq, a_gen, b_gen, point)


def format_value(value: Any) -> str:
    """Short text of a value for messages: 6 significant digits for real numbers."""
    expr = sm.sympify(value, strict=True)
    return f"{complex(expr.evalf()).real:.6g}" if expr.is_number and expr.is_real else str(expr)


def is_nonzero(value: Any, tol: float) -> bool:
    """True when a number exceeds ``tol`` in magnitude, or an expression does not simplify to 0."""
    expr = sm.sympify(value, strict=True)
    if expr.is_number:
        return bool(abs(complex(expr.evalf())) > tol)
    return sm.simplify(expr) != 0


def is_singular(mat: sm.Matrix) -> bool:
    """True when a square matrix is rank deficient (numerically, or with a zero determinant)."""
    if mat.shape[0] == 0:
        return False
    if is_numeric(mat):
        arr = to_array(mat)
        return arr.shape[0] != arr.shape[1] or np.linalg.matrix_rank(arr) < arr.shape[0]
    return mat.shape[0] != mat.shape[1] or sm.simplify(mat.det()) == 0


def symbolic_solve(mat: sm.Matrix, rhs: sm.Matrix) -> sm.Matrix:
    """Solve ``mat x = rhs`` symbolically by LU.

    Floats are made exact first (and the result evaluated back to floats) because SymPy's
    elimination does not cancel rounded floats (``1.3*m - 1.3*m`` leaves ``4e-16*m``), which
    wrecks the pivots and the result.
    """
    has_floats = mat.has(sm.Float) or rhs.has(sm.Float)
    if has_floats:
        mat, rhs = (m.applyfunc(lambda e: sm.nsimplify(e, rational=True)) for m in (mat, rhs))
    sol = mat.LUsolve(rhs)
    return sol.evalf() if has_floats else sol


def stack(*mats: sm.Matrix) -> sm.Matrix:
    """Stack column matrices, skipping empty ones."""
    # SymPy's empty Matrix() is 0 x 0 and refuses to join with a column.
    rows = [mat for mat in mats if mat.shape[0]]
    return sm.Matrix.vstack(*rows) if rows else sm.zeros(0, 1)
