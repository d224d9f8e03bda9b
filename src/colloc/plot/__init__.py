"""Figures and animations; every function returns data or a Figure and never shows it.

Names load on first use (``colloc._lazy``): matplotlib is imported by the first figure.
"""

# ruff: noqa: F401  (the TYPE_CHECKING imports are re-exported by __all__, built from _EXPORTS)
from typing import TYPE_CHECKING

from colloc._lazy import lazy_exports

_EXPORTS = {
    "animate_pendulum_cart": "colloc.plot.animation",
    "frame_coordinates": "colloc.plot.animation",
    "plot_pendulum_cart": "colloc.plot.animation",
    "PlotInputError": "colloc.plot.common",
    "save_figure": "colloc.plot.common",
    "plot_angle_comparison": "colloc.plot.gait_identification",
    "plot_mean_strides": "colloc.plot.gait_identification",
    "plot_schedule": "colloc.plot.gait_identification",
    "plot_torque_vaf": "colloc.plot.gait_identification",
    "link_positions": "colloc.plot.geometry",
    "plot_constraint_violations": "colloc.plot.pendulum",
    "plot_force": "colloc.plot.pendulum",
    "plot_gains": "colloc.plot.pendulum",
    "plot_states": "colloc.plot.pendulum",
    "plot_trajectory_comparison": "colloc.plot.pendulum",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())

if TYPE_CHECKING:  # for type checkers; re-exported through __all__
    from colloc.plot.animation import animate_pendulum_cart, frame_coordinates, plot_pendulum_cart
    from colloc.plot.common import PlotInputError, save_figure
    from colloc.plot.gait_identification import (
        plot_angle_comparison,
        plot_mean_strides,
        plot_schedule,
        plot_torque_vaf,
    )
    from colloc.plot.geometry import link_positions
    from colloc.plot.pendulum import (
        plot_constraint_violations,
        plot_force,
        plot_gains,
        plot_states,
        plot_trajectory_comparison,
    )

__all__ = list(_EXPORTS)
