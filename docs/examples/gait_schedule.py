"""Read a gait trial's controller and draw its schedule over the gait cycle.

A synthetic trial (``colloc gait simulate``) keeps its true controller
``T(t) = T*(phi) - K(phi) s(t)`` in ``metadata.yaml``. This draws ``T*(phi)`` and each joint's
stiffness, its gain on its own angle, against the phase. Run it as a script::

    python docs/examples/gait_schedule.py TRIAL_DIR [OUT_DIR]

The same function draws an identified schedule with its standard-error bands
(``colloc.plot.plot_schedule``; ``colloc runs export`` gives the identified ``Tstar`` and
``K``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from colloc.data import read_trial
from colloc.data.columns import JOINT_ANGLE_COLUMNS
from colloc.gait.metadata import controller_from_metadata
from colloc.plot import plot_schedule, save_figure


def main(trial_dir: Path, out_dir: Path) -> list[Path]:
    """Draw ``T*(phi)`` and the joints' stiffness schedules; returns the files written."""
    trial = read_trial(trial_dir)
    tstar, gains, _ = controller_from_metadata(trial.metadata)
    signals = list(trial.metadata["controller"]["feedback"])
    joints = [column.removesuffix("_angle") for column in JOINT_ANGLE_COLUMNS]
    stiffness = gains[:, range(len(joints)), [signals.index(c) for c in JOINT_ANGLE_COLUMNS]]
    points = tstar.shape[0]
    written = save_figure(
        plot_schedule(
            {"T*": (tstar, None)}, joints, f"feedforward torque T*(phi) [N m], P = {points}"
        ),
        out_dir,
        "gait-schedule-tstar",
        ("png",),
        dpi=80,
    )
    written += save_figure(
        plot_schedule(
            {"K": (stiffness, None)}, joints, "stiffness K(phi) on the joint's own angle [N m/rad]"
        ),
        out_dir,
        "gait-schedule-stiffness",
        ("png",),
        dpi=80,
    )
    return written


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("trial", type=Path)
    parser.add_argument("out", type=Path, nargs="?", default=Path("docs/figures"))
    arguments = parser.parse_args()
    for path in main(arguments.trial, arguments.out):
        print(path)
