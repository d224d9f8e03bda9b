"""What the two fits of :func:`colloc.identify.gait.workflow.identify_gait` read and return."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from colloc.control.gain_scheduled import GainScheduled
from colloc.identify.gait.estimate import (
    ControllerEstimate,
)
from colloc.identify.gait.read import (
    GaitData,
)
from colloc.identify.gait.settings import GaitIdentifySettings
from colloc.identify.gait.windows import (
    WindowMap,
)

Progress = Callable[[str, str], None]


Iterations = Callable[[dict[str, float]], Any]


@dataclass
class FitContext:
    """What both fits read: the settings, the data and the direct start."""

    settings: GaitIdentifySettings
    data: GaitData
    dyn: Any
    gs: GainScheduled
    direct: ControllerEstimate
    say: Progress
    iterations: Iterations | None
    notes: list[str]
    lap: Callable[[str], None]
    map_windows: WindowMap | None = None


@dataclass
class Fit:
    """A fit's estimate, solver record, problem size and fitted joint angles."""

    estimate: ControllerEstimate
    solver: dict[str, Any]
    problem_size: dict[str, int]
    fitted: np.ndarray
