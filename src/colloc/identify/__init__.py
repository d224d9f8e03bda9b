"""Identification workflows: data -> Problem -> Solution -> metrics."""

from colloc.identify.direct import direct_estimate, smooth_with_derivatives
from colloc.identify.guesses import GAIN_GUESSES
from colloc.identify.pendulum import SCHEMES, PendulumRun, PendulumSettings, run_pendulum

__all__ = [
    "GAIN_GUESSES",
    "SCHEMES",
    "PendulumRun",
    "PendulumSettings",
    "direct_estimate",
    "run_pendulum",
    "smooth_with_derivatives",
]
