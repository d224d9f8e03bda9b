"""Linear-quadratic regulator for a linear time-periodic system ``x' = A(t) x + B(t) u``.

The periodic Riccati differential equation

.. math::

    -S' = A^T S + S A - S B R^{-1} B^T S + Q

is integrated backward in time over repeated periods until ``S`` at the start of the period
stops changing; its periodic solution gives the gain ``K(t) = R^{-1} B^T S(t)`` of
``u = -K(t) x``, which minimises ``integral(x' Q x + u' R u) dt`` over an infinite horizon.
Stability of the closed loop is judged by its Floquet multipliers, the eigenvalues of the
monodromy matrix (the state-transition matrix over one period).

``A`` and ``B`` are given at samples of one period and interpolated with periodic cubic
interpolation (see ``_periodic_spline``); both ODEs are integrated with SciPy's implicit Radau method and exact Jacobians,
since linearised contact models are stiff.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.integrate
import scipy.interpolate
import scipy.linalg

__all__ = [
    "RiccatiBreakdownError",
    "PeriodicLQRResult",
    "discrete_monodromy",
    "monodromy",
    "periodic_lqr",
    "sampled_periodic_lqr",
]


@dataclass(frozen=True, eq=False)
class PeriodicLQRResult:
    """Result of :func:`periodic_lqr`.

    Attributes
    ----------
    K : numpy.ndarray, shape (N, m, n)
        Gain at each sample time for ``u = -K(t) x``.
    S : numpy.ndarray, shape (N, n, n)
        Periodic solution of the Riccati differential equation at each sample time.
    floquet_multipliers : numpy.ndarray, shape (n,)
        Eigenvalues of the closed-loop monodromy matrix, largest magnitude first; the closed
        loop is asymptotically stable when all lie inside the unit circle.
    times : numpy.ndarray, shape (N,)
        The sample times.
    num_periods : int
        Periods integrated backward until ``S(t_0)`` converged.
    """

    K: np.ndarray
    S: np.ndarray
    floquet_multipliers: np.ndarray
    times: np.ndarray
    num_periods: int

    def __iter__(self) -> Any:
        # ``K, S, mu = periodic_lqr(...)`` like lqr's ``K, S, E``.
        return iter((self.K, self.S, self.floquet_multipliers))

    @property
    def spectral_radius(self) -> float:
        """Largest Floquet multiplier magnitude."""
        return float(np.max(np.abs(self.floquet_multipliers)))


def periodic_lqr(
    A: Any,
    B: Any,
    times: Any,
    Q: Any,
    R: Any,
    *,
    tol: float = 1e-8,
    max_cycles: int = 200,
    rtol: float = 1e-8,
) -> PeriodicLQRResult:
    """Periodic LQR gain of ``x' = A(t) x + B(t) u`` by backward Riccati integration.

    Parameters
    ----------
    A : array_like, shape (N, n, n)
        State matrix at ``times``; ``A[-1]`` must equal ``A[0]`` (the samples span one period).
    B : array_like, shape (N, n, m)
        Input matrix at ``times``; ``B[-1]`` must equal ``B[0]``.
    times : array_like, shape (N,)
        Strictly increasing sample times, ``N >= 3``; the period is ``times[-1] - times[0]``.
    Q : array_like, shape (n, n)
        State weight, symmetric positive semi-definite.
    R : array_like, shape (m, m)
        Input weight, symmetric positive definite.
    tol : float
        Convergence threshold on ``max|S_k(t_0) - S_{k-1}(t_0)| / max|S_k(t_0)|`` between
        successive periods.
    max_cycles : int
        Most periods to integrate backward.
    rtol : float
        Relative tolerance of the ODE integrations.

    Returns
    -------
    PeriodicLQRResult

    Raises
    ------
    ValueError
        Listing every shape, periodicity, symmetry or definiteness problem of the arguments,
        or when ``S`` does not converge within ``max_cycles`` periods (the system is then
        likely not stabilisable).
    """
    a, b, t, q, r = _validated(A, B, times, Q, R, tol, max_cycles)
    n = b.shape[1]
    a_of, b_of = _periodic_spline(t, a), _periodic_spline(t, b)
    r_inv = np.linalg.inv(r)
    eye = np.eye(n)

    def rhs(tau: float, s_flat: np.ndarray) -> np.ndarray:
        s = s_flat.reshape(n, n)
        at, bt = a_of(tau), b_of(tau)
        sb = s @ bt
        return -(at.T @ s + s @ at - sb @ r_inv @ sb.T + q).ravel()

    def jac(tau: float, s_flat: np.ndarray) -> np.ndarray:
        # d(S')/dS = -(Acl' X + X Acl) with Acl = A - B R^-1 B' S, written for row-major vec.
        s = s_flat.reshape(n, n)
        at, bt = a_of(tau), b_of(tau)
        acl = at - bt @ r_inv @ bt.T @ s
        return -(np.kron(acl.T, eye) + np.kron(eye, acl.T))

    s_end = _initial_guess(a, b, q, r)
    previous = s_end
    for periods in range(1, max_cycles + 1):  # noqa: B007 (count reported)
        sol = scipy.integrate.solve_ivp(
            rhs,
            (t[-1], t[0]),
            s_end.ravel(),
            method="Radau",
            jac=jac,
            dense_output=True,
            rtol=rtol,
            atol=rtol * max(1.0, float(np.max(np.abs(s_end)))),
        )
        if not sol.success:
            raise ValueError(f"periodic_lqr: Riccati integration failed ({sol.message})")
        s_start = _symmetric(sol.y[:, -1].reshape(n, n))
        change = np.max(np.abs(s_start - previous)) / max(np.max(np.abs(s_start)), 1e-300)
        previous = s_end = s_start
        if change < tol:
            break
    else:
        raise ValueError(
            f"periodic_lqr: S(t0) did not converge within max_cycles={max_cycles} periods "
            f"(last relative change {change:.3g}); check that (A, B) is stabilisable"
        )
    S = np.array([_symmetric(sol.sol(ti).reshape(n, n)) for ti in t])
    S[-1] = S[0]
    K = np.einsum("ij,kjl->kil", r_inv, np.einsum("kji,kjl->kil", b, S))
    acl = a - np.einsum("kij,kjl->kil", b, K)
    mu = np.linalg.eigvals(monodromy(acl, t, rtol=rtol))
    mu = mu[np.argsort(-np.abs(mu), kind="stable")]
    return PeriodicLQRResult(K=K, S=S, floquet_multipliers=mu, times=t, num_periods=periods)


def monodromy(A: Any, times: Any, *, rtol: float = 1e-8) -> np.ndarray:
    """State-transition matrix of ``x' = A(t) x`` over one period.

    Parameters
    ----------
    A : array_like, shape (N, n, n)
        System matrix at ``times`` (for a closed loop, ``A - B K``); ``A[-1]`` must equal
        ``A[0]``. It is interpolated linearly and periodically.
    times : array_like, shape (N,)
        Strictly increasing sample times spanning one period.
    rtol : float
        Relative tolerance of the integration.

    Returns
    -------
    numpy.ndarray, shape (n, n)
        ``Phi(t_N, t_0)``; its eigenvalues are the Floquet multipliers.

    Raises
    ------
    ValueError
        If the shapes do not match or ``A`` is not periodic over the samples.
    """
    a = np.asarray(A, dtype=float)
    t = np.asarray(times, dtype=float)
    problems = _time_problems(t)
    if a.ndim != 3 or a.shape[1] != a.shape[2] or a.shape[0] != t.size:
        problems.append(f"A: expected shape ({t.size}, n, n), found {a.shape}")
    else:
        problems += _periodicity_problems("A", a)
    if problems:
        raise ValueError("monodromy: " + "; ".join(problems))
    n = a.shape[1]
    a_of = _periodic_spline(t, a)
    eye = np.eye(n)

    def rhs(tau: float, phi_flat: np.ndarray) -> np.ndarray:
        return (a_of(tau) @ phi_flat.reshape(n, n)).ravel()

    def jac(tau: float, phi_flat: np.ndarray) -> np.ndarray:
        return np.kron(a_of(tau), eye)

    sol = scipy.integrate.solve_ivp(
        rhs, (t[0], t[-1]), eye.ravel(), method="Radau", jac=jac, rtol=rtol, atol=rtol * 1e-3
    )
    if not sol.success:
        raise ValueError(f"monodromy: integration failed ({sol.message})")
    return sol.y[:, -1].reshape(n, n)


class RiccatiBreakdownError(ValueError):
    """The periodic Riccati recursion did not converge or broke down (``S`` overflowed, or
    ``R h + Gamma^T S Gamma`` became singular): the sampled system is not stabilisable as
    given."""


def sampled_periodic_lqr(
    A: Any,
    B: Any,
    times: Any,
    Q: Any,
    R: Any,
    *,
    tol: float = 1e-9,
    max_cycles: int = 500,
) -> PeriodicLQRResult:
    """Periodic LQR of the system discretised exactly between the samples.

    On each interval ``[t_k, t_k+1]`` the system is frozen at the mean of its end samples and
    discretised exactly for piecewise-constant input (matrix exponential);
    the periodic discrete Riccati recursion with ``Q h``, ``R h`` is iterated backward over
    periods until ``S_0`` converges. As the sample spacing ``h`` shrinks this tends to
    :func:`periodic_lqr`; unlike the Riccati ODE it cannot be upset by stiffness or by
    abrupt changes of ``A`` between samples (contact), and it is fast.

    Parameters and result as in :func:`periodic_lqr` (``K`` is the gain on each interval's
    left sample; ``K[-1] = K[0]``). The Floquet multipliers are those of the discretised
    closed loop (:func:`discrete_monodromy` of ``A - B K``). Raises
    :class:`RiccatiBreakdownError` (a ``ValueError``) when the recursion does not converge
    or breaks down.
    """
    a, b, t, q, r = _validated(A, B, times, Q, R, tol, max_cycles)
    phis, gammas, hs = _discretised(a, b, t)
    n = a.shape[1]
    s_next = _initial_guess(a, b, q, r)
    num = t.size - 1
    S = np.zeros((t.size, n, n))
    K = np.zeros((t.size, b.shape[2], n))
    previous = s_next
    for periods in range(1, max_cycles + 1):  # noqa: B007 (count reported)
        for k in range(num - 1, -1, -1):
            phi, gam, h = phis[k], gammas[k], hs[k]
            gs = gam.T @ s_next
            try:
                K[k] = np.linalg.solve(r * h + gs @ gam, gs @ phi)
            except np.linalg.LinAlgError as exc:
                raise _breakdown(k, periods, "R h + Gamma^T S Gamma became singular") from exc
            s_next = _symmetric(q * h + phi.T @ s_next @ (phi - gam @ K[k]))
            if not np.all(np.isfinite(s_next)):
                raise _breakdown(k, periods, "S overflowed")
            S[k] = s_next
        change = np.max(np.abs(s_next - previous)) / max(np.max(np.abs(s_next)), 1e-300)
        previous = s_next
        if change < tol:
            break
    else:
        raise RiccatiBreakdownError(
            f"sampled_periodic_lqr: S(t0) did not converge within max_cycles={max_cycles} "
            f"periods (last relative change {change:.3g}); check that (A, B) is stabilisable"
        )
    S[-1], K[-1] = S[0], K[0]
    # A plain loop: numpy's multi_dot recurses once per factor and fails beyond ~1000.
    monodromy = np.eye(n)
    for k in range(num):
        monodromy = (phis[k] - gammas[k] @ K[k]) @ monodromy
    mu = np.linalg.eigvals(monodromy)
    mu = mu[np.argsort(-np.abs(mu), kind="stable")]
    return PeriodicLQRResult(K=K, S=S, floquet_multipliers=mu, times=t, num_periods=periods)


def _breakdown(sample: int, period: int, what: str) -> RiccatiBreakdownError:
    return RiccatiBreakdownError(
        f"sampled_periodic_lqr: the Riccati recursion broke down at sample {sample} in period "
        f"{period} ({what}); check that (A, B) is stabilisable"
    )


def discrete_monodromy(A: Any, times: Any) -> np.ndarray:
    """Monodromy of ``x' = A(t) x`` with ``A`` frozen at each interval's mean.

    ``prod_k expm(h_k (A_k + A_k+1) / 2)``, the counterpart of :func:`monodromy` that
    :func:`sampled_periodic_lqr` uses; exact for piecewise-constant ``A`` and robust to
    stiffness.

    Parameters
    ----------
    A : array_like, shape (N, n, n)
    times : array_like, shape (N,)

    Returns
    -------
    numpy.ndarray, shape (n, n)
    """
    a = np.asarray(A, dtype=float)
    t = np.asarray(times, dtype=float)
    problems = _time_problems(t)
    if a.ndim != 3 or a.shape[1] != a.shape[2] or a.shape[0] != t.size:
        problems.append(f"A: expected shape ({t.size}, n, n), found {a.shape}")
    if problems:
        raise ValueError("discrete_monodromy: " + "; ".join(problems))
    phi = np.eye(a.shape[1])
    for k in range(t.size - 1):
        phi = scipy.linalg.expm(0.5 * (t[k + 1] - t[k]) * (a[k] + a[k + 1])) @ phi
    return phi


def _discretised(
    a: np.ndarray, b: np.ndarray, t: np.ndarray
) -> tuple[list[np.ndarray], list[np.ndarray], np.ndarray]:
    n, m = b.shape[1], b.shape[2]
    hs = np.diff(t)
    phis, gammas = [], []
    for k, h in enumerate(hs):
        block = np.zeros((n + m, n + m))
        block[:n, :n] = 0.5 * (a[k] + a[k + 1])
        block[:n, n:] = 0.5 * (b[k] + b[k + 1])
        e = scipy.linalg.expm(h * block)
        phis.append(e[:n, :n])
        gammas.append(e[:n, n:])
    return phis, gammas, hs


def _periodic_spline(t: np.ndarray, values: np.ndarray) -> Any:
    """Periodic piecewise-linear interpolation in time.

    Linear, not cubic: the linearisation of a contact model changes abruptly at touch-down
    and lift-off, and a cubic spline through such samples overshoots into matrices with
    large spurious unstable eigenvalues; a convex combination of neighbours does not.
    """
    closed = values.copy()
    closed[-1] = closed[0]
    period, t0 = t[-1] - t[0], t[0]

    def at(tau: float) -> np.ndarray:
        tt = t0 + (tau - t0) % period
        k = min(int(np.searchsorted(t, tt, side="right")) - 1, t.size - 2)
        w = (tt - t[k]) / (t[k + 1] - t[k])
        return (1 - w) * closed[k] + w * closed[k + 1]

    return at


def _symmetric(s: np.ndarray) -> np.ndarray:
    return 0.5 * (s + s.T)


def _initial_guess(a: np.ndarray, b: np.ndarray, q: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Riccati solution of the period-averaged system, else zero (any PSD start converges)."""
    try:
        return scipy.linalg.solve_continuous_are(a[:-1].mean(0), b[:-1].mean(0), q, r)
    except (np.linalg.LinAlgError, ValueError):
        return np.zeros_like(q)


