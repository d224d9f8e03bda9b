"""Identify the parameters of your own model: a driven mass on a hardening spring.

The plant is written in SymPy mechanics (Kane's method); the driving force is measured, the
position is measured with noise, and the damping and the linear and cubic stiffness are
estimated with their standard errors. Run it as a script::

    python docs/examples/own_model.py [OUT_DIR] [--duration 10]

It prints the estimates and writes ``own-model.png`` (measured against identified motion).
The data here are simulated by SciPy so that the truth is known; with a real record, replace
``simulate`` by reading your measurements.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me
from scipy.integrate import solve_ivp

import colloc

x, u, F = me.dynamicsymbols("x u F")
m, c, k1, k3 = sm.symbols("m c k1 k3")
TRUTH = {m: 1.0, c: 0.6, k1: 25.0, k3: 400.0}
SIGMA = 0.002  # position noise [m]


def force(time: np.ndarray) -> np.ndarray:
    """The measured driving force [N]."""
    return 6.0 * np.sin(3.1 * time) + 3.0 * np.sin(7.3 * time + 1.0)


def plant() -> colloc.Model:
    """m x'' = F - c x' - k1 x - k3 x^3, by Kane's method."""
    frame = me.ReferenceFrame("N")
    wall = me.Point("wall")
    wall.set_vel(frame, 0)
    mass = wall.locatenew("P", x * frame.x)
    mass.set_vel(frame, u * frame.x)
    load = (F - c * u - k1 * x - k3 * x**3) * frame.x
    kane = me.KanesMethod(frame, [x], [u], kd_eqs=[x.diff() - u])
    kane.kanes_equations([me.Particle("mass", mass, m)], [(mass, load)])
    return colloc.Model.from_kane(kane, known_inputs=[F])


def simulate(times: np.ndarray, seed: int = 11) -> np.ndarray:
    """A noisy position record of the true system."""

    def rhs(time: float, y: np.ndarray) -> list[float]:
        spring = TRUTH[k1] * y[0] + TRUTH[k3] * y[0] ** 3
        return [y[1], (force(time) - TRUTH[c] * y[1] - spring) / TRUTH[m]]

    span = (times[0], times[-1])
    exact = solve_ivp(rhs, span, [0.05, 0.0], t_eval=times, rtol=1e-11, atol=1e-12).y[0]
    return exact + np.random.default_rng(seed).normal(0.0, SIGMA, times.size)


def identify(times: np.ndarray, measured: np.ndarray) -> tuple[colloc.Solution, dict]:
    """Estimates and standard errors of c, k1 and k3 (the mass is known)."""
    problem = colloc.Problem(
        plant(),
        times,
        scheme=colloc.transcription.HermiteSimpson(),  # fourth order: no visible bias in k3
        known_trajectories={F: force(times)},
        known_parameters={m: TRUTH[m]},
        objective=colloc.Tracking({x: measured}, SIGMA**-2),
    )
    guess = problem.initial_guess(
        {x: measured, u: np.gradient(measured, times)}, {c: 1.0, k1: 10.0, k3: 0.0}
    )
    solution = problem.solve(guess, scale={k1: 10.0, k3: 100.0})
    errors = colloc.parameter_uncertainty(problem, solution).standard_errors
    return solution, errors


def main(out_dir: Path, duration: float = 10.0) -> dict[str, tuple[float, float, float]]:
    """Simulate, identify, print and draw; returns name -> (truth, estimate, standard error)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    times = np.linspace(0.0, duration, int(round(100 * duration)) + 1)
    measured = simulate(times)
    solution, errors = identify(times, measured)
    table = {
        str(p): (TRUTH[p], float(solution.parameters[p]), float(errors[p])) for p in (c, k1, k3)
    }
    for name, (true, estimate, error) in table.items():
        print(f"{name:>3} = {estimate:9.4f} +/- {error:.4f}   (truth {true})")
    fig, ax = plt.subplots(figsize=(7, 2.8))
    ax.plot(times, measured, ".", ms=2, color="0.6", label="measured")
    ax.plot(times, solution.trajectories[x], lw=1.2, label="identified")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("x [m]")
    ax.legend(loc="upper right")
    fig.tight_layout()
    out_dir.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_dir / "own-model.png", dpi=110)
    plt.close(fig)
    return table


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, nargs="?", default=Path("docs/figures"))
    parser.add_argument("--duration", type=float, default=10.0)
    arguments = parser.parse_args()
    main(arguments.out, arguments.duration)
