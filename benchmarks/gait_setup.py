"""The gait identification setup the gait benchmarks share: a trial, its true controller, the
plant, a ``GainScheduled`` with the trial's feedback and P, and the columns of each signal."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from colloc import GainScheduled
from colloc.data import read_trial
from colloc.data.columns import TORQUE_COLUMNS
from colloc.data.trial import Trial
from colloc.gait.metadata import STATE_SIGNAL_NAMES, controller_from_metadata
from colloc.gait.orbit import GaitDynamics
from colloc.gait.trials import COLUMN_NOISE_GROUP, DEFAULT_NOISE_STD, STATE_COLUMNS
from colloc.models.gait2d_params import load_parameters


@dataclass
class GaitSetup:
    trial: Trial
    Tstar: np.ndarray
    K: np.ndarray
    dyn: GaitDynamics
    gs: GainScheduled
    names: list[str]
    columns: dict  # state or torque symbol -> trial column

    def window(self, start: float, length: float) -> tuple[np.ndarray, pd.DataFrame]:
        """Times and signals of ``[start, start + length]``."""
        t = self.trial.time
        keep = (t >= start - 1e-9) & (t <= start + length + 1e-9)
        return t[keep], self.trial.signals[keep]

    def known(self, signals: pd.DataFrame) -> dict:
        """The known trajectories of the closed loop: belt speed and controller phase."""
        return {
            self.dyn.gait.belt_speed: signals["belt_speed"].to_numpy(),
            self.gs.phase: signals["controller_phase"].to_numpy(),
        }

    def sigma(self, signal) -> float:
        """Noise standard deviation of a state or torque's column: the trial's, or the default
        lab noise when the trial is noise-free."""
        group = COLUMN_NOISE_GROUP[self.columns[signal]]
        return self.trial.metadata["noise"]["std"][group] or DEFAULT_NOISE_STD[group]


def load(path: Path) -> GaitSetup:
    """Read the trial at ``path`` and build its plant and controller."""
    trial = read_trial(path)
    Tstar, K, _ = controller_from_metadata(trial.metadata)
    dyn = GaitDynamics.build(
        load_parameters(trial.metadata.get("body_mass", 75.0), trial.metadata.get("height", 1.8))
    )
    model = dyn.model
    names = trial.metadata["controller"]["feedback"]
    feedback = [model.states[STATE_SIGNAL_NAMES.index(n)] for n in names]
    gs = GainScheduled(Tstar.shape[0], feedback, dyn.gait.torques)
    columns = dict(zip(model.states, STATE_COLUMNS, strict=True))
    columns.update(zip(dyn.gait.torques, TORQUE_COLUMNS, strict=True))
    return GaitSetup(trial, Tstar, K, dyn, gs, names, columns)
