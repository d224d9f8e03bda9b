"""colloc's lab pipeline on 3 s of real walking, against GaitAnalysisToolKit's leg2d.

The clip (``rawdata.txt``: the right leg's six sagittal markers and its force plate, 100 Hz,
11 frames with a marker missing) and leg2d's output for it (``refresults.mat``, made with a
4 Hz cut-off) are GaitAnalysisToolKit's test fixtures, copied into colloc's test data. Run::

    python docs/examples/lab_clip.py tests/data/records/gatk-leg2d-sagittal-gait-3s [OUT_DIR]

It fills the gaps, filters at leg2d's 4 Hz (and at the 6 Hz default, for comparison), solves
the right leg's angles, rates and moments with colloc's functions and draws them over leg2d's.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from scipy.io import loadmat

from colloc.lab import (
    DEFAULT_MARKER_SET,
    LEG2D_SIGNS,
    LegInertia,
    angles_from_leg2d,
    fill_gaps,
    joint_angles,
    leg_inverse_dynamics,
    read_lab_export,
    segment_orientations,
    time_derivative,
    zero_lag_lowpass,
)
from colloc.models.gait2d_params import load_parameters
from colloc.plot import save_figure

MASS = 67.2  # kg, the clip's subject (leg2d's test)
RIGHT = DEFAULT_MARKER_SET.side_markers("right")  # RSHO, RGTRO, RLEK, RLM, RHEE, RMT5
JOINTS = ("hip", "knee", "ankle")


def right_leg(clip: Path, cutoff: float) -> dict[str, np.ndarray]:
    """Angles, rates [rad, rad/s] and moments [N m/kg] of the clip's right leg, gait2d's signs."""
    export = read_lab_export(clip / "rawdata.txt")
    filled, _, span = fill_gaps(export.time, export.markers)
    rate = export.sample_rate
    marks = {k: zero_lag_lowpass(filled[v][span], rate, cutoff) for k, v in RIGHT.items()}
    orientations = segment_orientations(marks)
    angles = joint_angles(orientations)
    # the subject's height is not recorded: the one whose thigh (0.245 H) the markers measure
    thigh = np.linalg.norm(marks["knee"] - marks["hip"], axis=1).mean()
    inertia = LegInertia.from_parameters(load_parameters(MASS, thigh / 0.245))
    load = zero_lag_lowpass(export.plates["FP2"][span], rate, cutoff)
    loads = leg_inverse_dynamics(marks, orientations, load, inertia, rate)
    return {
        "time": export.time[span],
        "angles": angles,
        "rates": time_derivative(angles, rate),
        "moments": loads.torques / MASS,
        "stance": export.plates["FP2"][span, 1] > 20.0,
    }


def main(clip: Path, out_dir: Path) -> list[Path]:
    """Draw the clip's kinematics and moments against leg2d's; returns the files written."""
    reference = loadmat(clip / "refresults.mat")["refresults"]
    leg2d = {
        "angles": angles_from_leg2d(reference[:, :3]),
        "rates": reference[:, 3:6] * LEG2D_SIGNS,
        "moments": reference[:, 6:9] * LEG2D_SIGNS,
    }
    at4, at6 = right_leg(clip, 4.0), right_leg(clip, 6.0)
    time = at4["time"]
    fig, axes = plt.subplots(2, 3, figsize=(11, 5.5), sharex=True)
    for row, (key, unit) in enumerate((("angles", "deg"), ("rates", "deg/s"))):
        for j, joint in enumerate(JOINTS):
            ax = axes[row, j]
            ax.plot(
                time, np.degrees(leg2d[key][:, j]), "k", lw=2.5, alpha=0.35, label="leg2d (4 Hz)"
            )
            ax.plot(time, np.degrees(at4[key][:, j]), "C0", lw=1.2, label="colloc, 4 Hz")
            ax.plot(time, np.degrees(at6[key][:, j]), "C1--", lw=1.0, label="colloc, 6 Hz")
            ax.set_title(f"right {joint}" if row == 0 else "")
            ax.set_ylabel(f"{key[:-1]} [{unit}]" if j == 0 else "")
            if row == 1:
                ax.set_xlabel("time [s]")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("real walking: gait2d angles and rates, colloc against leg2d")
    fig.tight_layout()
    written = save_figure(fig, out_dir, "lab-clip-kinematics", ("png",), dpi=80)
    plt.close(fig)
    fig, axes = plt.subplots(1, 3, figsize=(11, 3.2), sharex=True)
    for j, joint in enumerate(JOINTS):
        ax = axes[j]
        ax.fill_between(
            time, 0, 1, where=at4["stance"], color="0.9", transform=ax.get_xaxis_transform()
        )
        ax.plot(
            time, leg2d["moments"][:, j], "k", lw=2.5, alpha=0.35, label="leg2d (2013 segments)"
        )
        ax.plot(time, at4["moments"][:, j], "C0", lw=1.2, label="colloc, gait2d segments")
        ax.set_title(f"right {joint} (stance shaded)")
        ax.set_xlabel("time [s]")
    axes[0].set_ylabel("moment [N m/kg], gait2d signs")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    written += save_figure(fig, out_dir, "lab-clip-moments", ("png",), dpi=80)
    plt.close(fig)
    return written


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("clip", type=Path, help="folder with rawdata.txt and refresults.mat")
    parser.add_argument("out_dir", type=Path, nargs="?", default=Path("."))
    args = parser.parse_args()
    for path in main(args.clip, args.out_dir):
        print(path)
