"""The gait smoother's zero-defect start: the positions filtered, the rest completed by the
scheme's inverse dynamics."""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla


def lowpass(times: np.ndarray, values: np.ndarray, cutoff_hz: float, order: int = 2) -> np.ndarray:
    """Zero-lag Butterworth low-pass of uniformly sampled columns (forward and backward).

    Parameters
    ----------
    times : ndarray, shape (N,)
        Uniform sample times.
    values : ndarray, shape (N,) or (N, k)
    cutoff_hz : float
        Cut-off frequency, below the Nyquist frequency.
    order : int
        Order of the filter applied in each direction.

    Returns
    -------
    ndarray
        Same shape as ``values``.

    Raises
    ------
    ValueError
        When the sampling is not uniform, the cut-off is not below the Nyquist frequency, or
        the record is too short for the filter's edge padding.
    """
    from colloc.data.filtering import zero_lag_lowpass
    from colloc.identify.direct import uniform_step

    h = uniform_step(times, "the Butterworth filter")
    return zero_lag_lowpass(values, 1.0 / h, cutoff_hz, order, per_pass=True)


def consistent_completion(
    problem: Any,
    z: np.ndarray,
    free: np.ndarray,
    rows: np.ndarray | None = None,
    tol: float = 1e-9,
    max_steps: int = 5,
) -> np.ndarray:
    """Change only the variables ``free`` of ``z`` (least norm) until the defects ``rows``
    (default all) are zero.

    With ``free`` the rates and the actuation of a fully actuated model, this is the inverse
    dynamics of the scheme: the rates become the scheme's differences of the positions and
    the inputs whatever makes the dynamics hold. Each step solves ``J_f d = -c`` for the
    smallest ``d`` (``d = J_f^T (J_f J_f^T)^-1 (-c)``, one sparse factorisation); the
    defects are linear in the rates' kinematic rows and in the inputs, so a few steps do.

    Parameters
    ----------
    problem : Problem
    z : ndarray
        The free vector to complete (not changed).
    free : ndarray of int
        Indices of the variables that may change.
    rows : ndarray of int, optional
        Indices of the defects to zero (e.g. the kinematic rows, to make the rates the
        scheme's differences of the positions); default every defect.
    tol : float
        Largest defect accepted.
    max_steps : int

    Returns
    -------
    ndarray
        The completed free vector.

    Raises
    ------
    ValueError
        When ``free`` cannot zero the defects (``J_f`` has not full row rank, or the steps
        stall above ``tol``), naming the largest defect left.
    """
    nlp, lay = problem.nlp, problem.layout
    jac_rows, jac_cols = nlp.jacobianstructure()
    z = np.array(z, dtype=float)
    free = np.asarray(free)
    chosen = np.arange(lay.num_constraints) if rows is None else np.asarray(rows)
    for _ in range(max_steps):
        c = nlp.constraints(z)[chosen]
        if c.size == 0 or float(np.max(np.abs(c))) <= tol:
            return z
        J = sp.csc_matrix(
            (nlp.jacobian(z), (jac_rows, jac_cols)), shape=(lay.num_constraints, nlp.n)
        )
        Jf = J[chosen][:, free]
        try:
            y = spla.spsolve((Jf @ Jf.T).tocsc(), -c)
        except RuntimeError as exc:  # exactly singular factor
            raise ValueError(f"free variables cannot zero the defects: {exc}") from exc
        if not np.all(np.isfinite(y)):
            break
        z[free] += Jf.T @ y
    c = nlp.constraints(z)[chosen]
    worst = float(np.max(np.abs(c))) if c.size else 0.0
    if not worst <= tol:
        i = int(chosen[np.nanargmax(np.abs(c))])
        raise ValueError(
            f"free variables cannot zero the defects: {worst:.3g} left at "
            f"{lay.describe_constraint(i)}"
        )
    return z
