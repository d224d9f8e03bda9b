"""Measurement I/O for gait trials: trial files, heel-strike events, gait phase, records."""

from colloc.data.belt import (
    belt_position,
    perturbation_belt_speed,
    read_belt_perturbation,
    rescale_belt_speed,
)
from colloc.data.checks import TrialError
from colloc.data.columns import (
    COLUMN_UNITS,
    REQUIRED_COLUMNS,
    SIGNAL_COLUMNS,
    TIME_COLUMN,
    TORQUE_COLUMNS,
    TRUNK_RATE_COLUMNS,
)
from colloc.data.events import detect_heel_strikes
from colloc.data.phase import (
    causal_gait_phase,
    gait_phase,
    phase_normalised,
    unwrapped_gait_phase,
)
from colloc.data.records import WinterGaitCycle, read_vertical_grf, read_winter_gait_cycle
from colloc.data.split import split
from colloc.data.trial import Trial, read_trial

__all__ = [
    "COLUMN_UNITS",
    "REQUIRED_COLUMNS",
    "SIGNAL_COLUMNS",
    "TIME_COLUMN",
    "TORQUE_COLUMNS",
    "TRUNK_RATE_COLUMNS",
    "Trial",
    "TrialError",
    "WinterGaitCycle",
    "belt_position",
    "detect_heel_strikes",
    "gait_phase",
    "phase_normalised",
    "unwrapped_gait_phase",
    "causal_gait_phase",
    "perturbation_belt_speed",
    "read_belt_perturbation",
    "read_trial",
    "read_vertical_grf",
    "read_winter_gait_cycle",
    "rescale_belt_speed",
    "split",
]
