"""The seed's study from Python: a 1-link pendulum on a cart, gains identified from noisy data.

Run it as a script::

    python docs/examples/pendulum_study.py [OUT_DIR] [--duration 60]

It prints the known and identified gains with their standard errors and writes the study's
figures into OUT_DIR (a sketch of the model, measured against identified trajectories, the
gains with error bars, the cart force, the defects) - the same as ``colloc pendulum -n 1 -r -i close -p``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from colloc.identify import PendulumSettings, run_pendulum
from colloc.identify.pendulum.outputs import save_pendulum_plots
from colloc.plot import plot_pendulum_cart, save_figure


def main(out_dir: Path, duration: float = 60.0) -> list[Path]:
    """Run the study, print the gains, write the figures; returns the files written."""
    settings = PendulumSettings(
        num_links=1, duration=duration, sensor_noise=True, initial_guess="close", seed=0
    )
    run = run_pendulum(settings)
    print(f"IPOPT: {run.solution.stats['message']} ({run.uncertainty.method} standard errors)")
    for name, known, found, error in zip(
        run.gain_names, run.known_gains, run.identified_gains, run.standard_errors, strict=True
    ):
        print(f"{name}: known {known:9.4f}  identified {found:9.4f} +/- {error:.4f}")
    sketch = plot_pendulum_cart(run.true_states[0, :2], run.lengths, time=0.0, figsize=(4.0, 3.0))
    written = save_figure(sketch, out_dir, "model", ("png",), dpi=80)
    return written + save_pendulum_plots(run, out_dir, formats=("png",))


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, nargs="?", default=Path("docs/figures"))
    parser.add_argument("--duration", type=float, default=60.0)
    arguments = parser.parse_args()
    for path in main(arguments.out, arguments.duration):
        print(path)
