"""Animation of the n-link pendulum on a cart (GIF with Pillow, MP4 with ffmpeg)."""

from __future__ import annotations

import logging
import math
import os
import secrets
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.animation import AbstractMovieWriter, FFMpegWriter, PillowWriter
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from colloc.plot.common import PlotInputError, as_columns, as_times, raise_if_any
from colloc.plot.geometry import link_positions

logger = logging.getLogger(__name__)


def _pillow(fps: int) -> AbstractMovieWriter:
    return PillowWriter(fps=fps)


def _ffmpeg(fps: int) -> AbstractMovieWriter:
    if shutil.which("ffmpeg") is None:
        raise PlotInputError(
            [
                "path: writing .mp4 needs the ffmpeg program on PATH, which was not found; "
                "install ffmpeg or use a .gif path"
            ]
        )
    return FFMpegWriter(fps=fps)


#: File suffix -> writer factory.
WRITERS: dict[str, Callable[[int], AbstractMovieWriter]] = {".gif": _pillow, ".mp4": _ffmpeg}


def frame_coordinates(
    times: Any, coordinates: Any, fps: int = 30, max_frames: int | None = 300
) -> tuple[np.ndarray, np.ndarray]:
    """Resample a trajectory to video frames in real time.

    Frames are at ``times[0] + k / fps`` up to ``times[-1]``; coordinates are linearly
    interpolated between samples. When that gives more than ``max_frames`` frames, only
    the first ``max_frames`` are kept (the video shows the start of the record in real
    time rather than all of it sped up).

    Parameters
    ----------
    times : array_like, shape (N,)
        Increasing sample times in seconds.
    coordinates : array_like, shape (N, m)
        One row per sample.
    fps : int, optional
        Frames per second.
    max_frames : int or None, optional
        Upper bound on the number of frames; ``None`` for no bound.

    Returns
    -------
    frame_times : numpy.ndarray, shape (F,)
    frame_values : numpy.ndarray, shape (F, m)

    Raises
    ------
    PlotInputError
        If shapes disagree, times do not increase, or ``fps``/``max_frames`` are not
        positive (all problems listed).
    """
    problems: list[str] = []
    t = as_times(times, problems)
    q = as_columns(coordinates, t.size, problems, "coordinates")
    if t.size and np.any(np.diff(t) <= 0):
        problems.append("times: expected strictly increasing values")
    if t.size == 0 and not problems:
        problems.append("times: expected at least one sample, found none")
    if isinstance(fps, bool) or not (isinstance(fps, int | np.integer) and fps > 0):
        problems.append(f"fps: expected a positive int, found {fps!r}")
    if max_frames is not None and (
        isinstance(max_frames, bool)
        or not (isinstance(max_frames, int | np.integer) and max_frames > 0)
    ):
        problems.append(f"max_frames: expected a positive int or None, found {max_frames!r}")
    raise_if_any(problems)
    # The small tolerance keeps the last frame when the duration is a whole number of frames.
    count = int(math.floor((t[-1] - t[0]) * fps + 1e-9)) + 1
    if max_frames is not None and count > max_frames:
        logger.info(
            "animation: keeping the first %d of %d frames (%.2f s of %.2f s)",
            max_frames,
            count,
            max_frames / fps,
            t[-1] - t[0],
        )
        count = max_frames
    frame_times = t[0] + np.arange(count) / fps
    frame_values = np.column_stack([np.interp(frame_times, t, column) for column in q.T])
    return frame_times, frame_values.reshape(count, q.shape[1])


def _cart_size(lengths: Any, cart_size: tuple[float, float] | None) -> tuple[float, float]:
    if cart_size is not None:
        size = np.asarray(cart_size, dtype=float)
        if size.shape != (2,) or not np.all(np.isfinite(size) & (size > 0)):
            raise PlotInputError(
                [f"cart_size: expected (width, height), two positive numbers, found {cart_size!r}"]
            )
        return float(size[0]), float(size[1])
    total_length = float(np.sum(lengths))
    return 0.4 * total_length, 0.2 * total_length


class _Scene:
    """The drawing of the cart and links, with fixed limits that contain every frame."""

    def __init__(
        self,
        positions: np.ndarray,
        cart_size: tuple[float, float],
        figsize: tuple[float, float],
        dpi: float,
    ) -> None:
        width, height = cart_size
        reach = float(np.max(np.abs(positions[..., 1]))) if positions.size else 1.0
        margin = 0.1 * reach + height
        self.cart_width = width
        self.figure = Figure(figsize=figsize, dpi=dpi)
        # Fixed axes placement: a layout engine would re-solve the layout on every frame.
        self.axis = self.figure.add_axes((0.08, 0.1, 0.88, 0.85))
        self.axis.set_xlim(
            positions[..., 0].min() - width / 2 - margin,
            positions[..., 0].max() + width / 2 + margin,
        )
        self.axis.set_ylim(
            min(positions[..., 1].min(), -height / 2) - margin,
            max(positions[..., 1].max(), height / 2) + margin,
        )
        self.axis.set_aspect("equal", adjustable="box")
        self.axis.axhline(-height / 2, color="0.6", linewidth=1.0)
        self.axis.set_xlabel("x")
        self.cart = Rectangle((0.0, -height / 2), width, height, facecolor="C0", edgecolor="k")
        self.axis.add_patch(self.cart)
        (self.links,) = self.axis.plot([], [], "-o", color="k", markerfacecolor="C3", linewidth=2.0)
        self.clock = self.axis.text(0.02, 0.95, "", transform=self.axis.transAxes, va="top")

    def update(self, frame: np.ndarray, moment: float | None) -> None:
        self.cart.set_x(frame[0, 0] - self.cart_width / 2)
        self.links.set_data(frame[:, 0], frame[:, 1])
        self.clock.set_text("" if moment is None else f"t = {moment:.3f} s")


