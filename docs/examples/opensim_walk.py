"""OpenSim's example walk (subject01) through ``colloc gait trial-from-lab``, against OpenSim.

The walk (TRC markers at 60 Hz in mm, clusters on thighs and shanks), its ground reactions
(MOT, two plates at 600 Hz) and the standing trial (with the epicondyles and malleoli) are
read as OpenSim ships them, and the planar angles and moments compared with OpenSim's planar
model's (Gait10dof18musc) inverse kinematics and dynamics. The files state no licence of their
own, so colloc does not ship them: the script reads them from the folder given, by default
``../shared/data/opensim-subject01-walk`` beside the project, and says so when it is missing::

    python docs/examples/opensim_walk.py [FOLDER] [OUT_DIR] [--smooth]

With ``--smooth`` the trial also goes through ``colloc gait smooth`` (the smoother tracking the
raw markers and plates the trial keeps), whose moments are compared with OpenSim's beside the
6 Hz inverse dynamics' (about a minute more).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from colloc.data.trial import Trial
from colloc.lab import LabSettings, trial_from_lab
from colloc.plot import save_figure

DEFAULT_FOLDER = (
    Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "opensim-subject01-walk"
)
WALK = "Gait2354_Simbody__subject01_walk1.trc"
FORCES = "Gait2354_Simbody__subject01_walk1_grf.mot"
STATIC = "Gait2354_Simbody__subject01_static.trc"
IK = "Gait10dof18musc__OutputReference__IK__subject01_walk_IK.mot"
ID = "Gait10dof18musc__OutputReference__ID__Results__subject01_walk_ID.sto"
SUBJECT = {"mass": 72.6, "height": 1.8034, "belt_speed": 1.12}  # the setup files; the belt
# from the feet's speed in stance
JOINTS = {"hip": "hip_flexion", "knee": "knee_angle", "ankle": "ankle_angle"}


def read_opensim(path: Path) -> pd.DataFrame:
    """An OpenSim storage (MOT/STO) as a table."""
    lines = path.read_text().splitlines()
    start = next(k for k, line in enumerate(lines) if line.strip() == "endheader") + 1
    return pd.read_csv(path, sep=r"\s+", skiprows=start)


def compare(folder: Path) -> tuple[Trial, dict[str, dict[str, float]]]:
    """The trial colloc makes of the walk, and per joint and side its agreement with OpenSim."""
    settings = LabSettings(SUBJECT["mass"], SUBJECT["height"], belt_speed=SUBJECT["belt_speed"])
    result = trial_from_lab(folder / WALK, settings, folder / FORCES, static=folder / STATIC)
    trial = result.trial
    ik, inverse = read_opensim(folder / IK), read_opensim(folder / ID)
    table = {}
    for side, s in (("right", "r"), ("left", "l")):
        for joint, name in JOINTS.items():
            ours = np.degrees(trial.signals[f"{side}_{joint}_angle"].to_numpy())
            theirs = np.interp(trial.time, ik["time"], ik[f"{name}_{s}"])
            moment = trial.signals[f"{side}_{joint}_torque"].to_numpy() / SUBJECT["mass"]
            their_moment = (
                np.interp(trial.time, inverse["time"], inverse[f"{name}_{s}_moment"])
                / SUBJECT["mass"]
            )
            table[f"{side} {joint}"] = {
                "angle_r": float(np.corrcoef(ours, theirs)[0, 1]),
                "angle_offset_deg": float(np.mean(ours - theirs)),
                "moment_rms_nm_per_kg": float(np.sqrt(np.mean((moment - their_moment) ** 2))),
            }
    return trial, table


def draw(folder: Path, trial: Trial, out: Path) -> Path:
    ik, inverse = read_opensim(folder / IK), read_opensim(folder / ID)
    fig, axes = plt.subplots(2, 3, figsize=(11, 5.5), sharex=True)
    for column, (joint, name) in enumerate(JOINTS.items()):
        angle, moment = axes[0, column], axes[1, column]
        for side, s, colour in (("right", "r", "C0"), ("left", "l", "C3")):
            angle.plot(
                trial.time,
                np.degrees(trial.signals[f"{side}_{joint}_angle"]),
                colour,
                label=f"colloc {side}",
            )
            angle.plot(
                ik["time"], ik[f"{name}_{s}"], colour, ls="--", lw=1, label=f"OpenSim {side}"
            )
            moment.plot(
                trial.time, trial.signals[f"{side}_{joint}_torque"] / SUBJECT["mass"], colour
            )
            moment.plot(
                inverse["time"],
                inverse[f"{name}_{s}_moment"] / SUBJECT["mass"],
                colour,
                ls="--",
                lw=1,
            )
        angle.set_title(joint)
        angle.set_ylabel("angle [deg]" if column == 0 else "")
        moment.set_ylabel("moment [N m/kg]" if column == 0 else "")
        moment.set_xlabel("time [s]")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle("OpenSim's subject01 walk: colloc (solid) and OpenSim's planar IK and ID (dashed)")
    return save_figure(fig, out, "opensim-walk", formats=("png",))[0]


def smoothed(trial: Trial, fit_places: bool = False) -> pd.DataFrame:
    """The trial through the marker smoother (``colloc gait smooth``, with ``--fit-places``
    the markers' places estimated with the motion), as its table."""
    from colloc.identify.gait.smooth import smooth_trial, smoothed_table

    with tempfile.TemporaryDirectory() as folder:
        trial.write(Path(folder) / "trial")
        run = smooth_trial(Path(folder) / "trial", fit_places=fit_places)
    if not run.success:
        print("note: a window's last stage did not converge:", *run.notes, sep="\n  ")
    return smoothed_table(run)


def compare_smoothed(folder: Path, table: pd.DataFrame) -> dict[str, dict[str, float]]:
    """Per joint and side, the smoother's angles and moments against OpenSim's."""
    ik, inverse = read_opensim(folder / IK), read_opensim(folder / ID)
    t = table["time"].to_numpy()
    out = {}
    for side, s in (("right", "r"), ("left", "l")):
        for joint, name in JOINTS.items():
            ours = np.degrees(table[f"{side}_{joint}_angle"].to_numpy())
            theirs = np.interp(t, ik["time"], ik[f"{name}_{s}"])
            moment = table[f"{side}_{joint}_torque"].to_numpy() / SUBJECT["mass"]
            their = np.interp(t, inverse["time"], inverse[f"{name}_{s}_moment"]) / SUBJECT["mass"]
            out[f"{side} {joint}"] = {
                "angle_r": float(np.corrcoef(ours, theirs)[0, 1]),
                "moment_rms_nm_per_kg": float(np.sqrt(np.mean((moment - their) ** 2))),
            }
    return out


def draw_smoothed(folder: Path, trial: Trial, table: pd.DataFrame, out: Path) -> Path:
    """The right side's moments: the smoother's, the 6 Hz inverse dynamics' and OpenSim's."""
    inverse = read_opensim(folder / ID)
    fig, axes = plt.subplots(1, 3, figsize=(11, 3.4), sharex=True)
    for ax, (joint, name) in zip(axes, JOINTS.items(), strict=True):
        ax.plot(table["time"], table[f"right_{joint}_torque"] / SUBJECT["mass"], "C0",
                label="smoother (markers, plates)")  # fmt: skip
        ax.plot(trial.time, trial.signals[f"right_{joint}_torque"] / SUBJECT["mass"], "C2",
                lw=1, ls=":", label="6 Hz inverse dynamics")  # fmt: skip
        ax.plot(inverse["time"], inverse[f"{name}_r_moment"] / SUBJECT["mass"], "k", lw=1,
                ls="--", label="OpenSim ID")  # fmt: skip
        ax.set_title(f"right {joint}")
        ax.set_xlabel("time [s]")
    axes[0].set_ylabel("moment [N m/kg]")
    axes[0].legend(fontsize=7)
    fig.suptitle("OpenSim's subject01 walk: moments from the smoother, the 6 Hz path and OpenSim")
    return save_figure(fig, out, "opensim-smooth", formats=("png",))[0]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?", type=Path, default=DEFAULT_FOLDER)
    parser.add_argument("out", nargs="?", type=Path, default=None)
    parser.add_argument("--smooth", action="store_true", help="also through gait smooth")
    parser.add_argument(
        "--fit-places",
        action="store_true",
        help="with --smooth: the markers' places estimated with the motion (gait smooth --fit-places)",
    )
    args = parser.parse_args()
    if not (args.folder / WALK).is_file():
        print(
            f"OpenSim's example walk is not at {args.folder} (colloc does not ship it: its data "
            "state no licence); give the folder holding the opensim-models Pipelines files",
            file=sys.stderr,
        )
        return 2
    trial, table = compare(args.folder)
    print(f"{'joint':<12} {'angle r':>8} {'offset':>8} {'moment RMS':>11}")
    for joint, row in table.items():
        print(
            f"{joint:<12} {row['angle_r']:8.3f} {row['angle_offset_deg']:+7.1f}° "
            f"{row['moment_rms_nm_per_kg']:8.3f} N m/kg"
        )
    out = args.out or Path(tempfile.mkdtemp())
    print(f"figure: {draw(args.folder, trial, out)}")
    if args.smooth:
        table = smoothed(trial, args.fit_places)
        print(
            f"\nthe smoother's, against OpenSim's\n{'joint':<12} {'angle r':>8} {'moment RMS':>11}"
        )
        for joint, row in compare_smoothed(args.folder, table).items():
            print(f"{joint:<12} {row['angle_r']:8.3f} {row['moment_rms_nm_per_kg']:8.3f} N m/kg")
        print(f"figure: {draw_smoothed(args.folder, trial, table, out)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
