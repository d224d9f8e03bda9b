"""The reduced system of a condensed chain: banded in the segments, bordered by the
parameters, solved with the parameters eliminated by their Schur complement."""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg as sla


class Links:
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


def solve_bordered(
    H_loc: np.ndarray,
    H_cross: np.ndarray,
    H_theta: np.ndarray,
    g_loc: np.ndarray,
    g_theta: np.ndarray,
    links: Links,
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
