"""Parameters scheduled over a periodic phase, kept sparse for collocation.

A scheduled quantity ``c(phi)`` is given at ``P`` points of the cycle and interpolated
linearly (periodically) between them. Written out, every equation would depend on all ``P``
points; instead the residual uses two *slots* ``c_a``, ``c_b`` and a weight ``w``:
``c(phi) = (1 - w) c_a + w c_b``. For each interval or node of a collocation grid the
engine binds the slots to the two schedule points that bracket the phase there (known from
the data), so every equation touches two points only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sm


@dataclass(frozen=True)
class ParameterSchedule:
    """``P`` points of ``m`` parameters each, interpolated periodically in the phase.

    Attributes
    ----------
    phase : sympy.Function
        ``Phi(t)``: the unwrapped phase in cycles (0 at the first reference event, 1 at the
        next, ...), supplied as a known trajectory.
    weight : sympy.Function
        ``w(t)`` in the residual; computed by the engine from the phase, never supplied.
    slots_a, slots_b : tuple of sympy.Symbol
        The ``m`` slot symbols of the lower and upper bracketing point.
    points : tuple of tuple of sympy.Symbol
        ``P`` tuples of ``m`` symbols: the parameters of each schedule point.
    """

    phase: sm.Basic
    weight: sm.Basic
    slots_a: tuple[sm.Symbol, ...]
    slots_b: tuple[sm.Symbol, ...]
    points: tuple[tuple[sm.Symbol, ...], ...]

    @property
    def num_points(self) -> int:
        """``P``."""
        return len(self.points)

    @property
    def size(self) -> int:
        """``m``: parameters per point."""
        return len(self.slots_a)

    @property
    def parameters(self) -> tuple[sm.Symbol, ...]:
        """Every point's parameters, point-major."""
        return tuple(s for point in self.points for s in point)

    def bracket(self, phase: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Lower point, upper point and weight of the upper point at each phase value.

        Parameters
        ----------
        phase : ndarray
            Unwrapped phase in cycles.

        Returns
        -------
        a, b : ndarray of int
            Indices of the bracketing points (``b = a + 1`` modulo ``P``).
        w : ndarray
            ``c = (1 - w) c_a + w c_b``.
        """
        scaled = np.asarray(phase, dtype=float) * self.num_points
        base = np.floor(scaled)
        a = base.astype(np.int64) % self.num_points
        return a, (a + 1) % self.num_points, scaled - base
