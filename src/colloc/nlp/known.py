"""A known input trajectory with its rule for values between the nodes."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from colloc.transcription.interpolation import (
    INTERPOLATIONS,
    CubicInterpolation,
    Interpolation,
)


@dataclass(frozen=True)
class KnownTrajectory:
    """Values of a known input at the nodes and how the scheme evaluates it between them.

    A plain array in ``known_trajectories`` is the same as ``KnownTrajectory(values)``.

    Parameters
    ----------
    values : array_like, shape (N,)
        One value per node.
    between : Interpolation or {"cubic", "linear"}
        How the input is evaluated at the interval midpoints by schemes that evaluate the
        model there (midpoint, Hermite-Simpson): ``"cubic"`` (default) through the four
        surrounding nodes, fourth order; ``"linear"`` the mean of the two nodes, second
        order, which is what tools that average the nodes pose (see
        :mod:`colloc.transcription.interpolation`).

    Raises
    ------
    ValueError
        When ``between`` names no interpolation.
    """

    values: Any
    between: Interpolation = field(default_factory=CubicInterpolation)

    def __post_init__(self) -> None:
        rule = self.between
        if isinstance(rule, str):
            if rule not in INTERPOLATIONS:
                raise ValueError(
                    f"between: expected an Interpolation or one of {sorted(INTERPOLATIONS)}, "
                    f"found {rule!r}"
                )
            object.__setattr__(self, "between", INTERPOLATIONS[rule]())
        elif not isinstance(rule, Interpolation):
            raise ValueError(
                f"between: expected an Interpolation or one of {sorted(INTERPOLATIONS)}, "
                f"found {type(rule).__name__}"
            )

    def as_array(self) -> np.ndarray:
        """The node values as a float array (not checked)."""
        return np.asarray(self.values, dtype=float)
