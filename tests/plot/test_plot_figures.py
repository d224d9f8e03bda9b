"""Pendulum-study figures: the plotted data equals the inputs; files are written."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from PIL import Image  # noqa: E402

from colloc.plot import (  # noqa: E402
    PlotInputError,
    plot_constraint_violations,
    plot_force,
    plot_gains,
    plot_states,
    plot_trajectory_comparison,
    save_figure,
)

RNG = np.random.default_rng(11)
TIMES = np.linspace(0.0, 0.49, 50)
STATES = RNG.normal(size=(50, 4))
NAMES = ["q0", "q1", "u0", "u1"]


def test_plot_states_one_axis_per_state():
    figure = plot_states(TIMES, STATES, NAMES)
    assert len(figure.axes) == 4
    for i, axis in enumerate(figure.axes):
        assert len(axis.lines) == 1
        assert np.array_equal(axis.lines[0].get_xdata(), TIMES)
        assert np.array_equal(axis.lines[0].get_ydata(), STATES[:, i])
        assert axis.get_ylabel() == NAMES[i]
    assert figure.axes[-1].get_xlabel() == "time [s]"


def test_plot_force_accepts_a_column():
    force = RNG.normal(size=50)
    for given in (force, force[:, np.newaxis], list(force)):
        figure = plot_force(TIMES, given)
        assert len(figure.axes) == 1 and len(figure.axes[0].lines) == 1
        assert np.array_equal(figure.axes[0].lines[0].get_ydata(), force)


def test_trajectory_comparison_measured_and_identified():
    measured = STATES[:, :2]
    identified = measured + 0.01
    figure = plot_trajectory_comparison(TIMES, measured, identified, ["q0", "q1"])
    assert len(figure.axes) == 2
    for i, axis in enumerate(figure.axes):
        assert len(axis.lines) == 2
        assert np.array_equal(axis.lines[0].get_ydata(), measured[:, i])
        assert np.array_equal(axis.lines[1].get_ydata(), identified[:, i])
        assert [line.get_label() for line in axis.lines] == ["measured", "identified"]


def test_constraint_violations_per_equation():
    defects = RNG.normal(scale=1e-10, size=(49, 4))
    figure = plot_constraint_violations(TIMES[1:], defects, ["kin 0", "kin 1", "dyn 0", "dyn 1"])
    assert len(figure.axes) == 4
    for i, axis in enumerate(figure.axes):
        assert np.array_equal(axis.lines[0].get_xdata(), TIMES[1:])
        assert np.array_equal(axis.lines[0].get_ydata(), defects[:, i])


def test_gains_with_error_bars():
    known = np.array([[-4.71764346, 19.67083668, -3.69402157, 5.57114809]])
    identified = np.array([[-3.45783597, 17.0274554, -3.27007286, 5.24318706]])
    std_errors = np.array([[0.1, 0.5, 0.05, 0.2]])
    figure = plot_gains(known, identified, std_errors)
    (axis,) = figure.axes
    assert np.array_equal(axis.lines[0].get_ydata(), identified.ravel())
    assert np.array_equal(axis.lines[0].get_xdata(), [0, 1, 2, 3])
    assert np.array_equal(axis.lines[-1].get_ydata(), known.ravel())
    segments = axis.collections[0].get_segments()
    for i, segment in enumerate(segments):
        lower, upper = sorted(segment[:, 1])
        assert lower == pytest.approx(identified[0, i] - 1.96 * std_errors[0, i], rel=1e-12)
        assert upper == pytest.approx(identified[0, i] + 1.96 * std_errors[0, i], rel=1e-12)
        assert np.all(segment[:, 0] == i)
    labels = [tick.get_text() for tick in axis.get_xticklabels()]
    assert labels == ["K[0,0]", "K[0,1]", "K[0,2]", "K[0,3]"]


def test_gains_without_known_or_errors():
    figure = plot_gains(None, [1.0, 2.0, 3.0], names=["a", "b", "c"])
    (axis,) = figure.axes
    assert len(axis.lines) == 1 and len(axis.collections) == 0
    assert np.array_equal(axis.lines[0].get_ydata(), [1.0, 2.0, 3.0])
    assert [tick.get_text() for tick in axis.get_xticklabels()] == ["a", "b", "c"]


def test_save_figure_writes_png_and_svg(tmp_path):
    figure = plot_states(TIMES, STATES[:, :1], ["q0"])
    paths = save_figure(figure, tmp_path / "figures", "states", dpi=50)
    assert [p.name for p in paths] == ["states.png", "states.svg"]
    with Image.open(paths[0]) as image:
        assert image.format == "PNG"
        width, height = figure.get_size_inches() * 50
        assert image.size == (round(width), round(height))
    svg = paths[1].read_text()
    assert svg.startswith("<?xml") and "<svg" in svg
    assert sorted(p.name for p in (tmp_path / "figures").iterdir()) == ["states.png", "states.svg"]


def test_save_figure_errors(tmp_path):
    figure = plot_force(TIMES, STATES[:, 0])
    with pytest.raises(PlotInputError, match="2 problem") as caught:
        save_figure(figure, tmp_path, "../up", formats=("png", "docx"))
    message = str(caught.value)
    assert "stem: expected a file name without directories, found '../up'" in message
    assert "formats: expected some of" in message and "found ['docx']" in message
    with pytest.raises(PlotInputError, match="formats: expected a sequence of format names"):
        save_figure(figure, tmp_path, "x", formats="png")
    with pytest.raises(PlotInputError, match="fig: expected a matplotlib Figure, found str"):
        save_figure("figure", tmp_path, "x")
    assert list(tmp_path.iterdir()) == []


def test_transposed_states_are_reported_with_a_hint():
    with pytest.raises(PlotInputError, match="it looks transposed"):
        plot_states(TIMES, STATES.T, NAMES)


def test_shape_problems_are_listed_together():
    with pytest.raises(PlotInputError, match="2 problem") as caught:
        plot_trajectory_comparison(TIMES, STATES[:, :2], STATES[:40, :2], ["q0"])
    message = str(caught.value)
    assert "identified: expected shape (50,) or (50, k)" in message
    assert "names: expected 2 labels (one per column), found 1" in message
    with pytest.raises(
        PlotInputError, match=r"identified: expected the shape of measured \(50, 2\)"
    ):
        plot_trajectory_comparison(TIMES, STATES[:, :2], STATES[:, :3], ["q0", "q1"])
    with pytest.raises(PlotInputError, match="force: expected one column, found 2"):
        plot_force(TIMES, STATES[:, :2])
    with pytest.raises(PlotInputError, match=r"pass times\[1:\] when the first node"):
        plot_constraint_violations(TIMES, STATES[1:], NAMES)
    with pytest.raises(PlotInputError, match="times: expected a 1-D array, found shape"):
        plot_states(STATES, STATES, NAMES)
    with pytest.raises(PlotInputError, match="names: expected a sequence of 4 str, found str"):
        plot_states(TIMES, STATES, "q0")


def test_gain_problems_are_listed_together():
    with pytest.raises(PlotInputError, match="3 problem") as caught:
        plot_gains([1.0, 2.0], [1.0, 2.0, 3.0], [-0.1, 0.1, 0.1], interval=0)
    message = str(caught.value)
    assert "known: expected the shape of identified (3,), found (2,)" in message
    assert "std_errors: expected non-negative values" in message
    assert "interval: expected a positive number, found 0" in message
    with pytest.raises(PlotInputError, match="identified: expected an array of numbers"):
        plot_gains(None, ["a", "b"])