def _time_problems(t: np.ndarray) -> list[str]:
    if t.ndim != 1 or t.size < 3:
        return [f"times: expected a 1-D array of at least 3 samples, found shape {t.shape}"]
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        return ["times: expected finite, strictly increasing values"]
    return []


def _periodicity_problems(name: str, x: np.ndarray) -> list[str]:
    gap = float(np.max(np.abs(x[-1] - x[0])))
    scale = max(1.0, float(np.max(np.abs(x))))
    if gap > 1e-8 * scale:
        return [
            f"{name}: expected the last sample to equal the first (one closed period), "
            f"found max difference {gap:.3g}"
        ]
    return []


def _validated(
    A: Any, B: Any, times: Any, Q: Any, R: Any, tol: float, max_cycles: int
) -> tuple[np.ndarray, ...]:
    problems: list[str] = []
    arrays = {}
    for name, value in (("A", A), ("B", B), ("times", times), ("Q", Q), ("R", R)):
        arr = np.asarray(value, dtype=float)
        if not np.all(np.isfinite(arr)):
            problems.append(f"{name}: expected finite entries, found NaN or inf")
        arrays[name] = arr
    a, b, t, q, r = (arrays[k] for k in ("A", "B", "times", "Q", "R"))
    problems += _time_problems(t)
    if a.ndim != 3 or a.shape[1] != a.shape[2] or a.shape[0] != t.shape[0]:
        problems.append(f"A: expected shape ({t.shape[0]}, n, n), found {a.shape}")
    else:
        n = a.shape[1]
        problems += _periodicity_problems("A", a)
        if b.ndim != 3 or b.shape[:2] != (a.shape[0], n) or b.shape[2] == 0:
            problems.append(f"B: expected shape ({a.shape[0]}, {n}, m), found {b.shape}")
        else:
            problems += _periodicity_problems("B", b)
            m = b.shape[2]
            if r.shape != (m, m):
                problems.append(f"R: expected shape ({m}, {m}), found {r.shape}")
        if q.shape != (n, n):
            problems.append(f"Q: expected shape ({n}, {n}), found {q.shape}")
    if not (isinstance(tol, float | int) and tol > 0):
        problems.append(f"tol: expected a positive number, found {tol!r}")
    if isinstance(max_cycles, bool) or not isinstance(max_cycles, int) or max_cycles < 1:
        problems.append(f"max_cycles: expected a positive integer, found {max_cycles!r}")
    if not problems:
        for name, mat in (("Q", q), ("R", r)):
            if np.max(np.abs(mat - mat.T)) > 1e-10 * max(1.0, float(np.max(np.abs(mat)))):
                problems.append(f"{name}: expected a symmetric matrix")
        if not problems:
            if np.min(np.linalg.eigvalsh(q)) < -1e-10 * max(1.0, float(np.max(np.abs(q)))):
                problems.append("Q: expected positive semi-definite")
            if np.min(np.linalg.eigvalsh(r)) <= 0:
                problems.append("R: expected positive definite")
    if problems:
        raise ValueError("periodic_lqr: " + "; ".join(problems))
    return a, b, t, q, r
