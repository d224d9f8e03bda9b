"""Constrained Gauss-Newton for one-step collocation with many global parameters.

For an NLP ``min f(z) s.t. c(z) = 0`` whose variables are states ``x_k`` at nodes
``k = 0..N-1`` plus ``q`` global parameters ``theta``, and whose constraints are one block of
``n`` defects per interval linking ``x_k``, ``x_{k+1}`` and ``theta`` (backward Euler,
midpoint), each step solves the Gauss-Newton model (the objective's Hessian; the constraints'
curvature is left out) with the linearized defects eliminated by *condensing*: within a
segment of nodes the state step is propagated forward,

    dx_{k+1} = -E_k^{-1} (D_k dx_k + T_k dtheta + c_k),

so each segment contributes a dense block in its first state and ``theta`` only, and the
segments are joined by the linearized defects at their boundaries. The reduced system has
``n * segments + q`` unknowns, so the cost per iteration grows linearly in ``N`` (where a
general sparse LDL^T of the KKT matrix fills the parameter block in at every node) and each
segment can be checked against a wall-time limit or interrupted without losing the last
accepted iterate. The step is damped (Levenberg-Marquardt on the reduced Hessian) and
globalised by a backtracking line search on the l1 merit ``f + mu sum_k ||E_k^{-1} c_k||_1``
(defects measured as corrections of the next state, with ``E_k`` frozen at the iterate).

The objective is a sum of terms each in one node's states and the parameters (tracked
states, and tracked controller outputs such as joint torques ``T*(phi) - K(phi) s``). Its
Hessian is the NLP's Gauss-Newton one (tracking terms by ``2 J^T W J``), with each node's
state block also taken positive semidefinite for any other term; the node-parameter and
parameter blocks enter the reduced system as they are.

This is the classical approach to parameter estimation in ODEs by collocation or multiple
shooting (Bock's generalized Gauss-Newton with condensing); the implementation is ours.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla

from colloc.solve.result import NLP, SolveResult
from colloc.solve.status import status_from_code

SUCCEEDED, STALLED, USER_STOP, MAX_ITER, WALL_TIME, INVALID_NUMBER = 0, 3, 5, -1, -5, -13
#: Times the damping may be raised within one iteration to reach a positive-curvature step.
MAX_DAMPING_RAISES = 12


@dataclass(frozen=True)
class ChainStructure:
    """Where the states, the parameters and the defects of a one-step NLP sit.

    Attributes
    ----------
    node_index : ndarray of int, shape (N, n)
        Free-vector index of state ``j`` at node ``k``.
    parameter_index : ndarray of int, shape (q,)
        Free-vector index of each global parameter.
    interval_rows : ndarray of int, shape (N - 1, n)
        Constraint row of defect ``i`` of interval ``k`` (between nodes ``k`` and ``k + 1``).
    input_index : ndarray of int, shape (N, m), optional
        Free-vector index of free input ``j`` at node ``k`` (disturbances, measured inputs):
        node-local unknowns that the defects of the node's two intervals and the node's
        objective terms may depend on. None (or ``m = 0``) when every input is known.
    """

    node_index: np.ndarray
    parameter_index: np.ndarray
    interval_rows: np.ndarray
    input_index: np.ndarray | None = None

    def __post_init__(self) -> None:
        N, n = np.shape(self.node_index)
        if np.shape(self.interval_rows) != (N - 1, n):
            raise ValueError(
                f"interval_rows: expected shape ({N - 1}, {n}) for {N} nodes of {n} states, "
                f"found {np.shape(self.interval_rows)}"
            )
        if N < 2:
            raise ValueError(f"node_index: expected at least 2 nodes, found {N}")
        if self.input_index is not None and (
            np.ndim(self.input_index) != 2 or np.shape(self.input_index)[0] != N
        ):
            raise ValueError(
                f"input_index: expected shape ({N}, m) for {N} nodes, "
                f"found {np.shape(self.input_index)}"
            )

    @property
    def node_variables(self) -> np.ndarray:
        """``(N, n + m)``: each node's states, then its free inputs."""
        if self.input_index is None:
            return np.asarray(self.node_index)
        return np.concatenate([self.node_index, self.input_index], axis=1)


