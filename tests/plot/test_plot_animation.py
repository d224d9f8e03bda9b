"""Pendulum animation: frame resampling, GIF output and error paths."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from PIL import Image  # noqa: E402

import colloc.plot.animation as animation_module  # noqa: E402
from colloc.plot import (  # noqa: E402
    PlotInputError,
    animate_pendulum_cart,
    frame_coordinates,
    link_positions,
    plot_pendulum_cart,
)

TIMES = np.arange(101) * 0.01  # 0 .. 1 s at 100 Hz


def linear_coordinates(times):
    # Linear in time, so interpolation between samples is exact.
    return np.column_stack([0.2 + 0.5 * times, -0.3 * times, 0.1 + times])


def test_frames_are_in_real_time_and_interpolated():
    frame_times, values = frame_coordinates(TIMES, linear_coordinates(TIMES), fps=30)
    # floor(1.0 s * 30) + 1 frames at k / 30 s.
    assert frame_times.size == 31
    assert np.allclose(frame_times, np.arange(31) / 30, rtol=0, atol=1e-15)
    assert np.allclose(values, linear_coordinates(frame_times), rtol=0, atol=1e-14)


def test_frames_keep_the_last_sample_when_it_falls_on_a_frame():
    frame_times, _ = frame_coordinates(TIMES, linear_coordinates(TIMES), fps=10)
    assert frame_times.size == 11 and frame_times[-1] == pytest.approx(1.0)


def test_max_frames_keeps_the_start():
    frame_times, values = frame_coordinates(TIMES, linear_coordinates(TIMES), 50, max_frames=7)
    assert np.allclose(frame_times, np.arange(7) * 0.02)
    assert values.shape == (7, 3)
    all_times, _ = frame_coordinates(TIMES, linear_coordinates(TIMES), 50, max_frames=None)
    assert all_times.size == 51


def test_gif_has_the_expected_frames(tmp_path):
    coordinates = np.column_stack([0.3 * np.sin(4 * TIMES), 0.4 * np.sin(6 * TIMES), -0.2 * TIMES])
    path = animate_pendulum_cart(
        TIMES, coordinates, [1.0, 0.6], tmp_path / "movie.gif", fps=12, figsize=(3, 2), dpi=40
    )
    assert path == tmp_path / "movie.gif"
    with Image.open(path) as image:
        assert image.format == "GIF"
        assert image.n_frames == 13  # floor(1.0 * 12) + 1
        assert image.size == (120, 80)
    assert [p.name for p in tmp_path.iterdir()] == ["movie.gif"]


def test_gif_respects_max_frames(tmp_path):
    coordinates = np.column_stack([np.sin(3 * TIMES), 0.5 * np.cos(5 * TIMES)])
    path = animate_pendulum_cart(
        TIMES,
        coordinates,
        [1.0],
        tmp_path / "short.gif",
        fps=30,
        max_frames=4,
        figsize=(2, 2),
        dpi=30,
    )
    with Image.open(path) as image:
        assert image.n_frames == 4


def test_mp4_without_ffmpeg_is_refused(tmp_path, monkeypatch):
    monkeypatch.setattr(animation_module.shutil, "which", lambda name: None)
    with pytest.raises(PlotInputError, match="writing .mp4 needs the ffmpeg program on PATH"):
        animate_pendulum_cart(TIMES, linear_coordinates(TIMES), [1.0, 1.0], tmp_path / "m.mp4")
    assert list(tmp_path.iterdir()) == []


def test_unknown_suffix(tmp_path):
    with pytest.raises(PlotInputError, match=r"path: expected a file ending in one of \['.gif'"):
        animate_pendulum_cart(TIMES, linear_coordinates(TIMES), [1.0, 1.0], tmp_path / "m.avi")


def test_input_problems_are_listed_together(tmp_path):
    with pytest.raises(PlotInputError, match="4 problem") as caught:
        frame_coordinates(TIMES[::-1], linear_coordinates(TIMES)[:50], fps=0, max_frames=0)
    message = str(caught.value)
    assert "times: expected strictly increasing values" in message
    assert "coordinates: expected shape (101,) or (101, k)" in message
    assert "fps: expected a positive int, found 0" in message
    assert "max_frames: expected a positive int or None, found 0" in message
    with pytest.raises(PlotInputError, match="coordinates: expected a last dimension of n \\+ 1"):
        animate_pendulum_cart(TIMES, linear_coordinates(TIMES), [1.0], tmp_path / "m.gif")
    assert list(tmp_path.iterdir()) == []


def test_still_draws_cart_and_links_where_link_positions_puts_them():
    coordinates = [0.25, 0.3, -0.6, 1.1]
    lengths = [1.0, 0.8, 0.5]
    figure = plot_pendulum_cart(coordinates, lengths, time=1.5, cart_size=(0.4, 0.2))
    (axis,) = figure.axes
    links = axis.lines[-1]
    assert np.array_equal(links.get_xydata(), link_positions(coordinates, lengths))
    cart = axis.patches[0]
    assert (cart.get_x(), cart.get_y()) == (0.25 - 0.2, -0.1)
    assert (cart.get_width(), cart.get_height()) == (0.4, 0.2)
    assert axis.texts[0].get_text() == "t = 1.500 s"
    # Every mass is inside the axis limits.
    x_low, x_high = axis.get_xlim()
    y_low, y_high = axis.get_ylim()
    points = links.get_xydata()
    assert np.all((points[:, 0] > x_low) & (points[:, 0] < x_high))
    assert np.all((points[:, 1] > y_low) & (points[:, 1] < y_high))


def test_still_errors():
    with pytest.raises(PlotInputError, match="expected one configuration of shape"):
        plot_pendulum_cart([[0.0, 0.1], [0.0, 0.2]], [1.0])
    with pytest.raises(PlotInputError, match="cart_size: expected .width, height., two positive"):
        plot_pendulum_cart([0.0, 0.1], [1.0], cart_size=(0.4, -1.0))
