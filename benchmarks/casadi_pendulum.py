"""The seed's pendulum identification written by hand in CasADi: the reference colloc is timed against.

What a careful user would write without colloc, in one script that imports only SymPy,
CasADi, NumPy and SciPy: Kane's equations of the n-link pendulum on a spring-damper cart
(the plant of ``colloc.models.pendulum_cart``: unit masses and lengths, k = 10 N/m,
c = 5 N s/m), LQR about upright (Q = I, R = I), a closed-loop simulation under the seed's
12-sine cart force (amplitude 10 N, seeded phases), angle and cart noise (0.25 deg and its arc
on 1 m), then midpoint collocation on the sample grid with the gains unknown, the
per-interval defects ``M(x_m) (x_{k+1} - x_k) / h - f(x_m, F_m, K)`` mapped over all intervals,
``nlpsol('ipopt', expand=True)`` with the exact Hessian and MUMPS (CasADi's bundled IPOPT) and
IPOPT's default-ish options as colloc uses them (tol 1e-8, adaptive mu).

    python benchmarks/casadi_pendulum.py -n 1 -d 60 -s 100 -i close
    python benchmarks/casadi_pendulum.py -n 4 -i direct --json out.json

Prints the phase times (derive, simulate, build, solve), IPOPT's iterations and status and the
largest relative gain error; ``--json`` writes them. ``benchmarks/startup.py`` runs it as a
whole process next to ``colloc pendulum``.
"""

from __future__ import annotations

import argparse
import json
import time

T_START = time.perf_counter()

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402
import scipy.linalg  # noqa: E402
import sympy as sm  # noqa: E402
import sympy.physics.mechanics as me  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402
from scipy.signal import savgol_filter  # noqa: E402

T_IMPORTED = time.perf_counter()
CYCLES = np.array([7, 11, 16, 25, 38, 61, 103, 131, 151, 181, 313, 523], dtype=float)


