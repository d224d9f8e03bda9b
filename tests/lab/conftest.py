"""The simulated walk the lab tests record, made once per session: 4 s of closed-loop
walking at 100 Hz on a constant 1.2 m/s belt around the stored 60-node cycle."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from colloc.gait.closed_loop import ClosedLoopRecord, simulate_walking
from colloc.gait.design import design_controller
from colloc.gait.orbit import GaitDynamics
from colloc.gait.walking_cycle import WalkingCycle

CYCLE_FILE = Path(__file__).resolve().parents[1] / "gait" / "data" / "walking_cycle_60.npz"
#: The stored cycle's subject: body mass [kg] and height [m].
SUBJECT = (75.0, 1.8)


@pytest.fixture(scope="session")
def walk() -> ClosedLoopRecord:
    """4 s of walking (3 s to make)."""
    dynamics = GaitDynamics.build()
    cycle = WalkingCycle.from_npz(CYCLE_FILE)
    feedback = np.arange(1, 18)
    _, Tstar, K, _ = design_controller(
        cycle, 200, R=np.eye(6) / 25.0, dynamics=dynamics, num_samples=241, feedback=feedback
    )
    record = simulate_walking(
        cycle, Tstar, K, 4.0, None, dynamics=dynamics, feedback=feedback, sample_rate=100.0
    )
    assert not record.fell
    return record
