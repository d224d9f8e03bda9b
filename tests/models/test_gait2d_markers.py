"""Points fixed in gait2d's segments: against the points Kane's method derived, and the
fixed points recovered from a record of them."""

from __future__ import annotations

import numpy as np
import pytest

from colloc.models.gait2d import derive
from colloc.models.gait2d_markers import SEGMENTS, local_positions, marker_position
from colloc.models.gait2d_params import load_parameters


@pytest.fixture(scope="module")
def gait():
    return derive()


@pytest.fixture(scope="module")
def constants(gait):
    return gait.constant_array(load_parameters(75.0, 1.8))


def test_points_in_segment_frames_are_the_derived_contact_points(gait, constants):
    s = gait.segment_symbols
    exprs = []
    for side in ("right", "left"):
        for point, x in (("heel", s.x_heel), ("toe", s.x_toe)):
            exprs.append(list(marker_position(gait, f"{side}_foot", (x, -s.h_ankle))))
            exprs.append(list(gait.contact_points[f"{side}_{point}"]))
        # the knee as the thigh's end and as the shank's origin; the ankle likewise
        exprs.append(list(marker_position(gait, f"{side}_thigh", (0.0, -s.l_thigh))))
        exprs.append(list(marker_position(gait, f"{side}_shank", (0.0, 0.0))))
        exprs.append(list(marker_position(gait, f"{side}_shank", (0.0, -s.l_shank))))
        exprs.append(list(marker_position(gait, f"{side}_foot", (0.0, 0.0))))
    f = gait.lambdify(exprs)
    rng = np.random.default_rng(5)
    for _ in range(5):
        q = rng.normal(scale=1.0, size=9)
        values = np.array(f(q, np.zeros(9), np.zeros(6), 0.0, constants), dtype=float)
        pairs = values.reshape(-1, 2, 2)
        np.testing.assert_allclose(pairs[:, 0], pairs[:, 1], atol=1e-12)


def test_a_trunk_point_turns_with_the_trunk_angle(gait, constants):
    f = gait.lambdify(list(marker_position(gait, "trunk", (0.1, 0.5))))
    q = np.zeros(9)
    q[:3] = (0.3, 1.0, np.pi / 2)  # trunk leaning back a quarter turn: its y axis points back
    x, y = (float(v) for v in f(q, np.zeros(9), np.zeros(6), 0.0, constants))
    assert (x, y) == pytest.approx((0.3 - 0.5, 1.0 + 0.1))


def test_fixed_points_are_recovered_from_noisy_markers_with_gaps(gait, constants):
    rng = np.random.default_rng(1)
    n = 400
    t = np.linspace(0.0, 4.0, n)
    q = np.column_stack(
        [1.2 * t, 1.0 + 0.02 * np.sin(6 * t), 0.05 * np.sin(6 * t)]
        + [0.4 * np.sin(6 * t + k) for k in range(6)]
    )
    truth = {"A": ("right_shank", (0.04, -0.2)), "B": ("left_foot", (0.15, -0.06))}
    segments = {name: seg for name, (seg, _) in truth.items()}
    markers = {}
    for name, (seg, local) in truth.items():
        f = gait.lambdify(list(marker_position(gait, seg, local)))
        xy = np.array([f(qk, np.zeros(9), np.zeros(6), 0.0, constants) for qk in q], float)
        xy += rng.normal(scale=1e-3, size=xy.shape)
        xy[100:140] = np.nan  # a gap is left out
        markers[name] = xy
    found = local_positions(gait, constants, q, markers, segments)
    for name, (_, local) in truth.items():
        # the mean of 360 samples of 1 mm noise: about 0.05 mm
        np.testing.assert_allclose(found[name], local, atol=3e-4)


def test_unknown_segments_and_unseen_markers_are_named(gait, constants):
    q = np.zeros((3, 9))
    with pytest.raises(ValueError, match="expected one of"):
        marker_position(gait, "right_arm", (0.0, 0.0))
    with pytest.raises(ValueError, match="found \\['arm'\\]"):
        local_positions(gait, constants, q, {"A": np.zeros((3, 2))}, {"A": "arm"})
    with pytest.raises(ValueError, match="marker A: never seen"):
        local_positions(gait, constants, q, {"A": np.full((3, 2), np.nan)}, {"A": SEGMENTS[0]})
