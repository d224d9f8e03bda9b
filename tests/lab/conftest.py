"""The simulated walk the lab tests record, made once per session: 4 s of closed-loop
walking at 100 Hz on a constant 1.2 m/s belt around the stored 60-node cycle, with its
contact forces at 1000 Hz as well (``substeps=10``) for plates at their own rate."""

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
#: The plates' samples per marker sample of the session's walk (1000 Hz under 100 Hz).
PLATE_SUBSTEPS = 10


@pytest.fixture(scope="session")
def walk(walk_parts) -> ClosedLoopRecord:
    """4 s of walking (3 s to make)."""
    return walk_parts[0]


@pytest.fixture(scope="session")
def walk_parts() -> tuple[ClosedLoopRecord, tuple]:
    """The walk, and what made it: ``(cycle, Tstar, K, dynamics, feedback)``."""
    dynamics = GaitDynamics.build()
    cycle = WalkingCycle.from_npz(CYCLE_FILE)
    feedback = np.arange(1, 18)
    _, Tstar, K, _ = design_controller(
        cycle, 200, R=np.eye(6) / 25.0, dynamics=dynamics, num_samples=241, feedback=feedback
    )
    record = simulate_walking(
        cycle,
        Tstar,
        K,
        4.0,
        None,
        dynamics=dynamics,
        feedback=feedback,
        sample_rate=100.0,
        substeps=PLATE_SUBSTEPS,
    )
    assert not record.fell
    return record, (cycle, Tstar, K, dynamics, feedback)
