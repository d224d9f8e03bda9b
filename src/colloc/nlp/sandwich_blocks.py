"""The sandwich's blocks: the runs of consecutive nodes whose residual gradients are summed
before their outer products (:func:`colloc.nlp.uncertainty.parameter_uncertainty`'s ``blocks``)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from colloc.model.symbols import name_of
from colloc.nlp.trials import Trials

if TYPE_CHECKING:
    pass


def trial_block_starts(
    blocks: int | Sequence[int] | Sequence[Sequence[int]] | None, design: Trials
) -> list[np.ndarray]:
    """The first node of every sandwich block, per trial.

    Parameters
    ----------
    blocks : int, sequence of int, sequence of sequences of int, or None
        One number of blocks for every trial, one trial's first nodes (a single trial), one
        sequence of first nodes per trial, or None (about ``sqrt(N)`` blocks per trial).
    design : Trials

    Returns
    -------
    list of ndarray
        Per trial, the increasing first nodes of its blocks.

    Raises
    ------
    ValueError
        Naming the form expected when ``blocks`` does not fit the trials.
    """
    sizes = [p.layout.num_nodes for p in design.problems]
    if len(sizes) == 1:
        return [block_starts(blocks, sizes[0])]  # type: ignore[arg-type]
    if blocks is None or isinstance(blocks, int | np.integer):
        return [block_starts(blocks, N) for N in sizes]  # type: ignore[arg-type]
    flat = isinstance(blocks, Sequence) and any(isinstance(b, int | np.integer) for b in blocks)
    if (
        flat
        or isinstance(blocks, str)
        or not isinstance(blocks, Sequence)
        or len(blocks) != len(sizes)
    ):
        hint = (
            f" (a flat list of numbers is one trial's first nodes; for {len(sizes)} trials give "
            f"one number for all, e.g. blocks=4, or a list of {len(sizes)} lists, e.g. "
            f"blocks=[[0, 50], [0, 40], ...])"
            if flat
            else ""
        )
        raise ValueError(
            f"blocks: with {len(sizes)} trials, expected one number of blocks for every trial "
            f"or one sequence of first nodes per trial, found {blocks!r}{hint}"
        )
    out = []
    for k, (own, N) in enumerate(zip(blocks, sizes, strict=True)):
        if not isinstance(own, Sequence | np.ndarray) or isinstance(own, str):
            raise ValueError(
                f"blocks[{k}]: expected the first nodes of trial {k}'s blocks, found {own!r}"
            )
        out.append(block_starts(list(own), N, least=1, name=f"blocks[{k}]"))
    return out


def check_blocks_per_parameter(design: Trials, starts: list[np.ndarray]) -> None:
    """Refuse blocks that leave a parameter informed by a single block: its residuals'
    gradient sums to zero over that block at the optimum, so the sandwich would call it
    exact.

    Parameters
    ----------
    design : Trials
    starts : list of ndarray
        Per trial, the first nodes of its blocks (:func:`trial_block_starts`).

    Raises
    ------
    ValueError
        Naming each parameter informed by one block only.
    """
    lonely = []
    for s in design.unknown_parameters:
        holders = [k for k, p in enumerate(design.problems) if s in p.partition.unknown_parameters]
        if sum(starts[k].size for k in holders) < 2:
            lonely.append(f"{name_of(s)} ({design.names[holders[0]]}'s own)")
    if lonely:
        raise ValueError(
            f"blocks: {', '.join(lonely)} would be informed by one block only, whose gradient "
            "vanishes at the optimum (a standard error of 0): give its trial at least 2 blocks"
        )


def block_starts(
    blocks: int | Sequence[int] | None, N: int, least: int = 2, name: str = "blocks"
) -> np.ndarray:
    """The first node of each block of one trial of ``N`` nodes.

    Parameters
    ----------
    blocks : int, sequence of int or None
        A number of equal blocks, the first nodes themselves, or None for about
        ``sqrt(N)`` blocks.
    N : int
        Nodes of the trial.
    least : int
        Fewest blocks accepted.
    name : str
        The argument's name in messages.

    Returns
    -------
    ndarray of int
        Increasing, starting at 0.

    Raises
    ------
    ValueError
        Naming ``name`` when the blocks are not usable.
    """
    if blocks is None:
        count = max(2, int(round(np.sqrt(N))))
        return np.unique(np.linspace(0, N, count, endpoint=False).astype(np.int64))
    if isinstance(blocks, int | np.integer) and not isinstance(blocks, bool):
        if not 2 <= blocks <= N:
            raise ValueError(f"blocks: expected between 2 and {N} blocks, found {blocks}")
        return np.unique(np.linspace(0, N, int(blocks), endpoint=False).astype(np.int64))
    try:
        starts = np.asarray(blocks, dtype=np.int64)
    except (TypeError, ValueError) as exc:
        raise ValueError(
            f"{name}: expected a number of blocks or the first node of each, found {blocks!r}"
        ) from exc
    if starts.ndim != 1 or starts.size < least or (starts[0] != 0) or np.any(np.diff(starts) <= 0):
        raise ValueError(
            f"{name}: expected at least {least} increasing first nodes starting at 0, "
            f"found {blocks!r}"
        )
    if starts[-1] >= N:
        raise ValueError(f"{name}: first node {int(starts[-1])} is beyond the {N} nodes")
    return starts


def block_gradients(design: Trials, z: np.ndarray, starts: list[np.ndarray]) -> sp.csc_matrix:
    """The objective gradient of each block's nodes.

    Parameters
    ----------
    design : Trials
    z : ndarray, shape (n,)
    starts : list of ndarray
        Per trial, the first nodes of its blocks.

    Returns
    -------
    scipy.sparse.csc_matrix, shape (n, nb)
        Column ``b``: the gradient of block ``b``, the blocks of each trial one trial after
        another.

    Raises
    ------
    ValueError
        When no trial has a least-squares objective.
    """
    values, rows, columns = [], [], []
    first = 0
    for problem, zk, index, own in zip(
        design.problems, design.split(z), design.index, starts, strict=True
    ):
        p = problem.nlp.objective_placement
        if p is not None:
            vals = p.mapped.jacobian(p.gather(zk), p.data).reshape(p.count, -1)
            items = np.repeat(np.arange(p.count), vals.shape[1])
            values.append(vals.ravel())
            rows.append(index[p.jac_cols])
            columns.append(first + np.searchsorted(own, items, side="right") - 1)
        first += own.size
    if not values:
        raise ValueError("problem: has no least-squares objective to take residuals from")
    return sp.coo_matrix(
        (np.concatenate(values), (np.concatenate(rows), np.concatenate(columns))),
        shape=(design.nlp.n, first),
    ).tocsc()
