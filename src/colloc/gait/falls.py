"""A lost walk told in words: what fell, on which side, when, in which stride, and what the
belt had just done.

The closed-loop simulation stops when the hip leaves its walking range or a segment turns
over (:mod:`colloc.gait.closed_loop`); a user reading the message needs the joint and its
direction, not the index of a coordinate, and the belt's recent history, since a fall that
follows a large belt excursion is a different finding from one on a steady belt.
"""

from __future__ import annotations

import numpy as np

#: What each coordinate of gait2d is, with the words for its positive and negative
#: directions (:mod:`colloc.models.gait2d`'s conventions).
COORDINATE_WORDS: dict[int, tuple[str, str, str]] = {
    2: ("the trunk", "leaning back", "leaning forward"),
    3: ("the right hip", "flexion", "extension"),
    4: ("the right knee", "hyperextension", "flexion"),
    5: ("the right ankle", "dorsiflexion", "plantarflexion"),
    6: ("the left hip", "flexion", "extension"),
    7: ("the left knee", "hyperextension", "flexion"),
    8: ("the left ankle", "dorsiflexion", "plantarflexion"),
}

#: Seconds of belt history summarised in a fall's message.
BELT_HISTORY = 2.0


def describe_turn(coordinate: int, angle: float, limit: float) -> str:
    """``the left ankle turned to -251 degrees of plantarflexion (beyond +/-180)``.

    Parameters
    ----------
    coordinate : int
        Index of the coordinate in ``q`` (2 to 8).
    angle : float
        Its value [rad].
    limit : float
        The magnitude it passed [rad].

    Returns
    -------
    str
    """
    what, positive, negative = COORDINATE_WORDS[coordinate]
    direction = positive if angle > 0 else negative
    return (
        f"{what} turned to {np.degrees(angle):.0f} degrees of {direction} (beyond +/-"
        f"{np.degrees(limit):.0f})"
    )


def describe_belt(times: np.ndarray, belt_speed: np.ndarray, index: int, nominal: float) -> str:
    """What the belt did in the :data:`BELT_HISTORY` seconds before sample ``index``.

    Parameters
    ----------
    times, belt_speed : ndarray, shape (N,)
        The record's times [s] and belt speed [m/s].
    index : int
        The sample at which the walk was lost.
    nominal : float
        The walking speed the cycle was made for [m/s].

    Returns
    -------
    str
        ``the belt ran 1.19-1.62 m/s in the 2.0 s before (walking speed 1.40 m/s), its
        largest excursion +0.22 m/s 0.9 s before the fall; 1.32 m/s at the fall``.
    """
    recent = slice(int(np.searchsorted(times, times[index] - BELT_HISTORY)), index + 1)
    span = belt_speed[recent]
    largest = int(np.argmax(np.abs(span - nominal)))
    seconds = times[index] - times[recent.start]
    return (
        f"the belt ran {span.min():.2f}-{span.max():.2f} m/s in the {seconds:.1f} s before "
        f"(walking speed {nominal:.2f} m/s), its largest excursion {span[largest] - nominal:+.2f} "
        f"m/s {times[index] - times[recent.start + largest]:.1f} s before the fall; "
        f"{belt_speed[index]:.2f} m/s at the fall"
    )


def describe_fall(
    cause: str, times: np.ndarray, belt_speed: np.ndarray, index: int, strides: int, nominal: float
) -> str:
    """The whole message: ``fell at t = 4.72 s in stride 4: <cause>; <belt>``.

    Parameters
    ----------
    cause : str
        What was lost, in words (e.g. from :func:`describe_turn`).
    times, belt_speed : ndarray, shape (N,)
    index : int
        The sample at which the walk was lost.
    strides : int
        Right heel strikes detected before it (the stride it happened in is one more).
    nominal : float
        The cycle's walking speed [m/s].

    Returns
    -------
    str
    """
    belt = describe_belt(times, belt_speed, index, nominal)
    return f"fell at t = {times[index]:.2f} s in stride {strides + 1}: {cause}; {belt}"
