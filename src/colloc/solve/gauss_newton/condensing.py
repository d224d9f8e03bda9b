"""Condensing: each segment's state steps propagated through the linearized defects, so
that only its first state, the links between segments and the parameters remain; the step
expanded back; the adjoint recursion for the defects' multipliers."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from colloc.solve.gauss_newton.banded import Links, solve_bordered
from colloc.solve.gauss_newton.structure import Blocks, Chain


class WallTime(Exception):
    """The wall-time limit passed inside an iteration."""


def segment_bounds(N: int, length: int) -> list[tuple[int, int]]:
    """First and last node of each segment; the last one absorbs a short remainder."""
    starts = list(range(0, N - 1, length))
    if len(starts) > 1 and N - 1 - starts[-1] < length // 2:
        starts.pop()
    ends = [s - 1 for s in starts[1:]] + [N - 1]
    return list(zip(starts, ends, strict=True))


class Reached:
    """The parameters a segment has reached, in the order it reached them."""

    def __init__(self, q: int) -> None:
        self.slot = np.full(q + 1, -1, np.int64)
        self.order = np.zeros(q + 1, np.int64)
        self.count = 0

    def reach(self, columns: np.ndarray) -> np.ndarray:
        """Positions of ``columns`` (parameter indices), adding those not reached yet."""
        new = np.unique(columns[self.slot[columns] < 0])
        self.slot[new] = self.count + np.arange(new.size)
        self.order[self.count : self.count + new.size] = new
        self.count += new.size
        return self.slot[columns]


@dataclass
class InputSolve:
    """How a segment's inputs follow from the reduced unknowns:
    ``du = -Z [dy_s; dtheta[params]; 1; nu_{s-1}; nu_s]``."""

    Z: np.ndarray
    params: np.ndarray


@dataclass
class Reduced:
    """The condensed system before damping."""

    H_loc: np.ndarray  # (S, n, n)
    H_cross: np.ndarray  # (S, n, q)
    H_theta: np.ndarray  # (q, q)
    g_loc: np.ndarray  # (S, n)
    g_theta: np.ndarray  # (q,)
    links: Links
    inputs: list[InputSolve]  # one per segment when the chain has free inputs


class Step:
    """Condense, solve the reduced system, expand: one Gauss-Newton step."""

    def __init__(self, chain: Chain, segments: list[tuple[int, int]]) -> None:
        self.chain, self.segments = chain, segments

    def condense(self, b: Blocks, deadline: float, damping: float) -> Reduced:
        """The reduced system of the segments' first states, links and parameters.

        Each segment's free inputs are eliminated from its own dense block (their KKT rows,
        with ``damping`` on their diagonal), which couples the segment's two links.
        """
        ch = self.chain
        n, m, nv, q, S = ch.n, ch.m, ch.nv, ch.q, len(self.segments)
        H_loc = np.zeros((S, n, n))
        H_cross = np.zeros((S, n, q + 1))
        H_theta = b.H_theta.copy()
        g_loc = np.zeros((S, n))
        g_theta = np.r_[b.g_theta, 0.0]
        links = Links(S - 1, n, m, q)
        inputs: list[InputSolve] = []
        for s, (first, last) in enumerate(self.segments):
            # columns of the segment's unknowns: its first state, its inputs node by node,
            # then the parameters it has reached (column base + i holds reached[i]; q, the
            # padding column, included)
            base = n + (last - first + 1) * m
            X = np.zeros((n, base + q + 1))
            X[:, :n] = np.eye(n)
            # d v_k / d unknowns: the states' rows are X's, the inputs' rows pick u_k (without
            # inputs V is X itself, saving a copy per node)
            V = X if m == 0 else np.zeros((nv, base + q + 1))
            columns = Reached(q)
            d = np.zeros(n)
            rows: list[np.ndarray] = []
            grad = np.zeros(base + q + 1)
            # node-parameter curvature: rows as X's columns, columns by parameter
            coupled = bool(ch.coupled[first : last + 1].any())
            cross = np.zeros((base + q + 1, q + 1) if coupled else (0, 0))
            for k in range(first, last + 1):
                w = base + columns.count
                u = n + (k - first) * m
                if m:
                    V[:n, :w] = X[:, :w]
                    V[n:, u - m : u] = 0.0
                    V[n:, u : u + m] = np.eye(m)
                dv = np.r_[d, np.zeros(m)]
                if b.rank[k].any():
                    rows.append(b.factor[k][:, b.rank[k]].T @ V[:, :w])
                    grad[:w] += V[:, :w].T @ (b.g[k] + b.H[k] @ dv)
                if ch.coupled[k]:
                    cols_k = ch.node_columns[k]
                    cross[:w, cols_k] += V[:, :w].T @ b.H_cross[k]
                    grad[base + columns.reach(cols_k)] += b.H_cross[k].T @ dv
                if k < last:
                    at = base + columns.reach(ch.columns[k])
                    w = base + columns.count
                    X[:, :w] = b.A[k] @ V[:, :w]
                    X[:, u + m : u + 2 * m] += b.Bu[k]
                    X[:, at] += b.B[k]
                    d = b.A[k][:, :n] @ d + b.a[k]
            if time.perf_counter() > deadline:
                raise WallTime
            w = base + columns.count
            real = np.flatnonzero(columns.order[: columns.count] < q)
            params = columns.order[real]
            local = np.r_[np.arange(base), base + real]
            Q = np.zeros((local.size, local.size))
            if rows:
                R = np.zeros((sum(r.shape[0] for r in rows), w))
                i = 0
                for r in rows:
                    R[i : i + r.shape[0], : r.shape[1]] = r
                    i += r.shape[0]
                Q = sla.blas.dsyrk(1.0, R[:, local], trans=1)
                Q = np.triu(Q) + np.triu(Q, 1).T
            if coupled:
                W = cross[local][:, params]
                Q[:, base:] += W
                Q[base:, :] += W.T
            gq = grad[local]
            link_row = None
            if last < ch.N - 1:
                # the defects of the interval after the segment, in its unknowns
                link_row = b.D[last] @ V[:, :w]
                links.C[s] = link_row[:, :n]
                links.G[s][:, columns.order[: columns.count]] = link_row[:, base:w]
                links.G[s][:, ch.columns[last]] += b.T[last]
                links.E[s] = b.state_E[last]
                links.EU[s] = b.E[last][:, n:]
                links.r[s] = -b.c[last] - b.D[last][:, :n] @ d
            if m:
                Q, gq = self._eliminate_inputs(
                    s, Q, gq, base, params, link_row, links, inputs, damping
                )
            H_loc[s] += Q[:n, :n]
            H_cross[s][:, params] += Q[:n, n:]
            H_theta[np.ix_(params, params)] += Q[n:, n:]
            g_loc[s] += gq[:n]
            g_theta[params] += gq[n:]
        return Reduced(H_loc, H_cross[:, :, :q], H_theta, g_loc, g_theta[:q], links, inputs)

    def _eliminate_inputs(
        self,
        s: int,
        Q: np.ndarray,
        gq: np.ndarray,
        base: int,
        params: np.ndarray,
        link_row: np.ndarray | None,
        links: Links,
        inputs: list[InputSolve],
        damping: float,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Segment ``s``'s Hessian and gradient in its first state and parameters, its inputs
        eliminated by their own KKT rows (``G_UU du + G_Uw dw + g_U + J^T nu = 0``, ``J`` the
        inputs' columns of the links before and after the segment); the links take the
        inputs' share and ``inputs`` how to recover them."""
        n, m = self.chain.n, self.chain.m
        U = np.arange(n, base)
        keep = np.r_[np.arange(n), np.arange(base, Q.shape[0])]
        nk = keep.size
        G_UU = Q[np.ix_(U, U)]
        diag = np.diag(G_UU).copy()
        idx = np.arange(U.size)
        # an input without a prior of its own (a free trajectory) is held by the damping
        floor = 1e-8 * max(float(diag.max(initial=0.0)), 1.0)
        factor = None
        while factor is None:
            try:
                damped = G_UU.copy()
                damped[idx, idx] += max(damping, 1e-12) * np.maximum(diag, floor)
                factor = sla.cho_factor(damped, check_finite=False)
            except np.linalg.LinAlgError:
                damping = 10.0 * max(damping, 1e-12)
        prev = np.zeros((n, U.size))
        if s > 0:
            prev[:, :m] = links.EU[s - 1]
        after = np.zeros((n, U.size)) if link_row is None else link_row[:, U]
        rhs = np.column_stack([Q[np.ix_(U, keep)], gq[U], prev.T, after.T])
        Z = sla.cho_solve(factor, rhs, check_finite=False)
        coupling = Q[np.ix_(keep, U)]
        reduced = Q[np.ix_(keep, keep)] - coupling @ Z[:, :nk]
        gradient = gq[keep] - coupling @ Z[:, nk]
        into_nu = slice(nk + 1, nk + 1 + n), slice(nk + 1 + n, nk + 1 + 2 * n)
        if s > 0:
            JZ = prev @ Z
            links.E[s - 1] -= JZ[:, :n]
            links.G[s - 1][:, params] -= JZ[:, n:nk]
            links.r[s - 1] += JZ[:, nk]
            links.N[s - 1] -= JZ[:, into_nu[0]]
            if link_row is not None:
                links.O[s - 1] -= JZ[:, into_nu[1]]
        if link_row is not None:
            JZ = after @ Z
            links.C[s] -= JZ[:, :n]
            links.G[s][:, params] -= JZ[:, n:nk]
            links.r[s] += JZ[:, nk]
            links.N[s] -= JZ[:, into_nu[1]]
        inputs.append(InputSolve(Z, params))
        return 0.5 * (reduced + reduced.T), gradient

    def solve(self, b: Blocks, r: Reduced, damping: float) -> np.ndarray:
        """The full step ``dz`` with ``damping`` on the reduced Hessian's diagonal (the
        condensed system is kept, so raising the damping costs one banded solve)."""
        ch = self.chain
        n, q = ch.n, ch.q
        H_loc, H_theta = r.H_loc.copy(), r.H_theta.copy()
        diagonals = np.r_[np.einsum("sii->si", H_loc).ravel(), np.diag(H_theta)]
        floor = 1e-8 * max(float(diagonals.max(initial=0.0)), 1.0)
        idx = np.arange(n)
        H_loc[:, idx, idx] += damping * np.maximum(H_loc[:, idx, idx], floor)
        H_theta[np.diag_indices(q)] += damping * np.maximum(np.diag(H_theta), floor)
        dy, dtheta, nu = solve_bordered(
            H_loc, r.H_cross, H_theta, r.g_loc, r.g_theta, r.links, ch.m > 0
        )
        du = np.zeros((ch.N, ch.m))
        if ch.m:
            nu = np.concatenate([np.zeros((1, n)), nu, np.zeros((1, n))])
            for s, (first, last) in enumerate(self.segments):
                e = r.inputs[s]
                vector = np.r_[dy[s], dtheta[e.params], 1.0, nu[s], nu[s + 1]]
                du[first : last + 1] = -(e.Z @ vector).reshape(last - first + 1, ch.m)
        return self.expand(b, dy, dtheta, du)

    def expand(self, b: Blocks, dy: np.ndarray, dtheta: np.ndarray, du: np.ndarray) -> np.ndarray:
        """The full step: states propagated through every segment from its first state."""
        ch = self.chain
        n = ch.n
        padded = np.r_[dtheta, 0.0]
        forcing = np.einsum("kij,kj->ki", b.B, padded[ch.columns]) + b.a
        if ch.m:
            forcing += np.einsum("kij,kj->ki", b.A[:, :, n:], du[:-1])
            forcing += np.einsum("kij,kj->ki", b.Bu, du[1:])
        A = b.A[:, :, :n]
        dx = np.zeros((ch.N, n))
        for s, (first, last) in enumerate(self.segments):
            dx[first] = dy[s]
            for k in range(first, last):
                dx[k + 1] = A[k] @ dx[k] + forcing[k]
        full = np.zeros(ch.num_variables)
        full[ch.nodes] = np.concatenate([dx, du], axis=1)
        full[ch.parameter_index] = dtheta
        return full


def adjoint(b: Blocks, gradient: np.ndarray) -> np.ndarray:
    """Defect multipliers ``(N-1, n)`` making every node's states but the first stationary.

    Solves ``gradient_k + D_k^T lambda_k + E_{k-1}^T lambda_{k-1} = 0`` (state columns)
    backwards from the last node (which no later defect touches).
    """
    N1, n = b.c.shape
    D, E = b.D[:, :, :n], b.state_E
    lam = np.zeros((N1, n))
    lam[N1 - 1] = -np.linalg.solve(E[N1 - 1].T, gradient[N1, :n])
    for k in range(N1 - 1, 0, -1):
        lam[k - 1] = -np.linalg.solve(E[k - 1].T, gradient[k, :n] + D[k].T @ lam[k])
    return lam


def defect_multipliers(chain: Chain, b: Blocks, m: int) -> np.ndarray:
    """Defect multipliers (``L = f + lambda^T c``) at the final iterate."""
    lam = adjoint(b, b.g)
    out = np.zeros(m)
    out[chain.row_order] = lam.ravel()
    return out
