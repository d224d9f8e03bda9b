"""Gait figures and the stick-figure animation against hand-computed values."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
import sympy as sm  # noqa: E402
import sympy.physics.vector as vec  # noqa: E402
from PIL import Image  # noqa: E402

from colloc.models.gait2d_params import load_parameters  # noqa: E402
from colloc.models.gait2d_points import (  # noqa: E402
    POINT_NAMES,
    StickFigureGeometry,
    stick_figure_points,
)
from colloc.plot.common import PlotInputError  # noqa: E402
from colloc.plot.gait import (  # noqa: E402
    plot_contact_forces,
    plot_joint_angles_by_cycle,
    strides_by_cycle,
)
from colloc.plot.gait_animation import animate_gait, plot_stick_figure  # noqa: E402

GEOMETRY = StickFigureGeometry(
    trunk_length=0.5,
    thigh_length=0.44,
    shank_length=0.43,
    ankle_height=0.07,
    heel_x=-0.06,
    toe_x=0.15,
)
NAMES = ["right hip", "right knee", "right ankle", "left hip", "left knee", "left ankle"]


def band_limits(axis, x):
    """Lower and upper edge of the fill_between band at each x (from its polygon)."""
    vertices = axis.collections[0].get_paths()[0].vertices
    lower, upper = [], []
    for value in x:
        at = vertices[np.isclose(vertices[:, 0], value, rtol=0, atol=1e-9), 1]
        lower.append(at.min())
        upper.append(at.max())
    return np.array(lower), np.array(upper)


def test_strides_are_resampled_to_percent_of_cycle():
    # Linear signal y = t: stride k sampled at s_k + d_k c/100 gives exactly those times.
    time = np.linspace(0.0, 5.0, 501)
    strikes = np.array([0.5, 1.5, 2.7, 3.6])
    percent, strides = strides_by_cycle(time, time, strikes, num_samples=11)
    np.testing.assert_allclose(percent, np.arange(0, 101, 10))
    expected = strikes[:-1, None] + np.diff(strikes)[:, None] * np.linspace(0, 1, 11)
    assert strides.shape == (3, 11, 1)
    np.testing.assert_allclose(strides[:, :, 0], expected, atol=1e-12)


def test_mean_and_zero_sd_band_for_exactly_periodic_angles():
    period = 1.25
    time = np.arange(0, 8.0, 0.001)
    strikes = 0.3 + period * np.arange(6)
    amplitudes = np.radians([20, 30, 10, 20, 30, 10])
    angles = amplitudes * np.sin(2 * np.pi * (time[:, None] - 0.3) / period + np.arange(6))
    figure = plot_joint_angles_by_cycle(time, angles, strikes, NAMES, num_samples=51)
    axes = [a for a in figure.axes if a.get_visible()]
    assert len(axes) == 6
    c = np.linspace(0, 100, 51)
    by_title = {axis.get_title().split(" (")[0]: axis for axis in axes}
    for j, name in enumerate(NAMES):
        axis = by_title[name]
        x, mean = axis.lines[0].get_data()
        np.testing.assert_allclose(x, c)
        # Every stride is the same sinusoid of the cycle fraction; shown in degrees.
        hand = np.degrees(amplitudes[j]) * np.sin(2 * np.pi * c / 100 + j)
        np.testing.assert_allclose(mean, hand, atol=2e-3)  # 1 ms sampling, linear interp
        lower, upper = band_limits(axis, x)
        # Band = mean +- sd with sd ~ 0 (strides identical up to interpolation error).
        assert np.max(upper - lower) < 1e-3
        np.testing.assert_allclose(0.5 * (lower + upper), mean, atol=1e-12)
        assert "(5 strides)" in axis.get_title()
    # Column-major filling: the right leg in the left column (figure.axes is row-major).
    assert [a.get_title().split(" (")[0] for a in axes[:2]] == ["right hip", "left hip"]


def test_mean_and_sd_over_strides_with_different_amplitudes():
    # Stride k has amplitude a_k, so mean and sample sd at each c are those of a_k times
    # sin(2 pi c); per-column strike lists (left strikes shifted) are honoured.
    time = np.arange(0, 4.0, 0.0005)
    strikes = np.array([0.0, 1.0, 2.0, 3.0])
    a = np.array([1.0, 2.0, 4.0])
    stride = np.clip(np.floor(time).astype(int), 0, 2)
    y = a[stride] * np.sin(2 * np.pi * time)
    left_strikes = strikes[:3] + 0.5
    figure = plot_joint_angles_by_cycle(
        time,
        np.column_stack([y, y]),
        [strikes, left_strikes],
        ["r", "l"],
        in_degrees=False,
        num_samples=21,
        ncols=1,
    )
    c = np.linspace(0, 1, 21)
    x, mean = figure.axes[0].lines[0].get_data()
    np.testing.assert_allclose(x, 100 * c)
    # Hand values; tolerance for the 0.5 ms linear interpolation near the stride ends.
    hand_mean = a.mean() * np.sin(2 * np.pi * c)
    hand_sd = np.std(a, ddof=1) * np.abs(np.sin(2 * np.pi * c))
    np.testing.assert_allclose(mean, hand_mean, atol=5e-2)
    np.testing.assert_allclose(mean[1:-1], hand_mean[1:-1], atol=1e-6)
    lower, upper = band_limits(figure.axes[0], x)
    np.testing.assert_allclose(0.5 * (upper - lower)[1:-1], hand_sd[1:-1], atol=1e-6)
    assert "(2 strides)" in figure.axes[1].get_title()


def test_joint_angle_plot_errors():
    time = np.linspace(0, 2, 201)
    with pytest.raises(PlotInputError, match=r"(?s)angles: expected shape \(201,\).*names"):
        plot_joint_angles_by_cycle(time, np.zeros((200, 2)), [0.5, 1.5], ["a", "b", "c"])
    with pytest.raises(PlotInputError, match=r"heel_strikes: expected at least 2 heel strikes"):
        plot_joint_angles_by_cycle(time, np.zeros(201), [0.5, 2.5], ["a"])
    with pytest.raises(PlotInputError, match=r"heel_strikes\[1\]: expected strictly increasing"):
        plot_joint_angles_by_cycle(time, np.zeros((201, 2)), [[0.5, 1.5], [1.5, 0.5]], ["a", "b"])
    with pytest.raises(PlotInputError, match=r"list of 2 arrays.*found a list of 3"):
        plot_joint_angles_by_cycle(time, np.zeros((201, 2)), [[0.5, 1.5]] * 3, ["a", "b"])


def test_contact_forces_grouped_in_pairs_and_windowed():
    time = np.linspace(0, 10, 1001)
    forces = np.column_stack([np.sin(time + k) * (k + 1) for k in range(8)])
    names = [f"{p} F{a}" for p in ("rh", "rt", "lh", "lt") for a in "xy"]
    figure = plot_contact_forces(time, forces, names, window=(2.0, 4.0))
    assert len(figure.axes) == 4
    for i, axis in enumerate(figure.axes):
        assert len(axis.lines) == 2
        for j, line in enumerate(axis.lines):
            x, y = line.get_data()
            keep = (time >= 2.0) & (time <= 4.0)
            np.testing.assert_array_equal(x, time[keep])
            np.testing.assert_array_equal(y, forces[keep, 2 * i + j])
            assert line.get_label() == names[2 * i + j]


def test_contact_force_errors():
    time = np.linspace(0, 1, 11)
    with pytest.raises(
        PlotInputError, match=r"(?s)expected 8 labels.*per_axis.*window: no samples"
    ):
        plot_contact_forces(time, np.zeros((11, 8)), ["a"], per_axis=0, window=(5.0, 6.0))
    with pytest.raises(PlotInputError, match=r"window: expected \(start, end\)"):
        plot_contact_forces(time, np.zeros((11, 2)), ["a", "b"], window=(1.0, 0.0))


def test_standing_straight_points():
    q = np.array([0.3, 0.95, 0, 0, 0, 0, 0, 0, 0])
    points = stick_figure_points(q, GEOMETRY)
    assert set(points) == set(POINT_NAMES)
    hand = {
        "hip": (0.3, 0.95),
        "trunk_top": (0.3, 1.45),
        "right_knee": (0.3, 0.51),
        "right_ankle": (0.3, 0.08),
        "right_heel": (0.24, 0.01),
        "right_toe": (0.45, 0.01),
    }
    for name, xy in hand.items():
        np.testing.assert_allclose(points[name], xy, atol=1e-15)
        other = name.replace("right", "left")
        np.testing.assert_allclose(points[other], xy, atol=1e-15)


def test_right_angle_configuration_by_hand():
    # Trunk upright, right hip flexed 90 deg (thigh forward, horizontal), knee flexed 90 deg
    # (qc = -pi/2: shank hangs straight down), ankle 0 (foot flat, toes forward).
    q = np.array([0.0, 1.0, 0.0, np.pi / 2, -np.pi / 2, 0.0, 0.0, 0.0, np.pi / 2])
    points = stick_figure_points(q, GEOMETRY)
    np.testing.assert_allclose(points["right_knee"], (0.44, 1.0), atol=1e-15)
    np.testing.assert_allclose(points["right_ankle"], (0.44, 0.57), atol=1e-15)
    np.testing.assert_allclose(points["right_toe"], (0.59, 0.50), atol=1e-15)
    # Left ankle dorsiflexed 90 deg: the foot points straight up, the sole 0.07 m in front.
    np.testing.assert_allclose(points["left_toe"], (0.07, 0.13 + 0.15), atol=1e-15)
    np.testing.assert_allclose(points["left_heel"], (0.07, 0.13 - 0.06), atol=1e-15)


def test_points_agree_with_sympy_frames_for_random_configurations():
    # Second method: the gait2d kinematic chain built with sympy.physics.vector.
    syms = sm.symbols("qax qay qa qb qc qd qe qf qg")
    ground = vec.ReferenceFrame("N")
    origin = vec.Point("O")
    hip = origin.locatenew("hip", syms[0] * ground.x + syms[1] * ground.y)
    trunk = ground.orientnew("A", "Axis", (syms[2], ground.z))
    exprs = {"hip": hip, "trunk_top": hip.locatenew("top", GEOMETRY.trunk_length * trunk.y)}
    for side, start in (("right", 3), ("left", 6)):
        thigh = trunk.orientnew(f"{side}T", "Axis", (syms[start], trunk.z))
        shank = thigh.orientnew(f"{side}S", "Axis", (syms[start + 1], thigh.z))
        foot = shank.orientnew(f"{side}F", "Axis", (syms[start + 2], shank.z))
        knee = hip.locatenew("k", -GEOMETRY.thigh_length * thigh.y)
        ankle = knee.locatenew("a", -GEOMETRY.shank_length * shank.y)
        exprs[f"{side}_knee"] = knee
        exprs[f"{side}_ankle"] = ankle
        for name, along in (("heel", GEOMETRY.heel_x), ("toe", GEOMETRY.toe_x)):
            exprs[f"{side}_{name}"] = ankle.locatenew(
                name, along * foot.x - GEOMETRY.ankle_height * foot.y
            )
    functions = {
        name: sm.lambdify(
            [syms], [p.pos_from(origin).dot(ground.x), p.pos_from(origin).dot(ground.y)]
        )
        for name, p in exprs.items()
    }
    q = np.random.default_rng(1).uniform(-1.5, 1.5, size=(5, 9))
    points = stick_figure_points(q, GEOMETRY)
    for name, f in functions.items():
        reference = np.array([f(row) for row in q])
        np.testing.assert_allclose(points[name], reference, atol=1e-13)


def test_geometry_from_parameters_and_errors():
    params = load_parameters(75.0, 1.8)
    geometry = StickFigureGeometry.from_parameters(params)
    assert geometry.thigh_length == pytest.approx(0.245 * 1.8)
    assert geometry.heel_x == pytest.approx(-0.03333 * 1.8)
    with pytest.raises(ValueError, match=r"(?s)thigh_length: expected a positive.*heel_x < toe_x"):
        StickFigureGeometry(0.5, -0.4, 0.4, 0.07, 0.2, 0.1)
    with pytest.raises(ValueError, match=r"(?s)q: expected a last dimension of 9.*geometry"):
        stick_figure_points(np.zeros(8), "tall")  # type: ignore[arg-type]
    with pytest.raises(PlotInputError, match=r"q: expected one configuration of shape \(9,\)"):
        plot_stick_figure(np.zeros((2, 9)), GEOMETRY)


def test_still_draws_the_computed_points():
    q = np.array([0.0, 0.95, 0.1, 0.3, -0.2, 0.1, -0.3, -0.1, 0.0])
    figure = plot_stick_figure(q, GEOMETRY)
    _ground, _markers, trunk, right, _left = figure.axes[0].lines
    points = stick_figure_points(q, GEOMETRY)
    np.testing.assert_allclose(np.column_stack(right.get_data())[2], points["right_ankle"])
    np.testing.assert_allclose(np.column_stack(trunk.get_data())[1], points["trunk_top"])


def test_gif_has_real_time_frames(tmp_path):
    times = np.arange(101) * 0.01
    q = np.zeros((101, 9))
    q[:, 1] = 0.95
    q[:, 3] = 0.3 * np.sin(2 * np.pi * times)
    path = animate_gait(
        times,
        q,
        GEOMETRY,
        tmp_path / "walk.gif",
        belt_position=1.2 * times,
        fps=10,
        figsize=(2.0, 2.0),
        dpi=40,
    )
    with Image.open(path) as image:
        assert image.format == "GIF"
        assert image.n_frames == 11  # floor(1.0 s * 10) + 1
        assert image.size == (80, 80)
    assert [p.name for p in tmp_path.iterdir()] == ["walk.gif"]


def test_animation_errors(tmp_path):
    with pytest.raises(
        PlotInputError, match=r"(?s)path: expected a file ending in .gif.*q: expected"
    ):
        animate_gait([0, 1], np.zeros((2, 8)), GEOMETRY, tmp_path / "walk.mp4")
    with pytest.raises(PlotInputError, match=r"belt_position: expected shape \(2,\)"):
        animate_gait([0, 1], np.zeros((2, 9)), GEOMETRY, tmp_path / "w.gif", belt_position=[0.0])
    assert not any(tmp_path.iterdir())
