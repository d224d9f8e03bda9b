"""Forward simulation of implicit models and the excitation signals that drive them."""

from colloc.simulate.implicit_ode import ImplicitODE
from colloc.simulate.integrate import SimulationError, simulate
from colloc.simulate.signals import (
    SampledNoise,
    SumOfSines,
    add_sensor_noise,
    random_phases,
    seed_frequencies,
    sum_of_sines,
)

__all__ = [
    "ImplicitODE",
    "SampledNoise",
    "SimulationError",
    "SumOfSines",
    "add_sensor_noise",
    "random_phases",
    "seed_frequencies",
    "simulate",
    "sum_of_sines",
]
