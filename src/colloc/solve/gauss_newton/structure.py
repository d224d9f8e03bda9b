"""The chain a one-step collocation NLP forms, and its linearization at an iterate.

:class:`ChainStructure` says where states, free inputs, parameters and defects sit;
:class:`Chain` maps the NLP's sparse triplets to per-node and per-interval blocks once, and
:meth:`Chain.blocks` evaluates them at an iterate (each node's objective block taken positive
semidefinite: Gauss-Newton).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from colloc.solve.result import NLP


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


@dataclass
class Blocks:
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


class Chain:
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

    def state_defect_norm(self, b: Blocks, c: np.ndarray) -> float:
        """``sum |E_k^{-1} c_k|`` with the ``E_k`` of linearization ``b``."""
        c_k = c[self.row_order].reshape(self.N - 1, self.n, 1)
        return float(np.abs(np.linalg.solve(b.state_E, c_k)).sum())

    def blocks(self, nlp: NLP, z: np.ndarray) -> Blocks:
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
        H, factor, rank = positive_part(H.reshape(N, nv, nv))
        vt = hess[self.h_theta]
        H_theta = np.zeros((q, q))
        np.add.at(H_theta, (self.ht_r, self.ht_c), vt)
        off_t = self.ht_r != self.ht_c
        np.add.at(H_theta, (self.ht_c[off_t], self.ht_r[off_t]), vt[off_t])
        wn = self.node_width
        H_cross = np.bincount(self.hx_flat, hess[self.h_cross], N * nv * wn).reshape(N, nv, wn)
        m = self.m
        return Blocks(
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

    def curvature(self, b: Blocks, dz: np.ndarray) -> float:
        """``dz^T H dz`` of the model: node blocks, node-parameter blocks, parameter block."""
        dv, dtheta = dz[self.nodes], dz[self.parameter_index]
        padded = np.r_[dtheta, 0.0][self.node_columns]
        return (
            float(np.einsum("ki,kij,kj->", dv, b.H, dv))
            + 2.0 * float(np.einsum("ki,kij,kj->", dv, b.H_cross, padded))
            + float(dtheta @ b.H_theta @ dtheta)
        )


def positive_part(H: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each symmetric block with its negative eigenvalues set to zero (Gauss-Newton), its
    factor ``F_k`` with ``H_k = F_k F_k^T`` and which of the factor's columns are nonzero."""
    w, V = np.linalg.eigh(H)
    if (w < 0).any():
        w = np.maximum(w, 0.0)
        H = np.einsum("kij,kj,klj->kil", V, w, V)
    rank = w > 1e-14 * max(float(w.max(initial=0.0)), 1e-300)
    return H, V * np.sqrt(w)[:, None, :], rank
