"""Canonical column names and units of a gait trial.

Every gait trial that colloc reads or writes uses these names, so that synthetic trials,
converted gait-lab output and the identification workflow agree on one vocabulary.

Units (SI, angles in radians):

============================  =======  ==============================================
column                        unit     meaning
============================  =======  ==============================================
``time``                      s        sample time
``<side>_<joint>_angle``      rad      joint angle, gait2d convention (hip flexion +,
                                       knee extension +, i.e. minus knee flexion,
                                       ankle dorsiflexion +)
``<side>_<joint>_rate``       rad/s    time derivative of the joint angle
``trunk_x``, ``trunk_y``      m        trunk (pelvis) reference point, x forward, y up
``trunk_angle``               rad      trunk orientation, counter-clockwise +
``trunk_x_rate``,             m/s      trunk (pelvis) velocity, forward and up (optional,
``trunk_y_rate``                       all three or none; a gait lab differentiates the
``trunk_angle_rate``          rad/s    pelvis markers' trajectories as it does joint angles)
``belt_speed``                m/s      treadmill belt speed
``belt_position``             m        treadmill belt position (integral of belt speed)
``<side>_<joint>_torque``     N·m      joint torque (optional; absent in most real data)
``<side>_grf_x``, ``_grf_y``  N        ground reaction on the foot, forward and up
``<side>_cop_x``              m        its centre of pressure (NaN while unloaded); the
                                       three ground-reaction columns per side optional
============================  =======  ==============================================

with ``<side>`` in ``right``, ``left`` and ``<joint>`` in ``hip``, ``knee``, ``ankle``.
"""

from __future__ import annotations

SIDES: tuple[str, ...] = ("right", "left")
"""Body sides, in the order used by every side-indexed tuple in this module."""

JOINTS: tuple[str, ...] = ("hip", "knee", "ankle")
"""Joints of one leg, proximal to distal."""

TIME_COLUMN: str = "time"
"""Name of the time column of a trial file."""

JOINT_ANGLE_COLUMNS: tuple[str, ...] = tuple(
    f"{side}_{joint}_angle" for side in SIDES for joint in JOINTS
)
"""Joint angles [rad]: right hip, knee, ankle, then left hip, knee, ankle."""

JOINT_RATE_COLUMNS: tuple[str, ...] = tuple(
    f"{side}_{joint}_rate" for side in SIDES for joint in JOINTS
)
"""Joint angular rates [rad/s], same order as :data:`JOINT_ANGLE_COLUMNS`."""

TRUNK_COLUMNS: tuple[str, ...] = ("trunk_x", "trunk_y", "trunk_angle")
"""Trunk position [m] and orientation [rad]."""

BELT_COLUMNS: tuple[str, ...] = ("belt_speed", "belt_position")
"""Treadmill belt speed [m/s] and position [m]."""

TRUNK_RATE_COLUMNS: tuple[str, ...] = ("trunk_x_rate", "trunk_y_rate", "trunk_angle_rate")
"""Trunk velocity [m/s, m/s, rad/s], same order as :data:`TRUNK_COLUMNS`; optional in a trial.
Without them an identification must differentiate the noisy trunk positions."""

TORQUE_COLUMNS: tuple[str, ...] = tuple(
    f"{side}_{joint}_torque" for side in SIDES for joint in JOINTS
)
"""Joint torques [N·m], same order as :data:`JOINT_ANGLE_COLUMNS`; optional in a trial."""

GRF_COLUMNS: tuple[str, ...] = tuple(
    f"{side}_{name}" for side in SIDES for name in ("grf_x", "grf_y", "cop_x")
)
"""Ground reaction on each foot, as an instrumented treadmill's two plates give it: forward and
upward force [N] and the centre of pressure's forward position [m] (same frame as
``trunk_x``); optional in a trial. The centre of pressure is NaN while its foot is unloaded."""

COP_COLUMNS: tuple[str, ...] = tuple(c for c in GRF_COLUMNS if c.endswith("cop_x"))
"""The centre-of-pressure columns: the only ones that may hold NaN (an unloaded foot)."""

REQUIRED_COLUMNS: tuple[str, ...] = (
    JOINT_ANGLE_COLUMNS + JOINT_RATE_COLUMNS + TRUNK_COLUMNS + BELT_COLUMNS
)
"""Signal columns every trial must have (the time column is kept apart)."""

OPTIONAL_GROUPS: dict[str, tuple[str, ...]] = {
    "trunk rate": TRUNK_RATE_COLUMNS,
    "torque": TORQUE_COLUMNS,
    "ground reaction": GRF_COLUMNS,
}
"""Optional column groups: a trial has all columns of a group or none."""

SIGNAL_COLUMNS: tuple[str, ...] = (
    REQUIRED_COLUMNS + TRUNK_RATE_COLUMNS + TORQUE_COLUMNS + GRF_COLUMNS
)
"""All canonical signal columns, in the order a trial file is written."""


def _units() -> dict[str, str]:
    units = {TIME_COLUMN: "s"}
    units.update(dict.fromkeys(JOINT_ANGLE_COLUMNS, "rad"))
    units.update(dict.fromkeys(JOINT_RATE_COLUMNS, "rad/s"))
    units.update({"trunk_x": "m", "trunk_y": "m", "trunk_angle": "rad"})
    units.update({"trunk_x_rate": "m/s", "trunk_y_rate": "m/s", "trunk_angle_rate": "rad/s"})
    units.update({"belt_speed": "m/s", "belt_position": "m"})
    units.update(dict.fromkeys(TORQUE_COLUMNS, "N·m"))
    units.update({c: "m" if c in COP_COLUMNS else "N" for c in GRF_COLUMNS})
    return units


COLUMN_UNITS: dict[str, str] = _units()
"""Unit of every canonical column (including ``time``)."""


def normalize_unit(unit: str) -> str:
    """Return a unit string in a spelling-independent form for comparison.

    Spaces, multiplication signs (``·``, ``⋅``, ``*``) and case are ignored, so
    ``"N·m"``, ``"N m"``, ``"Nm"`` and ``"n*m"`` compare equal.

    Parameters
    ----------
    unit : str
        A unit as written in a metadata file.

    Returns
    -------
    str
        The normalised spelling.
    """
    normalized = unit.strip().lower()
    for separator in (" ", "·", "⋅", "*"):
        normalized = normalized.replace(separator, "")
    return normalized