@dataclass(frozen=True)
class GaussNewtonOptions:
    """Settings of :func:`solve_gauss_newton`.

    Attributes
    ----------
    segment_nodes : int
        Nodes per condensing segment (about one stride keeps the propagated sensitivities
        bounded on a stable closed loop; fewer is more robust, more is cheaper).
    max_iter : int
    tol : float
        Converged when the Gauss-Newton model's predicted decrease is below
        ``tol * max(1, |f|)`` and the largest defect below ``constraint_tol``.
    constraint_tol : float
    damping : float
        Initial Levenberg-Marquardt factor on the reduced Hessian's diagonal.
    max_wall_time : float
        Seconds; checked after every segment, so a long iteration stops too.
    max_backtracks : int
        Halvings of the step before the line search gives up.
    """

    segment_nodes: int = 100
    max_iter: int = 100
    tol: float = 1e-10
    constraint_tol: float = 1e-8
    damping: float = 1e-6
    max_wall_time: float = float("inf")
    max_backtracks: int = 30

    def __post_init__(self) -> None:
        problems = []
        if not (isinstance(self.segment_nodes, int) and self.segment_nodes >= 2):
            problems.append(
                f"segment_nodes: expected an integer >= 2, found {self.segment_nodes!r}"
            )
        if not (isinstance(self.max_iter, int) and self.max_iter >= 0):
            problems.append(f"max_iter: expected an integer >= 0, found {self.max_iter!r}")
        for name in ("tol", "constraint_tol", "damping", "max_wall_time"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and value > 0):
                problems.append(f"{name}: expected a positive number, found {value!r}")
        if not (isinstance(self.max_backtracks, int) and self.max_backtracks >= 1):
            problems.append(
                f"max_backtracks: expected an integer >= 1, found {self.max_backtracks!r}"
            )
        if problems:
            raise ValueError("; ".join(problems))


class _WallTime(Exception):
    """The wall-time limit passed inside an iteration."""


@dataclass
class _Blocks:
    """The linearization at one iterate, in chain form (``v_k``: node ``k``'s states, then its
    free inputs; ``n`` states, ``nv`` node variables)."""

    D: np.ndarray  # (N-1, n, nv) d c_k / d v_k
    E: np.ndarray  # (N-1, n, nv) d c_k / d v_{k+1}
    T: np.ndarray  # (N-1, n, width) d c_k / d theta on the interval's own columns
    c: np.ndarray  # (N-1, n)
    A: np.ndarray  # (N-1, n, nv) -E_k^{-1} D_k, E_k the state part of d c_k / d v_{k+1}
    Bu: np.ndarray  # (N-1, n, nv - n) -E_k^{-1} d c_k / d u_{k+1}
    B: np.ndarray  # (N-1, n, width) -E_k^{-1} T_k
    a: np.ndarray  # (N-1, n) -E_k^{-1} c_k
    gradient: np.ndarray  # (num_variables,) objective gradient
    g: np.ndarray  # (N, nv) its node parts
    g_theta: np.ndarray  # (q,) its parameter part
    H: np.ndarray  # (N, nv, nv) objective Hessian by node (PSD part)
    factor: np.ndarray  # (N, nv, nv) H_k = factor_k factor_k^T
    rank: np.ndarray  # (N, nv) bool: the columns of factor_k that are not zero
    H_theta: np.ndarray  # (q, q)
    H_cross: np.ndarray  # (N, nv, node width) objective Hessian node variables x parameters

    @property
    def state_E(self) -> np.ndarray:
        """``(N-1, n, n)``: d c_k / d x_{k+1}."""
        return self.E[:, :, : self.c.shape[1]]


