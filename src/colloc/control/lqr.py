"""Continuous-time linear-quadratic regulator on top of SciPy's Riccati solver."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg

__all__ = ["LQRResult", "lqr"]


@dataclass(frozen=True, eq=False)
class LQRResult:
    """Result of :func:`lqr`.

    Attributes
    ----------
    K : numpy.ndarray, shape (m, n)
        Optimal gain for the control law ``u = -K x``. The same matrix serves the set-point
        form ``u = K (x_eq - x)`` used by :class:`colloc.control.StateFeedback`.
    S : numpy.ndarray, shape (n, n)
        Stabilizing solution of the continuous algebraic Riccati equation
        ``A' S + S A - S B R^-1 B' S + Q = 0``.
    eigenvalues : numpy.ndarray, shape (n,)
        Eigenvalues of the closed loop ``A - B K``, sorted by real part then imaginary part.
    """

    K: np.ndarray
    S: np.ndarray
    eigenvalues: np.ndarray

    def __iter__(self) -> Any:
        # Allows ``K, S, E = lqr(...)`` like python-control and MATLAB.
        return iter((self.K, self.S, self.eigenvalues))

    def __repr__(self) -> str:
        with np.printoptions(precision=4, suppress=True):
            return f"LQRResult(K=\n{self.K},\neigenvalues={self.eigenvalues})"


def lqr(A: Any, B: Any, Q: Any, R: Any) -> LQRResult:
    """Continuous-time linear-quadratic regulator.

    Minimizes ``J = integral(x' Q x + u' R u) dt`` subject to ``x' = A x + B u`` with the
    control law ``u = -K x``.

    Parameters
    ----------
    A : array_like, shape (n, n)
        State matrix (for example ``colloc.linearize(...).A``).
    B : array_like, shape (n, m)
        Input matrix.
    Q : array_like, shape (n, n)
        State weight; symmetric positive semi-definite.
    R : array_like, shape (m, m)
        Input weight; symmetric positive definite. A scalar is accepted when ``m == 1``.

    Returns
    -------
    LQRResult
        ``K`` (with ``u = -K x``), the Riccati solution ``S`` and the closed-loop eigenvalues.

    Raises
    ------
    ValueError
        Listing every shape, symmetry or definiteness problem of the arguments, or when the
        Riccati equation has no stabilizing solution (``(A, B)`` not stabilizable or
        ``(A, Q)`` with unobservable modes on the imaginary axis).

    Examples
    --------
    >>> import numpy as np
    >>> res = lqr([[0, 1], [0, 0]], [[0], [1]], np.eye(2), [[1]])
    >>> np.round(res.K, 6)
    array([[1.      , 1.732051]])
    """
    arrays, problems = _as_arrays({"A": A, "B": B, "Q": Q, "R": R})
    if problems:
        raise ValueError("lqr: " + "; ".join(problems))
    a, b, q, r = arrays["A"], arrays["B"], arrays["Q"], arrays["R"]
    if r.ndim == 0 or r.shape == (1,):
        r = r.reshape(1, 1)
    problems = _shape_problems(a, b, q, r)
    if problems:
        raise ValueError("lqr: " + "; ".join(problems))
    problems = _definiteness_problems(q, r)
    if problems:
        raise ValueError("lqr: " + "; ".join(problems))
    try:
        s = scipy.linalg.solve_continuous_are(a, b, q, r)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise ValueError(
            "lqr: the Riccati equation has no stabilizing solution; check that (A, B) is "
            "stabilizable and that Q does not leave unstable or imaginary-axis modes of A "
            f"unweighted (SciPy: {exc})"
        ) from exc
    k = np.linalg.solve(r, b.T @ s)
    eig = np.linalg.eigvals(a - b @ k)
    eig = eig[np.lexsort((eig.imag, eig.real))]
    return LQRResult(K=k, S=s, eigenvalues=eig)


def _as_arrays(named: dict[str, Any]) -> tuple[dict[str, np.ndarray], list[str]]:
    arrays: dict[str, np.ndarray] = {}
    problems: list[str] = []
    for name, value in named.items():
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError) as exc:
            problems.append(
                f"{name}: expected a numeric array, found {type(value).__name__} ({exc})"
            )
            continue
        if not np.all(np.isfinite(arr)):
            problems.append(f"{name}: expected finite entries, found NaN or inf")
        arrays[name] = arr
    return arrays, problems


def _shape_problems(a: np.ndarray, b: np.ndarray, q: np.ndarray, r: np.ndarray) -> list[str]:
    problems: list[str] = []
    if a.ndim != 2 or a.shape[0] != a.shape[1] or a.shape[0] == 0:
        problems.append(f"A: expected a square (n, n) matrix, found shape {a.shape}")
        return problems
    n = a.shape[0]
    if b.ndim == 1 and b.shape == (n,):
        problems.append(f"B: expected shape ({n}, m) (2-D, one column per input), found {b.shape}")
    elif b.ndim != 2 or b.shape[0] != n or b.shape[1] == 0:
        problems.append(f"B: expected shape ({n}, m) to match A, found {b.shape}")
    if q.shape != (n, n):
        problems.append(f"Q: expected shape ({n}, {n}) to match A, found {q.shape}")
    if b.ndim == 2 and r.shape != (b.shape[1], b.shape[1]):
        m = b.shape[1]
        problems.append(
            f"R: expected shape ({m}, {m}) to match the {m} column(s) of B, found {r.shape}"
        )
    return problems


def _definiteness_problems(q: np.ndarray, r: np.ndarray) -> list[str]:
    problems: list[str] = []
    for name, mat in (("Q", q), ("R", r)):
        scale = max(1.0, float(np.max(np.abs(mat))))
        asym = float(np.max(np.abs(mat - mat.T)))
        if asym > 1e-10 * scale:
            problems.append(
                f"{name}: expected a symmetric matrix, found max |{name} - {name}'| = {asym:.3g}"
            )
    if problems:
        return problems
    q_min = float(np.min(np.linalg.eigvalsh(q)))
    if q_min < -1e-10 * max(1.0, float(np.max(np.abs(q)))):
        problems.append(
            f"Q: expected positive semi-definite, found smallest eigenvalue {q_min:.3g}"
        )
    r_min = float(np.min(np.linalg.eigvalsh(r)))
    if r_min <= 1e-12 * max(1.0, float(np.max(np.abs(r)))):
        problems.append(f"R: expected positive definite, found smallest eigenvalue {r_min:.3g}")
    return problems
