"""Identify parameters and a force nobody measured: an unknown input trajectory.

Two masses coupled by a spring; the first is pushed by a force ``w(t)`` that was not
measured, the second held by a spring and a damper. From both masses' noisy positions colloc
estimates the coupling spring, the second spring and damper, and the force at every sample.
Run it as a script::

    python docs/examples/unknown_input.py [OUT_DIR] [--duration 10]

It prints the estimates and writes ``unknown-input.png`` (the estimated force, smoothed over
a quarter second, against the force applied).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import sympy as sm
from scipy.integrate import solve_ivp
from sympy.physics.mechanics import dynamicsymbols

import colloc

t = dynamicsymbols._t
x1, v1, x2, v2, w = dynamicsymbols("x1 v1 x2 v2 w")
m1, m2, k12, k2, c2 = sm.symbols("m1 m2 k12 k2 c2")
TRUTH = {m1: 1.0, m2: 0.5, k12: 30.0, k2: 12.0, c2: 0.7}
SIGMA = 0.001  # position noise [m]


def push(time: np.ndarray) -> np.ndarray:
    """The force applied to the first mass (unknown to the identification) [N]."""
    return 2.0 * np.sin(1.7 * time) + 1.5 * np.sin(4.9 * time + 0.3) + np.sin(9.1 * time)


def measure(times: np.ndarray, seed: int = 4) -> dict:
    """Noisy positions of both masses, from SciPy's solution of the true system."""

    def rhs(time: float, y: np.ndarray) -> list[float]:
        a, va, b, vb = y
        spring = TRUTH[k12] * (a - b)
        return [
            va,
            (push(time) - spring) / TRUTH[m1],
            vb,
            (spring - TRUTH[k2] * b - TRUTH[c2] * vb) / TRUTH[m2],
        ]

    span = (times[0], times[-1])
    exact = solve_ivp(rhs, span, [0.0] * 4, t_eval=times, rtol=1e-11, atol=1e-13).y
    rng = np.random.default_rng(seed)
    return {s: y + rng.normal(0.0, SIGMA, times.size) for s, y in ((x1, exact[0]), (x2, exact[2]))}


def main(out_dir: Path, duration: float = 10.0) -> dict:
    """Identify, print, draw; returns name -> (truth, estimate, standard error), and the
    force's smoothed estimate and applied values under ``"force"``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    times = np.linspace(0.0, duration, int(round(100 * duration)) + 1)
    measured = measure(times)
    model = colloc.Model.from_equations(  # implicit equations, the force an unknown input
        [
            x1.diff(t) - v1,
            m1 * v1.diff(t) + k12 * (x1 - x2) - w,
            x2.diff(t) - v2,
            m2 * v2.diff(t) - k12 * (x1 - x2) + k2 * x2 + c2 * v2,
        ],
        [x1, v1, x2, v2],
        unknown_inputs=[w],
    )
    problem = colloc.Problem(
        model,
        times,
        scheme=colloc.transcription.HermiteSimpson(),
        known_parameters={m1: TRUTH[m1], m2: TRUTH[m2]},
        objective=colloc.Tracking(measured, SIGMA**-2),
        process_noise={w: 50.0},  # a loose prior on the force: keeps the problem regular
    )
    rates = {v1: np.gradient(measured[x1], times), v2: np.gradient(measured[x2], times)}
    guess = problem.initial_guess({**measured, **rates}, {k12: 20.0, k2: 8.0, c2: 0.3})
    solution = problem.solve(guess)
    errors = colloc.parameter_uncertainty(problem, solution).standard_errors
    out: dict = {}
    for p in (k12, k2, c2):
        out[str(p)] = (TRUTH[p], float(solution.parameters[p]), float(errors[p]))
        print(f"{p!s:>4} = {out[str(p)][1]:8.4f} +/- {out[str(p)][2]:.4f}   (truth {TRUTH[p]})")
    # node by node the force carries the second difference of the position noise; its sum
    # telescopes, so a quarter-second average shows the force itself
    window = np.ones(25) / 25
    estimate = np.convolve(solution.trajectories[w], window, "valid")
    applied = np.convolve(push(times), window, "valid")
    out["force"] = (estimate, applied)
    middle = times[12 : 12 + estimate.size]
    fig, ax = plt.subplots(figsize=(7, 2.8))
    ax.plot(middle, estimate, lw=0.8, color="tab:blue", label="estimated, 0.25 s average")
    ax.plot(middle, applied, lw=1.6, color="k", label="applied (not measured)")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("w [N]")
    ax.legend(loc="upper right")
    fig.tight_layout()
    out_dir.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_dir / "unknown-input.png", dpi=110)
    plt.close(fig)
    return out


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, nargs="?", default=Path("docs/figures"))
    parser.add_argument("--duration", type=float, default=10.0)
    arguments = parser.parse_args()
    main(arguments.out, arguments.duration)
