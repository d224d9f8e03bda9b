"""How a known input trajectory, given at the nodes, is evaluated between them.

Schemes that evaluate the model inside an interval (midpoint, Hermite-Simpson) need the known
inputs at the interval midpoints. Colloc's default is a cubic through the four surrounding
nodes, fourth order on smooth data, so that the interpolation does not limit
Hermite-Simpson's order. Other tools average the two nodes (second order); choose
:class:`LinearInterpolation` to pose their problem exactly, or for inputs that are not smooth
between samples (a steps-and-holds excitation), where a cubic overshoots.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np

from colloc.transcription.base import TimeGrid


class Interpolation(ABC):
    """A rule for a known trajectory's values at the interval midpoints."""

    #: The name by which the rule can be chosen (``KnownTrajectory(values, "linear")``).
    name: ClassVar[str]

    @abstractmethod
    def midpoint_values(self, grid: TimeGrid, values: np.ndarray) -> np.ndarray:
        """Values at the interval midpoints.

        Parameters
        ----------
        grid : TimeGrid
        values : ndarray, shape (N,) or (N, m)
            Values at the nodes.

        Returns
        -------
        ndarray, shape (N - 1,) or (N - 1, m)
        """

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"

    def __eq__(self, other: object) -> bool:
        return type(self) is type(other)

    def __hash__(self) -> int:
        return hash(type(self))


class CubicInterpolation(Interpolation):
    """The cubic through the four nodes around each interval (one-sided at the ends).

    Fourth order on smooth data; colloc's default.
    """

    name = "cubic"

    def midpoint_values(self, grid: TimeGrid, values: np.ndarray) -> np.ndarray:
        """See :meth:`Interpolation.midpoint_values`."""
        return grid.midpoint_values(values)


class LinearInterpolation(Interpolation):
    """The mean of the interval's two nodes, ``(r_k + r_{k+1}) / 2``. Second order."""

    name = "linear"

    def midpoint_values(self, grid: TimeGrid, values: np.ndarray) -> np.ndarray:
        """See :meth:`Interpolation.midpoint_values`."""
        v = np.asarray(values, dtype=float)
        return 0.5 * (v[:-1] + v[1:])


#: The interpolations by name.
INTERPOLATIONS: dict[str, type[Interpolation]] = {
    cls.name: cls for cls in (CubicInterpolation, LinearInterpolation)
}
