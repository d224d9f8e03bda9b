"""One lab record in SI units, as the lab's files hold it: 3-D markers and force plates.

A motion-capture file (TRC, C3D) gives markers in three dimensions in its own units and axes;
a force file (MOT/STO, C3D) gives each plate's force, its point of application and its free
torque at the plate's own rate. :class:`LabRecord` holds either or both in metres, newtons
and newton metres with the axes they came in, and says which axis is up and what was done
to read the file (units converted, time stamps rounded, ...). :mod:`colloc.lab.sagittal`
turns it into the planar :class:`colloc.lab.exports.LabExport` the pipeline reads.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Length units a lab file may state, in metres.
LENGTH_UNITS: dict[str, float] = {"m": 1.0, "cm": 0.01, "mm": 0.001}


@dataclass(frozen=True)
class PlateSeries:
    """One force plate's ground reaction on its own time stamps, in the lab's axes.

    Attributes
    ----------
    time : ndarray, shape (M,)
        [s].
    force : ndarray, shape (M, 3)
        The floor's force on the foot [N].
    point : ndarray, shape (M, 3)
        Its point of application (centre of pressure) [m]; NaN where the plate is unloaded.
    free_torque : ndarray, shape (M, 3)
        The free torque about that point [N m] (about the vertical axis on a level plate).
    """

    time: np.ndarray
    force: np.ndarray
    point: np.ndarray
    free_torque: np.ndarray

    @property
    def sample_rate(self) -> float:
        """Samples per second, from the median time step."""
        return float(1.0 / np.median(np.diff(self.time)))


@dataclass(frozen=True)
class LabRecord:
    """Markers and/or plates of one lab file in SI units.

    Attributes
    ----------
    time : ndarray, shape (N,)
        The markers' time stamps [s] (the plates carry their own); empty without markers.
    markers : dict
        Marker name -> array (N, 3) [m], NaN where the marker was not seen.
    plates : dict
        Plate name -> :class:`PlateSeries`.
    up : int
        Index of the vertical axis (0, 1 or 2; pointing up).
    source : str
        The file read.
    notes : list of str
        What was done to read it that a user should know (units converted, stamps rounded).
    plate_sides : dict
        Plate name -> ``right``/``left`` where the file says which foot it carries.
    columns : dict
        Other numeric channels by name (a belt speed), on :attr:`time`.
    analogs : dict
        Analog channels by label, on :attr:`analog_time`.
    analog_time : ndarray
        [s], the analog channels' own times (empty without them).
    events : list of dict
        Events the file marks: ``label`` (e.g. ``Foot Strike``), ``context`` (``Right``,
        ``Left``, ``General``) and ``time`` [s].
    subject : dict
        What the file says of the subject: ``name``, ``body_mass`` [kg], ``height`` [m],
        where stated.
    """

    time: np.ndarray
    markers: dict[str, np.ndarray]
    plates: dict[str, PlateSeries]
    up: int = 1
    source: str = ""
    notes: list[str] = field(default_factory=list)
    plate_sides: dict[str, str] = field(default_factory=dict)
    columns: dict[str, np.ndarray] = field(default_factory=dict)
    analogs: dict[str, np.ndarray] = field(default_factory=dict)
    analog_time: np.ndarray = field(default_factory=lambda: np.empty(0))
    events: list[dict[str, object]] = field(default_factory=list)
    subject: dict[str, object] = field(default_factory=dict)


def regular_time(time: np.ndarray, rate: float | None, what: str) -> tuple[np.ndarray, list[str]]:
    """Time stamps of a fixed rate, from stamps that may be rounded.

    Files of a fixed rate often write their stamps to 1 ms (60 Hz as 0.016, 0.033, ...):
    uneven by up to half a millisecond, yet of one rate. When every stamp lies within half
    a printed digit... within 1 ms of ``t_0 + k / rate``, the exact stamps replace them
    and a note says so; otherwise the stamps are kept as they are (and the sampling check
    downstream names them).

    Parameters
    ----------
    time : ndarray
        The stamps as read [s].
    rate : float or None
        The rate the file states [Hz]; None to take it from the median step.
    what : str
        The file, for the note.

    Returns
    -------
    time : ndarray
    notes : list of str
    """
    time = np.asarray(time, float)
    if time.size < 2 or not np.all(np.isfinite(time)):
        return time, []
    step = 1.0 / rate if rate else float(np.median(np.diff(time)))
    exact = time[0] + step * np.arange(time.size)
    deviation = float(np.max(np.abs(time - exact)))
    if deviation > 1e-3 or deviation > 0.25 * step:
        return time, []
    if deviation < 1e-9:  # printed in full: nothing to say
        return exact, []
    return exact, [
        f"{what}: time stamps written to {_digits(time)} of a fixed {1 / step:g} Hz (up to "
        f"{deviation * 1e3:.2g} ms off): taken as exactly {1 / step:g} Hz"
    ]


def _digits(time: np.ndarray) -> str:
    for decimals in range(1, 7):
        if np.allclose(time, np.round(time, decimals), atol=1e-9):
            return f"{10.0**-decimals:g} s"
    return "their precision"
