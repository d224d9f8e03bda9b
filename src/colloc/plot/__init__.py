"""Figures and animations; every function returns data or a Figure and never shows it."""

from colloc.plot.animation import animate_pendulum_cart, frame_coordinates, plot_pendulum_cart
from colloc.plot.common import PlotInputError, save_figure
from colloc.plot.geometry import link_positions
from colloc.plot.pendulum import (
    plot_constraint_violations,
    plot_force,
    plot_gains,
    plot_states,
    plot_trajectory_comparison,
)

__all__ = [
    "PlotInputError",
    "animate_pendulum_cart",
    "frame_coordinates",
    "link_positions",
    "plot_constraint_violations",
    "plot_force",
    "plot_gains",
    "plot_pendulum_cart",
    "plot_states",
    "plot_trajectory_comparison",
    "save_figure",
]
