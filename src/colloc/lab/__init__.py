"""The gait lab's side: marker and force-plate files (C3D, TRC, MOT/STO, tab exports) to a
colloc gait trial.

:func:`trial_from_lab` reads the exports, fills marker gaps, filters markers and forces
alike (zero-lag Butterworth, 6 Hz by default), solves the planar inverse kinematics in
gait2d's conventions and each leg's inverse dynamics with gait2d's segments, detects heel
strikes, and returns a :class:`colloc.data.Trial` that ``colloc gait identify`` reads.
:func:`lab_export_from_record` makes the exports a lab would have recorded of a simulated
walk, to check the pipeline against the truth.

Names load on first use (``colloc._lazy``).
"""

# ruff: noqa: F401  (the TYPE_CHECKING imports are re-exported by __all__, built from _EXPORTS)
from typing import TYPE_CHECKING

from colloc._lazy import lazy_exports

_EXPORTS = {
    "JointLoads": "colloc.lab.dynamics",
    "LegInertia": "colloc.lab.dynamics",
    "leg_inverse_dynamics": "colloc.lab.dynamics",
    "LabExport": "colloc.lab.exports",
    "LabFileError": "colloc.lab.exports",
    "read_lab_export": "colloc.lab.exports",
    "read_lab_file": "colloc.lab.formats",
    "lab_file_format": "colloc.lab.formats",
    "LabRecord": "colloc.lab.record",
    "PlateSeries": "colloc.lab.record",
    "SagittalPlane": "colloc.lab.sagittal",
    "find_plane": "colloc.lab.sagittal",
    "sagittal_exports": "colloc.lab.sagittal",
    "write_lab_files": "colloc.lab.writers",
    "dual_pass_correction": "colloc.data.filtering",
    "time_derivative": "colloc.data.filtering",
    "zero_lag_lowpass": "colloc.data.filtering",
    "Gap": "colloc.lab.gaps",
    "fill_gaps": "colloc.lab.gaps",
    "LEG2D_SIGNS": "colloc.lab.kinematics",
    "angles_from_leg2d": "colloc.lab.kinematics",
    "joint_angles": "colloc.lab.kinematics",
    "segment_orientation": "colloc.lab.kinematics",
    "segment_orientations": "colloc.lab.kinematics",
    "DEFAULT_MARKER_SET": "colloc.lab.markers",
    "MarkerSet": "colloc.lab.markers",
    "LabResult": "colloc.lab.pipeline",
    "LabSettings": "colloc.lab.settings",
    "process_lab": "colloc.lab.pipeline",
    "trial_from_lab": "colloc.lab.from_files",
    "LabNoise": "colloc.lab.synthetic",
    "lab_export_from_record": "colloc.lab.synthetic",
    "write_lab_export": "colloc.lab.synthetic",
    "SkinLab": "colloc.lab.synthetic_skin",
    "skin_lab_from_record": "colloc.lab.synthetic_skin",
    "write_skin_lab": "colloc.lab.writers",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())

if TYPE_CHECKING:  # for type checkers; re-exported through __all__
    from colloc.data.filtering import dual_pass_correction, time_derivative, zero_lag_lowpass
    from colloc.lab.dynamics import JointLoads, LegInertia, leg_inverse_dynamics
    from colloc.lab.exports import LabExport, LabFileError, read_lab_export
    from colloc.lab.formats import lab_file_format, read_lab_file
    from colloc.lab.from_files import trial_from_lab
    from colloc.lab.gaps import Gap, fill_gaps
    from colloc.lab.kinematics import (
        LEG2D_SIGNS,
        angles_from_leg2d,
        joint_angles,
        segment_orientation,
        segment_orientations,
    )
    from colloc.lab.markers import DEFAULT_MARKER_SET, MarkerSet
    from colloc.lab.pipeline import LabResult, process_lab
    from colloc.lab.record import LabRecord, PlateSeries
    from colloc.lab.sagittal import SagittalPlane, find_plane, sagittal_exports
    from colloc.lab.settings import LabSettings
    from colloc.lab.synthetic import LabNoise, lab_export_from_record, write_lab_export
    from colloc.lab.synthetic_skin import SkinLab, skin_lab_from_record
    from colloc.lab.writers import write_lab_files, write_skin_lab

__all__ = list(_EXPORTS)
