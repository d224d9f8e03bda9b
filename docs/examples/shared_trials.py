"""Several trials, one estimate: a mass-spring-damper recorded four times.

Each trial has its own length, sample rate, driving force and initial state, and its own
sensor offset (the marker was taped anew each time); damping and stiffness are shared. Each
trial is a ``colloc.Problem``; ``colloc.Trials`` solves them as one estimate, and
``colloc.parameter_uncertainty`` gives errors from the residuals, whose autoregression is
fitted trial by trial. Run::

    python docs/examples/shared_trials.py

It prints the estimates with their standard errors against the truth.
"""

from __future__ import annotations

import numpy as np
import sympy as sm
from scipy.integrate import solve_ivp
from sympy.physics.mechanics import dynamicsymbols

import colloc

t = dynamicsymbols._t
x, v, F, y = dynamicsymbols("x v F y")
m, c, k = sm.symbols("m c k")
SHARED = {c: 0.6, k: 18.0}
SIGMA = 0.002  # position noise [m]
#: per trial: duration [s], sample rate [Hz], force amplitude and frequency, start, offset
TRIALS = [
    (8.0, 50.0, 3.0, 2.0, (0.10, 0.0), 0.012),
    (5.0, 100.0, 4.0, 1.3, (-0.05, 0.2), -0.004),
    (6.0, 40.0, 2.0, 3.1, (0.0, 0.0), 0.020),
    (10.0, 50.0, 5.0, 0.8, (0.05, -0.1), 0.000),
]


def plant(offset: sm.Symbol) -> colloc.Model:
    """m x'' + c x' + k x = F, the sensor reading ``x + offset``."""
    return colloc.Model.from_equations(
        [x.diff(t) - v, m * v.diff(t) + c * v + k * x - F],
        [x, v],
        outputs={y: x + offset},
        known_inputs=[F],
        parameters=[m, c, k, offset],
    )


def record(duration, rate, amplitude, frequency, start, offset, rng):
    """Times, force and a noisy sensor record of one trial of the true plant."""
    times = np.arange(0.0, duration + 0.5 / rate, 1.0 / rate)

    def force(s):
        return amplitude * np.sin(frequency * s) + 0.5 * amplitude * np.sin(3.7 * frequency * s)

    def rhs(s, y):
        return [y[1], force(s) - SHARED[c] * y[1] - SHARED[k] * y[0]]

    exact = solve_ivp(rhs, times[[0, -1]], start, t_eval=times, rtol=1e-11, atol=1e-13).y[0]
    return times, force(times), exact + offset + rng.normal(0.0, SIGMA, times.size)


def main(seed: int = 3) -> dict[str, tuple[float, float, float]]:
    """Fit the four trials together; name -> (truth, estimate, standard error)."""
    rng = np.random.default_rng(seed)
    problems, guesses, truth = [], [], dict(SHARED)
    for i, (*design, offset) in enumerate(TRIALS):
        b = sm.Symbol(f"b{i}")
        truth[b] = offset
        times, force, sensor = record(*design, offset, rng)
        problem = colloc.Problem(
            plant(b),
            times,
            scheme=colloc.transcription.HermiteSimpson(),
            known_trajectories={F: force},
            known_parameters={m: 1.0},
            objective=colloc.Tracking({y: sensor}, 1.0 / SIGMA**2),
        )
        problems.append(problem)
        guesses.append(problem.initial_guess({x: sensor, v: np.gradient(sensor, times)}, {b: 0.0}))
    trials = colloc.Trials(problems, names=[f"trial {i + 1}" for i in range(len(problems))])
    solution = trials.solve(trials.initial_guess(guesses, {c: 1.0, k: 10.0}))
    errors = colloc.parameter_uncertainty(trials, solution)
    return {
        str(p): (truth[p], solution.parameters[p], errors.standard_errors[p])
        for p in trials.unknown_parameters
    }


if __name__ == "__main__":
    for name, (true, estimate, error) in main().items():
        print(f"{name:>3} = {estimate:9.5f} +/- {error:.5f}   (truth {true})")
