"""Where the parts of the n-link pendulum on a cart are, given its coordinates.

Convention (the same as ``colloc.models.pendulum_cart`` and the source study): ``q0`` is the
cart position along the x axis; ``q1..qn`` are absolute link angles measured from the upward
vertical, positive counter-clockwise (about +z). Link i points along
``(-sin q_i, cos q_i)``, so the end of link i (mass i) is at::

    x_i = q0 - sum_{j <= i} l_j sin(q_j)
    y_i =      sum_{j <= i} l_j cos(q_j)

This is the placement that reproduces the study's one-link equations: with mass m1 at
``(q0 - l0 sin q1, l0 cos q1)`` the kinetic energy has the coupling term
``-l0 m1 cos(q1) u0 u1`` and the potential energy ``g m1 l0 cos(q1)``, which give the
``-l0 m1 cos(q1) u0'`` and ``-g l0 m1 sin(q1)`` terms of the torque equation and the
``+l0 m1 u1**2 sin(q1)`` term of the cart equation. The opposite sign of ``sin`` would flip
the sign of all three.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from colloc.plot.common import PlotInputError


def link_positions(coordinates: Any, lengths: Any) -> np.ndarray:
    """Positions of the cart pivot and of each link's end.

    Parameters
    ----------
    coordinates : array_like, shape (..., n + 1)
        ``[q0, q1, ..., qn]``: cart position, then absolute link angles from the upward
        vertical (radians). Leading dimensions (e.g. time samples) are kept.
    lengths : array_like, shape (n,)
        Link lengths ``[l_1, ..., l_n]`` (the study's ``l0, l1, ...``).

    Returns
    -------
    numpy.ndarray, shape (..., n + 1, 2)
        ``[..., 0, :]`` is the pivot on the cart ``(q0, 0)``; ``[..., i, :]`` is the end
        of link i (where mass i sits).

    Raises
    ------
    PlotInputError
        If ``lengths`` is not a 1-D array of n finite non-negative numbers or
        ``coordinates`` does not end in n + 1 values (all problems listed).

    Examples
    --------
    >>> link_positions([0.5, np.pi / 2], [2.0]).round(12).tolist()
    [[0.5, 0.0], [-1.5, 0.0]]
    """
    problems: list[str] = []
    q = np.asarray(coordinates, dtype=float)
    l = np.asarray(lengths, dtype=float)  # noqa: E741 - the study's letter for lengths
    if l.ndim != 1 or l.size == 0:
        problems.append(f"lengths: expected a 1-D array of n >= 1 lengths, found shape {l.shape}")
    elif not np.all(np.isfinite(l) & (l >= 0)):
        problems.append(f"lengths: expected finite non-negative values, found {l.tolist()}")
    if q.ndim == 0 or (l.ndim == 1 and q.shape[-1] != l.size + 1):
        problems.append(
            f"coordinates: expected a last dimension of n + 1 = {l.size + 1} values "
            f"(q0 and one angle per link), found shape {q.shape}"
        )
    if problems:
        raise PlotInputError(problems)
    angles = q[..., 1:]
    x = q[..., :1] - np.cumsum(l * np.sin(angles), axis=-1)
    y = np.cumsum(l * np.cos(angles), axis=-1)
    pivot = np.stack([q[..., 0], np.zeros_like(q[..., 0])], axis=-1)[..., np.newaxis, :]
    ends = np.stack([x, y], axis=-1)
    return np.concatenate([pivot, ends], axis=-2)