def derive(n: int):
    """Kane's equations: ``M(q) u' = f(q, u, T, F)`` as CasADi functions of x, T, F."""
    q = me.dynamicsymbols(f"q0:{n + 1}")
    u = me.dynamicsymbols(f"u0:{n + 1}")
    T = me.dynamicsymbols(f"T1:{n + 1}")
    F = me.dynamicsymbols("F")
    k, c, g = 10.0, 5.0, 9.81
    N = me.ReferenceFrame("N")
    origin = me.Point("O")
    origin.set_vel(N, 0)
    P = origin.locatenew("P0", q[0] * N.x)
    P.set_vel(N, u[0] * N.x)
    bodies = [me.Particle("Pa0", P, 1.0)]
    loads = [(P, (F - k * q[0] - c * u[0]) * N.x)]
    frames = [N]
    for i in range(1, n + 1):
        A = N.orientnew(f"A{i}", "Axis", (q[i], N.z))
        A.set_ang_vel(N, u[i] * N.z)
        Pi = P.locatenew(f"P{i}", 1.0 * A.y)
        Pi.v2pt_theory(P, N, A)
        bodies.append(me.Particle(f"Pa{i}", Pi, 1.0))
        loads += [(Pi, -g * N.y), (A, T[i - 1] * N.z)]
        if i > 1:
            loads.append((frames[i - 1], -T[i - 1] * N.z))
        frames.append(A)
        P = Pi
    kane = me.KanesMethod(
        N, q_ind=q, u_ind=u, kd_eqs=[a.diff() - b for a, b in zip(q, u, strict=True)]
    )
    kane.kanes_equations(bodies, loads)
    # sympy -> casadi through lambdify with casadi's sin/cos
    xs = sm.symbols(f"x0:{2 * n + 2}")
    Ts = sm.symbols(f"t0:{n}")
    Fs = sm.Symbol("f")
    swap = dict(zip(list(q) + list(u) + list(T) + [F], list(xs) + list(Ts) + [Fs], strict=True))
    Mm = kane.mass_matrix.xreplace(swap)
    fm = kane.forcing.xreplace(swap)
    x = ca.SX.sym("x", 2 * n + 2)
    t = ca.SX.sym("T", n)
    f = ca.SX.sym("F")
    mod = [{"sin": ca.sin, "cos": ca.cos}, "math"]
    Mfun = sm.lambdify([xs, Ts, Fs], list(Mm), modules=mod)
    ffun = sm.lambdify([xs, Ts, Fs], list(fm), modules=mod)
    xl = [x[i] for i in range(2 * n + 2)]
    tl = [t[i] for i in range(n)]
    M = ca.reshape(ca.vertcat(*[ca.SX(e) for e in Mfun(xl, tl, f)]), n + 1, n + 1).T
    rhs = ca.vertcat(*[ca.SX(e) for e in ffun(xl, tl, f)])
    return ca.Function("M", [x], [M]), ca.Function("f", [x, t, f], [rhs])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("-n", type=int, default=1, help="links")
    ap.add_argument("-d", type=float, default=60.0, help="duration [s]")
    ap.add_argument("-s", type=float, default=100.0, help="sample rate [Hz]")
    ap.add_argument("-i", choices=["close", "direct"], default="close", help="gain guess")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    n, nx = a.n, 2 * a.n + 2
    times = {}
    rng = np.random.default_rng(a.seed)

    t0 = time.perf_counter()
    Mf, ff = derive(n)
    x, tq, fq = ca.SX.sym("x", nx), ca.SX.sym("T", n), ca.SX.sym("F")
    xdot = ca.vertcat(x[n + 1 :], ca.solve(Mf(x), ff(x, tq, fq)))
    jac = ca.Function("AB", [x, tq, fq], [ca.jacobian(xdot, x), ca.jacobian(xdot, tq)])
    A, B = (np.array(m) for m in jac(np.zeros(nx), np.zeros(n), 0.0))
    S = scipy.linalg.solve_continuous_are(A, B, np.eye(nx), np.eye(n))
    K = np.linalg.solve(np.eye(n), B.T @ S)
    times["derive"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    w = 2 * np.pi * CYCLES / 240.0
    phase = rng.uniform(0, 2 * np.pi, w.size)

    def force(t):
        return 10.0 * np.sin(np.multiply.outer(t, w) + phase).sum(axis=-1)

    closed = ca.Function("cl", [x, fq], [ca.substitute(xdot, tq, -K @ x)])
    N = int(np.floor(a.d * a.s + 1e-9)) + 1
    tt = np.arange(N) / a.s
    sol = solve_ivp(
        lambda t, y: np.array(closed(y, force(t))).ravel(),
        (0, tt[-1]),
        np.zeros(nx),
        t_eval=tt,
        method="LSODA",
        rtol=1e-8,
        atol=1e-8,
    )
    X = sol.y.T
    Fd = force(tt)
    std = np.r_[np.deg2rad(0.25), np.full(n, np.deg2rad(0.25))]
    meas = X[:, : n + 1] + std * rng.standard_normal((N, n + 1))
    times["simulate"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    h = 1.0 / a.s
    xk, xk1 = ca.SX.sym("xk", nx), ca.SX.sym("xk1", nx)
    Fm, Kp = ca.SX.sym("Fm"), ca.SX.sym("K", n, nx)
    xm = (xk + xk1) / 2
    dx = (xk1 - xk) / h
    defect = ca.vertcat(
        dx[: n + 1] - xm[n + 1 :],
        Mf(xm) @ dx[n + 1 :] - ff(xm, -Kp @ xm, Fm),
    )
    interval = ca.Function("interval", [xk, xk1, Fm, Kp], [defect])
    Xv = ca.MX.sym("X", nx, N)
    Kv = ca.MX.sym("K", n, nx)
    Fmid = (Fd[:-1] + Fd[1:]) / 2
    g = interval.map(N - 1)(Xv[:, :-1], Xv[:, 1:], Fmid[None, :], ca.repmat(Kv, 1, N - 1))
    obj = ca.sumsqr(Xv[: n + 1, :] - meas.T) / N
    z = ca.veccat(Xv, Kv)
    solver = ca.nlpsol(
        "id",
        "ipopt",
        {"x": z, "f": obj, "g": ca.vec(g)},
        {
            "expand": True,
            "print_time": False,
            "ipopt": {"tol": 1e-8, "mu_strategy": "adaptive", "print_level": 0, "sb": "yes"},
        },
    )
    times["build"] = time.perf_counter() - t0

    # the same start as colloc: Savitzky-Golay (0.15 s window) states, gains close or direct
    win = int(round(0.15 * a.s)) | 1
    qs = savgol_filter(meas, win, 3, axis=0)
    qd = savgol_filter(meas, win, 3, deriv=1, delta=h, axis=0)
    qdd = savgol_filter(meas, win, 3, deriv=2, delta=h, axis=0)
    x0 = np.hstack([qs, qd])
    if a.i == "close":
        K0 = K + 0.5 * np.abs(K) * rng.standard_normal(K.shape)
    else:
        # least squares of M(x) qdd - f(x, -K x, F) = 0, which is linear in K
        acc = ca.SX.sym("acc", n + 1)
        res = Mf(x) @ acc - ff(x, -Kp @ x, fq)
        kv = ca.vec(Kp)
        reg = ca.Function(
            "reg", [x, acc, fq], [ca.jacobian(res, kv), ca.substitute(res, kv, 0 * kv)]
        )
        A_all, r_zero = reg.map(N)(x0.T, qdd.T, Fd[None, :])
        design = np.array(A_all).reshape(n + 1, N, n * nx).transpose(1, 0, 2).reshape(-1, n * nx)
        target = -np.array(r_zero).T.reshape(-1)
        K0 = np.linalg.lstsq(design, target, rcond=None)[0].reshape(n, nx, order="F")
    t0 = time.perf_counter()
    out = solver(x0=np.r_[x0.T.ravel(order="F"), K0.ravel(order="F")], lbg=0, ubg=0)
    times["solve"] = time.perf_counter() - t0
    stats = solver.stats()
    Kid = np.array(out["x"][-n * nx :]).reshape(n, nx, order="F")
    record = {
        "links": n,
        "nodes": N,
        "guess": a.i,
        "times": times,
        "import_seconds": T_IMPORTED - T_START,
        "iterations": int(stats["iter_count"]),
        "status": stats["return_status"],
        "max_rel_gain_error": float(np.max(np.abs(Kid - K) / np.abs(K))),
        "in_process_seconds": time.perf_counter() - T_START,
    }
    print(json.dumps(record))
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(record, fh)


if __name__ == "__main__":
    main()
