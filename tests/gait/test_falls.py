"""A lost walk told in words (colloc.gait.falls and the closed loop's stop)."""

from __future__ import annotations

import numpy as np
import pytest

from colloc.gait.closed_loop import MAX_SEGMENT_ANGLE, _lost
from colloc.gait.falls import describe_belt, describe_fall, describe_turn


@pytest.mark.parametrize(
    ("coordinate", "degrees", "words"),
    [
        (8, -251.0, "the left ankle turned to -251 degrees of plantarflexion"),
        (5, 190.0, "the right ankle turned to 190 degrees of dorsiflexion"),
        (4, -185.0, "the right knee turned to -185 degrees of flexion"),
        (6, 200.0, "the left hip turned to 200 degrees of flexion"),
        (2, -181.0, "the trunk turned to -181 degrees of leaning forward"),
    ],
)
def test_a_turned_joint_is_named_with_its_side_and_direction(coordinate, degrees, words):
    text = describe_turn(coordinate, np.radians(degrees), MAX_SEGMENT_ANGLE)
    assert text == f"{words} (beyond +/-180)"


def test_the_belt_history_names_its_range_and_largest_excursion():
    times = np.arange(0.0, 10.0, 0.01)
    belt = np.full(times.size, 1.2)
    belt[(times > 7.5) & (times < 8.0)] = 1.55  # a surge 1.5-2 s before the fall at 9.5 s
    text = describe_belt(times, belt, int(np.searchsorted(times, 9.5)), 1.2)
    assert text.startswith("the belt ran 1.20-1.55 m/s in the 2.0 s before (walking speed 1.20")
    assert "its largest excursion +0.35 m/s 2.0 s before the fall; 1.20 m/s at the fall" in text


def test_the_message_counts_the_stride_the_fall_happened_in():
    times = np.arange(0.0, 3.0, 0.01)
    text = describe_fall("the hip dropped", times, np.full(times.size, 1.0), 250, 2, 1.0)
    assert text.startswith("fell at t = 2.50 s in stride 3: the hip dropped; the belt ran")


def test_the_stop_reads_the_hip_then_the_joints():
    state = np.zeros(18)
    state[1] = 0.9
    assert _lost(state, (0.8, 1.0)) is None
    state[1] = 0.7
    assert _lost(state, (0.8, 1.0)) == "the hip dropped to 0.700 m (walking range 0.800-1.000 m)"
    state[1], state[8] = 0.9, -3.5
    assert _lost(state, (0.8, 1.0)).startswith("the left ankle turned to -201 degrees")
