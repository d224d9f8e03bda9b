"""Collocation schemes: each turns the model residual into the defects of one interval."""

from colloc.transcription.backward_euler import BackwardEuler
from colloc.transcription.base import IntervalView, NodeView, Scheme, TimeGrid
from colloc.transcription.hermite_simpson import HermiteSimpson
from colloc.transcription.interpolation import (
    CubicInterpolation,
    Interpolation,
    LinearInterpolation,
)
from colloc.transcription.midpoint import Midpoint
from colloc.transcription.radau import RadauIIA
from colloc.transcription.trapezoidal import Trapezoidal

__all__ = [
    "BackwardEuler",
    "CubicInterpolation",
    "HermiteSimpson",
    "Interpolation",
    "IntervalView",
    "LinearInterpolation",
    "Midpoint",
    "NodeView",
    "RadauIIA",
    "Scheme",
    "TimeGrid",
    "Trapezoidal",
]