def plot_pendulum_cart(
    coordinates: Any,
    lengths: Any,
    time: float | None = None,
    cart_size: tuple[float, float] | None = None,
    figsize: tuple[float, float] = (6.0, 4.0),
) -> Figure:
    """Draw the pendulum on a cart in one configuration (a still of the animation).

    Parameters
    ----------
    coordinates : array_like, shape (n + 1,)
        ``[q0, q1, ..., qn]``: cart position and absolute link angles from the upward
        vertical.
    lengths : array_like, shape (n,)
        Link lengths.
    time : float or None, optional
        Time shown in the corner; ``None`` shows none.
    cart_size : (float, float) or None, optional
        Cart width and height; default 0.4 and 0.2 times the total link length.
    figsize : (float, float), optional
        Figure size in inches.

    Returns
    -------
    matplotlib.figure.Figure
        One axis: ``axes[0].patches[0]`` is the cart, ``axes[0].lines[-1]`` the links
        from the pivot through every mass.

    Raises
    ------
    PlotInputError
        If ``coordinates`` is not one configuration matching ``lengths``.
    """
    positions = link_positions(coordinates, lengths)
    if positions.ndim != 2:
        raise PlotInputError(
            [
                f"coordinates: expected one configuration of shape (n + 1,), found shape "
                f"{np.shape(coordinates)}; use animate_pendulum_cart for trajectories"
            ]
        )
    scene = _Scene(positions, _cart_size(lengths, cart_size), figsize, 100.0)
    scene.update(positions, time)
    return scene.figure


def animate_pendulum_cart(
    times: Any,
    coordinates: Any,
    lengths: Any,
    path: str | Path,
    fps: int = 30,
    max_frames: int | None = 300,
    cart_size: tuple[float, float] | None = None,
    figsize: tuple[float, float] = (6.0, 4.0),
    dpi: float = 80.0,
) -> Path:
    """Write an animation of the pendulum on a cart.

    The cart is a rectangle centred on ``(q0, 0)``; the links are drawn from the pivot at
    the cart's centre to the masses at their ends, with positions from
    :func:`colloc.plot.geometry.link_positions`.

    Parameters
    ----------
    times : array_like, shape (N,)
        Increasing sample times in seconds.
    coordinates : array_like, shape (N, n + 1)
        ``[q0, q1, ..., qn]`` per sample: cart position and absolute link angles from the
        upward vertical.
    lengths : array_like, shape (n,)
        Link lengths.
    path : str or Path
        Output file, ``.gif`` (Pillow) or ``.mp4`` (needs ``ffmpeg`` on PATH). Written
        under a temporary name and renamed when complete.
    fps : int, optional
        Frames per second; the video plays in real time.
    max_frames : int or None, optional
        Keep at most this many frames (the start of the record); ``None`` for all.
    cart_size : (float, float) or None, optional
        Cart width and height; default 0.4 and 0.2 times the total link length.
    figsize : (float, float), optional
        Figure size in inches.
    dpi : float, optional
        Pixels per inch of the frames.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    PlotInputError
        If the inputs disagree in shape, the suffix is not supported, or ffmpeg is missing
        for ``.mp4`` (all input problems listed).
    """
    target = Path(path)
    factory = WRITERS.get(target.suffix.lower())
    if factory is None:
        raise PlotInputError(
            [f"path: expected a file ending in one of {sorted(WRITERS)}, found {str(path)!r}"]
        )
    frame_times, frame_values = frame_coordinates(times, coordinates, fps, max_frames)
    positions = link_positions(frame_values, lengths)
    writer = factory(int(fps))
    scene = _Scene(positions, _cart_size(lengths, cart_size), figsize, dpi)

    temporary = target.with_name(f".{target.stem}.{secrets.token_hex(8)}{target.suffix}")
    target.parent.mkdir(parents=True, exist_ok=True)
    try:
        with writer.saving(scene.figure, str(temporary), dpi):
            for moment, frame in zip(frame_times, positions, strict=True):
                scene.update(frame, moment)
                writer.grab_frame()
        os.replace(temporary, target)
    finally:
        temporary.unlink(missing_ok=True)
    return target