class _Chain:
    """Index maps from the NLP's sparse triplets to the chain blocks (computed once)."""

    def __init__(self, nlp: NLP, s: ChainStructure) -> None:
        N, n = s.node_index.shape
        nodes = s.node_variables
        nv = nodes.shape[1]
        q = s.parameter_index.size
        self.N, self.n, self.m, self.nv, self.q = N, n, nv - n, nv, q
        self.num_variables = nlp.n
        node_of = np.full(nlp.n, -1, np.int64)
        local = np.full(nlp.n, -1, np.int64)
        node_of[nodes.ravel()] = np.repeat(np.arange(N), nv)
        local[nodes.ravel()] = np.tile(np.arange(nv), N)
        theta_of = np.full(nlp.n, -1, np.int64)
        theta_of[s.parameter_index] = np.arange(q)
        covered = (node_of >= 0) | (theta_of >= 0)
        if not covered.all():
            raise ValueError(
                f"structure: {int((~covered).sum())} free variables are neither node states, "
                "node inputs nor parameters (interval variables are not supported)"
            )
        interval_of = np.full(nlp.m, -1, np.int64)
        row_local = np.full(nlp.m, -1, np.int64)
        interval_of[s.interval_rows.ravel()] = np.repeat(np.arange(N - 1), n)
        row_local[s.interval_rows.ravel()] = np.tile(np.arange(n), N - 1)
        if (interval_of < 0).any():
            raise ValueError(
                f"structure: {int((interval_of < 0).sum())} constraint rows are not interval "
                "defects (instance or node constraints are not supported)"
            )
        self.row_order = s.interval_rows.ravel()
        rows, cols = nlp.jacobianstructure()
        k, i = interval_of[rows], row_local[rows]
        node, j = node_of[cols], local[cols]
        self.d_mask = node == k
        self.e_mask = node == k + 1
        self.t_mask = theta_of[cols] >= 0
        stray = ~(self.d_mask | self.e_mask | self.t_mask)
        if stray.any():
            e = int(np.flatnonzero(stray)[0])
            raise ValueError(
                f"structure: defect row {int(rows[e])} of interval {int(k[e])} depends on "
                f"variable {int(cols[e])} of node {int(node[e])}: not a one-step chain"
            )
        self.d_flat = ((k * n + i) * nv + j)[self.d_mask]
        self.e_flat = ((k * n + i) * nv + j)[self.e_mask]
        # each interval's parameter columns, padded with the dummy column q
        tk, tc = k[self.t_mask], theta_of[cols][self.t_mask]
        pairs = np.unique(tk * (q + 1) + tc)
        pk, pc = np.divmod(pairs, q + 1)
        starts = np.searchsorted(pk, np.arange(N - 1))
        rank = np.arange(pairs.size) - starts[pk]
        width = int(rank.max(initial=-1)) + 1
        self.columns = np.full((N - 1, max(width, 1)), q, np.int64)
        self.columns[pk, rank] = pc
        slot = rank[np.searchsorted(pairs, tk * (q + 1) + tc)]
        self.width = max(width, 1)
        self.t_flat = (tk * n + i[self.t_mask]) * self.width + slot
        hr, hc = nlp.hessianstructure()
        self.h_node = (node_of[hr] >= 0) & (node_of[hr] == node_of[hc])
        self.h_flat = ((node_of[hr] * nv + local[hr]) * nv + local[hc])[self.h_node]
        self.h_flat_t = ((node_of[hr] * nv + local[hc]) * nv + local[hr])[self.h_node]
        self.h_theta = (theta_of[hr] >= 0) & (theta_of[hc] >= 0)
        self.ht_r, self.ht_c = theta_of[hr][self.h_theta], theta_of[hc][self.h_theta]
        # objective terms in a node's variables and parameters (a tracked controller output):
        # each node's parameter columns, padded with the dummy column q like the intervals'
        forward = (node_of[hr] >= 0) & (theta_of[hc] >= 0)
        backward = (theta_of[hr] >= 0) & (node_of[hc] >= 0)
        self.h_cross = forward | backward
        xn = np.where(forward, hr, hc)[self.h_cross]
        xt = theta_of[np.where(forward, hc, hr)[self.h_cross]]
        kn, il = node_of[xn], local[xn]
        pairs = np.unique(kn * (q + 1) + xt)
        pk, pc = np.divmod(pairs, q + 1)
        starts = np.searchsorted(pk, np.arange(N))
        rank = np.arange(pairs.size) - starts[pk]
        self.node_width = max(int(rank.max(initial=-1)) + 1, 1)
        self.node_columns = np.full((N, self.node_width), q, np.int64)
        self.node_columns[pk, rank] = pc
        slot = rank[np.searchsorted(pairs, kn * (q + 1) + xt)]
        self.hx_flat = (kn * nv + il) * self.node_width + slot
        self.coupled = np.zeros(N, bool)
        self.coupled[pk] = True
        self.h_other = ~(self.h_node | self.h_theta | self.h_cross)
        self.node_index, self.parameter_index = s.node_index, s.parameter_index
        self.nodes = nodes

    def state_defect_norm(self, b: _Blocks, c: np.ndarray) -> float:
        """``sum |E_k^{-1} c_k|`` with the ``E_k`` of linearization ``b``."""
        c_k = c[self.row_order].reshape(self.N - 1, self.n, 1)
        return float(np.abs(np.linalg.solve(b.state_E, c_k)).sum())

    def blocks(self, nlp: NLP, z: np.ndarray) -> _Blocks:
        N, n, nv, q = self.N, self.n, self.nv, self.q
        jac = nlp.jacobian(z)
        size = (N - 1) * n * nv
        D = np.bincount(self.d_flat, jac[self.d_mask], size).reshape(N - 1, n, nv)
        E = np.bincount(self.e_flat, jac[self.e_mask], size).reshape(N - 1, n, nv)
        w = self.width
        T = np.bincount(self.t_flat, jac[self.t_mask], (N - 1) * n * w).reshape(N - 1, n, w)
        c = nlp.constraints(z)[self.row_order].reshape(N - 1, n)
        propagated = -np.linalg.solve(
            E[:, :, :n], np.concatenate([D, E[:, :, n:], T, c[:, :, None]], axis=2)
        )
        grad = nlp.gradient(z)
        hess = nlp.gauss_newton_hessian(z)
        if np.any(hess[self.h_other] != 0.0):
            raise ValueError(
                "objective: its Hessian couples different nodes; the Gauss-Newton solver "
                "supports objectives that are sums of terms in one node's variables and the "
                "parameters"
            )
        v = hess[self.h_node]
        H = np.zeros(N * nv * nv)
        np.add.at(H, self.h_flat, v)
        off = self.h_flat != self.h_flat_t
        np.add.at(H, self.h_flat_t[off], v[off])
        H, factor, rank = _positive_part(H.reshape(N, nv, nv))
        vt = hess[self.h_theta]
        H_theta = np.zeros((q, q))
        np.add.at(H_theta, (self.ht_r, self.ht_c), vt)
        off_t = self.ht_r != self.ht_c
        np.add.at(H_theta, (self.ht_c[off_t], self.ht_r[off_t]), vt[off_t])
        wn = self.node_width
        H_cross = np.bincount(self.hx_flat, hess[self.h_cross], N * nv * wn).reshape(N, nv, wn)
        m = self.m
        return _Blocks(
            D=D,
            E=E,
            T=T,
            c=c,
            A=propagated[:, :, :nv],
            Bu=propagated[:, :, nv : nv + m],
            B=propagated[:, :, nv + m : nv + m + w],
            a=propagated[:, :, -1],
            gradient=grad,
            g=grad[self.nodes],
            g_theta=grad[self.parameter_index],
            H=H,
            factor=factor,
            rank=rank,
            H_theta=H_theta,
            H_cross=H_cross,
        )

    def curvature(self, b: _Blocks, dz: np.ndarray) -> float:
        """``dz^T H dz`` of the model: node blocks, node-parameter blocks, parameter block."""
        dv, dtheta = dz[self.nodes], dz[self.parameter_index]
        padded = np.r_[dtheta, 0.0][self.node_columns]
        return (
            float(np.einsum("ki,kij,kj->", dv, b.H, dv))
            + 2.0 * float(np.einsum("ki,kij,kj->", dv, b.H_cross, padded))
            + float(dtheta @ b.H_theta @ dtheta)
        )


