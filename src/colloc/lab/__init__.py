"""The gait lab's side: marker and force-plate exports to a colloc gait trial.

:func:`trial_from_lab` reads the exports, fills marker gaps, filters markers and forces
alike (zero-lag Butterworth, 6 Hz by default), solves the planar inverse kinematics in
gait2d's conventions and each leg's inverse dynamics with gait2d's segments, detects heel
strikes, and returns a :class:`colloc.data.Trial` that ``colloc gait identify`` reads.
:func:`lab_export_from_record` makes the exports a lab would have recorded of a simulated
walk, to check the pipeline against the truth.
"""

from colloc.data.filtering import dual_pass_correction, time_derivative, zero_lag_lowpass
from colloc.lab.dynamics import JointLoads, LegInertia, leg_inverse_dynamics
from colloc.lab.exports import LabExport, LabFileError, read_lab_export
from colloc.lab.gaps import Gap, fill_gaps
from colloc.lab.kinematics import (
    LEG2D_SIGNS,
    angles_from_leg2d,
    joint_angles,
    segment_orientation,
    segment_orientations,
)
from colloc.lab.markers import DEFAULT_MARKER_SET, MarkerSet
from colloc.lab.pipeline import LabResult, LabSettings, process_lab, trial_from_lab
from colloc.lab.synthetic import LabNoise, lab_export_from_record, write_lab_export

__all__ = [
    "DEFAULT_MARKER_SET",
    "LEG2D_SIGNS",
    "Gap",
    "JointLoads",
    "LabExport",
    "LabFileError",
    "LabNoise",
    "LabResult",
    "LabSettings",
    "LegInertia",
    "MarkerSet",
    "angles_from_leg2d",
    "dual_pass_correction",
    "fill_gaps",
    "joint_angles",
    "lab_export_from_record",
    "leg_inverse_dynamics",
    "process_lab",
    "read_lab_export",
    "segment_orientation",
    "segment_orientations",
    "time_derivative",
    "trial_from_lab",
    "write_lab_export",
    "zero_lag_lowpass",
]
