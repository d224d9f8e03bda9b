"""The noise a trial records of its signals, and of its torque equations."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np


def trial_noise_std(meta: Mapping[str, Any], column: str) -> float:
    """Noise standard deviation of a trial column: the trial's metadata records it
    (``noise: std: group: value``), else the default lab noise of its group
    (:data:`colloc.gait.trials.DEFAULT_NOISE_STD`)."""
    from colloc.gait.trials import COLUMN_NOISE_GROUP, DEFAULT_NOISE_STD

    group = COLUMN_NOISE_GROUP[column]
    noise = meta.get("noise")
    recorded = noise.get("std", {}) if isinstance(noise, Mapping) else {}
    value = recorded.get(group) if isinstance(recorded, Mapping) else None
    return float(value) if value else DEFAULT_NOISE_STD[group]


def recorded_motor_noise(meta: Mapping[str, Any]) -> float | None:
    """The motor noise's standard deviation a synthetic trial records [N m] (``motor_noise:
    std``; 0 when the entry has none), or None when the trial records no motor noise entry."""
    motor = meta.get("motor_noise")
    if not isinstance(motor, Mapping):
        return None
    return float(motor.get("std", 0.0) or 0.0)


def torque_equation_noise(meta: Mapping[str, Any]) -> float | None:
    """The noise of each torque equation ``T = T*(phi) - K(phi) s``: the trial's torque
    measurement noise and its recorded motor noise combined (``hypot``), or None when the
    trial records no motor noise."""
    from colloc.data.columns import TORQUE_COLUMNS

    motor = recorded_motor_noise(meta)
    if motor is None:
        return None
    return float(np.hypot(trial_noise_std(meta, TORQUE_COLUMNS[0]), motor))