def _positive_part(H: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each symmetric block with its negative eigenvalues set to zero (Gauss-Newton), its
    factor ``F_k`` with ``H_k = F_k F_k^T`` and which of the factor's columns are nonzero."""
    w, V = np.linalg.eigh(H)
    if (w < 0).any():
        w = np.maximum(w, 0.0)
        H = np.einsum("kij,kj,klj->kil", V, w, V)
    rank = w > 1e-14 * max(float(w.max(initial=0.0)), 1e-300)
    return H, V * np.sqrt(w)[:, None, :], rank


def _segments(N: int, length: int) -> list[tuple[int, int]]:
    """First and last node of each segment; the last one absorbs a short remainder."""
    starts = list(range(0, N - 1, length))
    if len(starts) > 1 and N - 1 - starts[-1] < length // 2:
        starts.pop()
    ends = [s - 1 for s in starts[1:]] + [N - 1]
    return list(zip(starts, ends, strict=True))


class _Links:
    """The linearized defects joining segment ``s`` to ``s + 1`` after the segments' inputs
    are eliminated: ``C_s dy_s + E_s dy_{s+1} + G_s dtheta + N_s nu_s + O_{s-1}^T nu_{s-1} +
    O_s nu_{s+1} = r_s`` (``N``, ``O``: the eliminated inputs' share, zero without inputs)."""

    def __init__(self, count: int, n: int, m: int, q: int) -> None:
        self.C = np.zeros((count, n, n))
        self.E = np.zeros((count, n, n))
        self.G = np.zeros((count, n, q + 1))
        self.r = np.zeros((count, n))
        self.EU = np.zeros((count, n, m))  # d c / d u of the next segment's first node
        self.N = np.zeros((count, n, n))
        self.O = np.zeros((count, n, n))


def _solve_bordered(
    H_loc: np.ndarray,
    H_cross: np.ndarray,
    H_theta: np.ndarray,
    g_loc: np.ndarray,
    g_theta: np.ndarray,
    links: _Links,
    inputs: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The reduced KKT system, banded in the segments and bordered by the parameters.

    Unknowns ``[dy_0, nu_0, dy_1, nu_1, ..., dy_{S-1}]`` (segment first states and link
    multipliers) form a banded matrix ``M`` (bandwidth ``2n - 1``, ``3n - 1`` when eliminated
    inputs couple neighbouring links); the parameters are eliminated by their Schur
    complement ``H_theta - F^T M^{-1} F``, so the cost is ``O(S n^2 q + q^3)`` instead of a
    dense solve of ``(2S - 1) n + q`` unknowns. Returns ``dy``, ``dtheta`` and ``nu``.
    """
    S, n, _ = H_loc.shape
    q = H_theta.shape[0]
    size = (2 * S - 1) * n
    bw = (3 if inputs else 2) * n - 1
    ab = np.zeros((2 * bw + 1, size))
    F = np.zeros((size, q))
    rhs = np.zeros(size)
    i_loc, j_loc = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")

    def place(row: int, col: int, block: np.ndarray) -> None:
        rows, cols = row + i_loc, col + j_loc
        ab[bw + rows - cols, cols] = block

    for s in range(S):
        y = 2 * s * n
        place(y, y, H_loc[s])
        F[y : y + n] = H_cross[s]
        rhs[y : y + n] = -g_loc[s]
        if s < S - 1:
            nu = y + n
            place(nu, y, links.C[s])
            place(y, nu, links.C[s].T)
            place(nu, nu + n, links.E[s])
            place(nu + n, nu, links.E[s].T)
            F[nu : nu + n] = links.G[s][:, :q]
            rhs[nu : nu + n] = links.r[s]
            if inputs:
                place(nu, nu, links.N[s])
                if s < S - 2:
                    place(nu, nu + 2 * n, links.O[s])
                    place(nu + 2 * n, nu, links.O[s].T)
    with warnings.catch_warnings():
        # poorly determined parameters make these systems ill-conditioned; the damping
        # keeps them solvable and the line search judges the step
        warnings.simplefilter("ignore", sla.LinAlgWarning)
        solved = sla.solve_banded((bw, bw), ab, np.column_stack([F, rhs]), check_finite=False)
        schur = H_theta - F.T @ solved[:, :q]
        schur = 0.5 * (schur + schur.T)
        dtheta = sla.solve(schur, -g_theta - F.T @ solved[:, q], assume_a="sym")
    local = solved[:, q] - solved[:, :q] @ dtheta
    dy = np.stack([local[2 * s * n : (2 * s + 1) * n] for s in range(S)])
    nu = np.array([local[(2 * s + 1) * n : (2 * s + 2) * n] for s in range(S - 1)])
    return dy, dtheta, nu.reshape(S - 1, n)


class _Reached:
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
class _InputSolve:
    """How a segment's inputs follow from the reduced unknowns:
    ``du = -Z [dy_s; dtheta[params]; 1; nu_{s-1}; nu_s]``."""

    Z: np.ndarray
    params: np.ndarray


@dataclass
class _Reduced:
    """The condensed system before damping."""

    H_loc: np.ndarray  # (S, n, n)
    H_cross: np.ndarray  # (S, n, q)
    H_theta: np.ndarray  # (q, q)
    g_loc: np.ndarray  # (S, n)
    g_theta: np.ndarray  # (q,)
    links: _Links
    inputs: list[_InputSolve]  # one per segment when the chain has free inputs


class _Step:
    """Condense, solve the reduced system, expand: one Gauss-Newton step."""

    def __init__(self, chain: _Chain, segments: list[tuple[int, int]]) -> None:
        self.chain, self.segments = chain, segments

    def condense(self, b: _Blocks, deadline: float, damping: float) -> _Reduced:
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
        links = _Links(S - 1, n, m, q)
        inputs: list[_InputSolve] = []
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
            columns = _Reached(q)
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
                raise _WallTime
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
        return _Reduced(H_loc, H_cross[:, :, :q], H_theta, g_loc, g_theta[:q], links, inputs)

    def _eliminate_inputs(
        self,
        s: int,
        Q: np.ndarray,
        gq: np.ndarray,
        base: int,
        params: np.ndarray,
        link_row: np.ndarray | None,
        links: _Links,
        inputs: list[_InputSolve],
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
        inputs.append(_InputSolve(Z, params))
        return 0.5 * (reduced + reduced.T), gradient

    def solve(self, b: _Blocks, r: _Reduced, damping: float) -> np.ndarray:
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
        dy, dtheta, nu = _solve_bordered(
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

    def expand(self, b: _Blocks, dy: np.ndarray, dtheta: np.ndarray, du: np.ndarray) -> np.ndarray:
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


def _adjoint(b: _Blocks, gradient: np.ndarray) -> np.ndarray:
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


def _multipliers(chain: _Chain, b: _Blocks, m: int) -> np.ndarray:
    """Defect multipliers (``L = f + lambda^T c``) at the final iterate."""
    lam = _adjoint(b, b.g)
    out = np.zeros(m)
    out[chain.row_order] = lam.ravel()
    return out


def solve_gauss_newton(
    nlp: NLP,
    x0: np.ndarray,
    structure: ChainStructure,
    options: GaussNewtonOptions | None = None,
    progress: Callable[[dict[str, float]], Any] | None = None,
) -> SolveResult:
    """Solve ``min f(z) s.t. c(z) = 0`` on a one-step chain by constrained Gauss-Newton.

    Parameters
    ----------
    nlp : NLP
        Objective, gradient, defects, their sparse Jacobian and the objective's
        Gauss-Newton Hessian (``gauss_newton_hessian``).
    x0 : ndarray
        Start.
    structure : ChainStructure
        Where the states, parameters and defects sit.
    options : GaussNewtonOptions, optional
    progress : callable, optional
        Called after every iteration with ``iteration``, ``objective``, ``infeasibility``,
        ``dual_infeasibility`` (the Gauss-Newton model's predicted decrease of ``f``, which
        vanishes at a stationary point), ``step``, ``alpha``, ``ratio`` and ``damping``;
        returning ``False`` stops the solve.

    Returns
    -------
    SolveResult
        The last accepted iterate (also after a stop, a wall-time limit or Ctrl-C), its
        status, the defect multipliers from the adjoint recursion, the iteration history
        and a text log of it.

    Raises
    ------
    ValueError
        When the NLP is not a one-step chain (a defect depends on a non-adjacent node,
        a variable is neither a state nor a parameter, a constraint is not a defect) or the
        objective couples nodes.
    """
    opts = options or GaussNewtonOptions()
    t_start = time.perf_counter()
    deadline = t_start + opts.max_wall_time
    chain = _Chain(nlp, structure)
    stepper = _Step(chain, _segments(chain.N, opts.segment_nodes))
    z = np.asarray(x0, dtype=float).copy()
    if z.shape != (nlp.n,):
        raise ValueError(f"x0: expected shape ({nlp.n},), found {z.shape}")
    history: list[dict[str, float]] = []
    lines = [
        f"Gauss-Newton with condensing: N={chain.N}, states={chain.n}, parameters={chain.q}, "
        f"segments={len(stepper.segments)}",
        f"{'iter':>4} {'objective':>14} {'inf_pr':>9} {'decrease':>10} {'|dz|':>9} "
        f"{'alpha':>8} {'ratio':>8} {'damping':>8} {'merit_mu':>8}",
    ]
    timing = {"evaluations": 0.0, "condensing": 0.0, "line_search": 0.0}
    mu, damping = 0.0, opts.damping
    status, iterations = MAX_ITER, 0
    blocks: _Blocks | None = None
    f = nlp.objective(z)
    c = nlp.constraints(z)
    try:
        for it in range(opts.max_iter + 1):
            if not (np.isfinite(f) and np.all(np.isfinite(c))):
                status = INVALID_NUMBER
                break
            t0 = time.perf_counter()
            blocks = chain.blocks(nlp, z)
            t1 = time.perf_counter()
            timing["evaluations"] += t1 - t0
            if it == opts.max_iter:
                break
            # The node-parameter and parameter blocks are the objective's exact Hessian, which
            # a tracked controller output makes indefinite far from the data; more damping
            # until the step has positive curvature (a Levenberg-Marquardt safeguard).
            reduced = stepper.condense(blocks, deadline, damping)
            for _ in range(MAX_DAMPING_RAISES):
                dz = stepper.solve(blocks, reduced, damping)
                curvature = chain.curvature(blocks, dz)
                if curvature > 0 or not np.any(dz):
                    break
                damping = min(max(10.0 * damping, 1e-4), 1e6)
            t2 = time.perf_counter()
            timing["condensing"] += t2 - t1
            slope = float(blocks.gradient @ dz)
            # defects in state units, E_k^{-1} c_k with E_k frozen at this iterate: how far
            # each next state is from where the dynamics put it (a stiff contact's large
            # force defects are small state corrections)
            c_norm = float(np.abs(blocks.a).sum())
            if c_norm > 0:
                mu = max(mu, (slope + 0.5 * curvature) / (0.9 * c_norm) + 1e-12)
            merit = f + mu * c_norm
            derivative = slope - mu * c_norm
            predicted = -(slope + 0.5 * curvature)
            infeasibility = float(np.abs(c).max(initial=0.0))
            if infeasibility <= opts.constraint_tol and predicted <= opts.tol * max(1.0, abs(f)):
                status = SUCCEEDED
                break
            alpha, accepted = 1.0, False
            for _ in range(opts.max_backtracks):
                trial = z + alpha * dz
                f_t = nlp.objective(trial)
                c_t = nlp.constraints(trial)
                merit_t = f_t + mu * chain.state_defect_norm(blocks, c_t)
                if np.isfinite(merit_t) and merit_t <= merit + 1e-4 * alpha * derivative:
                    accepted = True
                    break
                alpha *= 0.5
            timing["line_search"] += time.perf_counter() - t2
            if not accepted:
                status = STALLED
                break
            # trust in the model: the merit's actual against its predicted decrease
            ratio = (merit - merit_t) / max(alpha * (predicted + mu * c_norm), 1e-300)
            z, f, c = trial, f_t, c_t
            iterations = it + 1
            if ratio > 0.5 and alpha == 1.0:
                damping = max(damping / 3.0, 1e-12)
            elif ratio < 0.25:
                damping = min(damping * 4.0, 1e6)
            row = {
                "iteration": float(iterations),
                "objective": float(f),
                "infeasibility": float(np.abs(c).max(initial=0.0)),
                "dual_infeasibility": predicted,
                "step": float(np.abs(dz).max(initial=0.0)),
                "alpha": alpha,
                "ratio": ratio,
                "damping": damping,
            }
            history.append(row)
            lines.append(
                f"{iterations:4d} {f:14.7e} {row['infeasibility']:9.2e} {predicted:10.2e} "
                f"{row['step']:9.2e} {alpha:8.2e} {ratio:8.2f} {damping:8.1e} {mu:8.1e}"
            )
            if progress is not None and progress(row) is False:
                status = USER_STOP
                break
            if time.perf_counter() > deadline:
                status = WALL_TIME
                break
    except _WallTime:
        status = WALL_TIME
    except KeyboardInterrupt:
        status = USER_STOP
        lines.append("interrupted (Ctrl-C): returning the last accepted iterate")
    elapsed = time.perf_counter() - t_start
    multipliers = np.full(nlp.m, np.nan)
    if blocks is not None:
        multipliers = _multipliers(chain, blocks, nlp.m)
    lines.append(
        "seconds: "
        + ", ".join(f"{k} {v:.3f}" for k, v in timing.items())
        + f", total {elapsed:.3f}"
    )
    result_status = status_from_code(status)
    lines.append(f"status: {result_status}")
    return SolveResult(
        x=z,
        status=result_status,
        objective=float(f),
        constraint_violation=float(np.abs(c).max(initial=0.0)),
        iterations=iterations,
        solve_time=elapsed,
        multipliers=multipliers,
        log="\n".join(lines),
        history=history,
        options={
            "solver": "gauss-newton",
            **{k: getattr(opts, k) for k in opts.__dataclass_fields__},
            "timing": timing,
        },
    )
