"""Identification workflows: data -> Problem -> Solution -> metrics.

Names load on first use (``colloc._lazy``).
"""

# ruff: noqa: F401  (the TYPE_CHECKING imports are re-exported by __all__, built from _EXPORTS)
from typing import TYPE_CHECKING

from colloc._lazy import lazy_exports

_EXPORTS = {
    "ScheduleFit": "colloc.identify.direct",
    "direct_estimate": "colloc.identify.direct",
    "fit_gain_schedule": "colloc.identify.direct",
    "smooth_with_derivatives": "colloc.identify.direct",
    "GaitSmoother": "colloc.identify.gait.smoother",
    "SmoothedGait": "colloc.identify.gait.smoother_results",
    "SmootherError": "colloc.identify.gait.smoother_results",
    "SmootherSettings": "colloc.identify.gait.smoother_settings",
    "SmootherStage": "colloc.identify.gait.smoother_results",
    "consistent_completion": "colloc.identify.gait.smoother_start",
    "lowpass": "colloc.identify.gait.smoother_start",
    "GAIN_GUESSES": "colloc.identify.guesses",
    "SCHEMES": "colloc.identify.pendulum.workflow",
    "PendulumRun": "colloc.identify.pendulum.workflow",
    "PendulumSettings": "colloc.identify.pendulum.settings",
    "SCHEME_NAMES": "colloc.identify.pendulum.settings",
    "run_pendulum": "colloc.identify.pendulum.workflow",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())

if TYPE_CHECKING:  # for type checkers; re-exported through __all__
    from colloc.identify.direct import (
        ScheduleFit,
        direct_estimate,
        fit_gain_schedule,
        smooth_with_derivatives,
    )
    from colloc.identify.gait.smoother import GaitSmoother
    from colloc.identify.gait.smoother_results import SmoothedGait, SmootherError, SmootherStage
    from colloc.identify.gait.smoother_settings import SmootherSettings
    from colloc.identify.gait.smoother_start import consistent_completion, lowpass
    from colloc.identify.guesses import GAIN_GUESSES
    from colloc.identify.pendulum.settings import SCHEME_NAMES, PendulumSettings
    from colloc.identify.pendulum.workflow import SCHEMES, PendulumRun, run_pendulum

__all__ = list(_EXPORTS)
