"""A simulated walking record as a gait-lab trial: canonical columns, sensor noise, metadata.

A gait lab's processing gives joint angles and rates (inverse kinematics), trunk position
and orientation, belt speed and position, heel-strike times and, from inverse dynamics,
joint torques. :func:`record_to_trial` turns a closed-loop simulation record into exactly
that, with seeded Gaussian sensor noise added to every sampled signal, so that the noise-free
truth is never in the trial file. :func:`colloc.gait.metadata.synthetic_metadata` records
what generated the trial (above all the true controller);
:func:`colloc.gait.metadata.controller_from_metadata` reads it back.

Mapping from the gait2d state ``[q, u]`` (see :mod:`colloc.models.gait2d`):

=================================  ========================================
trial column                       source
=================================  ========================================
``right_hip/knee/ankle_angle``     ``qb, qc, qd`` (``q[3:6]``)
``left_hip/knee/ankle_angle``      ``qe, qf, qg`` (``q[6:9]``)
``<side>_<joint>_rate``            ``ub .. ug`` (``u[3:9]``)
``trunk_x``, ``trunk_y``           hip position ``qax, qay``
``trunk_angle``                    ``qa``
``trunk_x/y/angle_rate``           ``uax, uay, ua`` (``u[0:3]``)
``belt_speed``, ``belt_position``  the record's belt signals
``<side>_<joint>_torque``          ``Tb .. Tg``
=================================  ========================================

Both use the same sign conventions, so no sign changes are needed.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, Protocol

import numpy as np
import pandas as pd

from colloc.data.columns import (
    BELT_COLUMNS,
    COP_COLUMNS,
    GRF_COLUMNS,
    JOINT_ANGLE_COLUMNS,
    JOINT_RATE_COLUMNS,
    SIDES,
    SIGNAL_COLUMNS,
    TORQUE_COLUMNS,
    TRUNK_COLUMNS,
    TRUNK_RATE_COLUMNS,
)
from colloc.data.trial import Trial
from colloc.store.ids import package_versions

#: Cut-off [Hz] of the low-pass filter a gait lab applies before differentiating angles;
#: the default rate noise is the angle noise times ``2 pi`` this frequency.
RATE_BANDWIDTH_HZ = 6.0

#: Default sensor-noise standard deviations, SI units, per group of columns.
DEFAULT_NOISE_STD: dict[str, float] = {
    "joint_angle": math.radians(0.25),
    "joint_rate": math.radians(0.25) * 2.0 * math.pi * RATE_BANDWIDTH_HZ,
    "trunk_position": 0.001,
    "trunk_angle": math.radians(0.25),
    "trunk_velocity": 0.001 * 2.0 * math.pi * RATE_BANDWIDTH_HZ,
    "trunk_angle_rate": math.radians(0.25) * 2.0 * math.pi * RATE_BANDWIDTH_HZ,
    "belt_speed": 0.005,
    "belt_position": 0.001,
    "joint_torque": 1.0,
    # an instrumented treadmill's plates: a few newtons of noise, millimetres of centre of
    # pressure while the foot is loaded
    "ground_reaction_force": 5.0,
    "center_of_pressure": 0.005,
}

#: Columns in each noise group.
NOISE_GROUPS: dict[str, tuple[str, ...]] = {
    "joint_angle": JOINT_ANGLE_COLUMNS,
    "joint_rate": JOINT_RATE_COLUMNS,
    "trunk_position": TRUNK_COLUMNS[:2],
    "trunk_angle": TRUNK_COLUMNS[2:],
    "trunk_velocity": TRUNK_RATE_COLUMNS[:2],
    "trunk_angle_rate": TRUNK_RATE_COLUMNS[2:],
    "belt_speed": BELT_COLUMNS[:1],
    "belt_position": BELT_COLUMNS[1:],
    "joint_torque": TORQUE_COLUMNS,
    # after the older groups, so that their draws from the seed stay what they were
    "ground_reaction_force": tuple(c for c in GRF_COLUMNS if c not in COP_COLUMNS),
    "center_of_pressure": COP_COLUMNS,
}

#: Trial columns of gait2d's state ``x = [q, u]``, in state order (trunk x, y, angle, the six
#: joints, then their rates).
STATE_COLUMNS: tuple[str, ...] = (
    TRUNK_COLUMNS + JOINT_ANGLE_COLUMNS + TRUNK_RATE_COLUMNS + JOINT_RATE_COLUMNS
)

#: Column -> the noise group it belongs to (inverse of :data:`NOISE_GROUPS`).
COLUMN_NOISE_GROUP: dict[str, str] = {
    column: group for group, columns in NOISE_GROUPS.items() for column in columns
}

_NUM_COORDINATES = 9
_NUM_STATES = 2 * _NUM_COORDINATES
_NUM_TORQUES = 6


class WalkingRecord(Protocol):
    """What :func:`record_to_trial` reads from a closed-loop simulation record."""

    times: np.ndarray
    states: np.ndarray
    torques: np.ndarray
    belt_speed: np.ndarray
    belt_position: np.ndarray
    right_heel_strikes: np.ndarray
    left_heel_strikes: np.ndarray


#: Extra trial column: the unwrapped phase (cycles) the simulated controller used.
CONTROLLER_PHASE_COLUMN = "controller_phase"


def resolve_noise_std(noise_std: float | Mapping[str, float] | None) -> dict[str, float]:
    """Turn the ``noise_std`` argument into one standard deviation per noise group.

    Parameters
    ----------
    noise_std : float, mapping or None
        ``None``: :data:`DEFAULT_NOISE_STD`. A float: that multiple of the defaults (``0``
        for a noise-free trial). A mapping: group name -> standard deviation [SI units],
        replacing the default of each group it names.

    Returns
    -------
    dict
        Group name -> standard deviation, one entry per group of :data:`NOISE_GROUPS`.

    Raises
    ------
    ValueError
        If a value is negative or not finite, or a group name is unknown (all listed).
    TypeError
        If ``noise_std`` is neither a number, a mapping nor None.
    """
    if noise_std is None:
        return dict(DEFAULT_NOISE_STD)
    if isinstance(noise_std, Mapping):
        problems = [
            f"noise_std: unknown group {key!r}, expected some of {sorted(NOISE_GROUPS)}"
            for key in noise_std
            if key not in NOISE_GROUPS
        ]
        problems += [
            f"noise_std[{key!r}]: expected a non-negative finite number, found {value!r}"
            for key, value in noise_std.items()
            if key in NOISE_GROUPS and not _non_negative(value)
        ]
        if problems:
            raise ValueError("; ".join(problems))
        return {key: float(noise_std.get(key, value)) for key, value in DEFAULT_NOISE_STD.items()}
    if isinstance(noise_std, bool) or not isinstance(noise_std, int | float | np.number):
        raise TypeError(
            f"noise_std: expected a number (multiple of the defaults), a mapping of group -> "
            f"standard deviation, or None, found {type(noise_std).__name__}"
        )
    if not _non_negative(noise_std):
        raise ValueError(f"noise_std: expected a non-negative finite multiple, found {noise_std}")
    return {key: float(noise_std) * value for key, value in DEFAULT_NOISE_STD.items()}


def _non_negative(value: Any) -> bool:
    return bool(
        isinstance(value, int | float | np.number)
        and not isinstance(value, bool)
        and math.isfinite(value)
        and value >= 0
    )


def true_signals(record: WalkingRecord) -> tuple[np.ndarray, pd.DataFrame]:
    """The noise-free canonical signals of a record, at the record's own times.

    Parameters
    ----------
    record : WalkingRecord
        ``times (N,)``, ``states (N, 18)``, ``torques (N, 6)``, ``belt_speed (N,)``,
        ``belt_position (N,)``; and ``ground_reactions (N, 6)`` when it has them.

    Returns
    -------
    time : ndarray, shape (N,)
    signals : DataFrame
        One column per name of :data:`colloc.data.columns.SIGNAL_COLUMNS`, the ground
        reactions only when the record has them.

    Raises
    ------
    ValueError
        If an array has the wrong shape or holds NaN/inf (all problems listed).
    """
    time = np.asarray(record.times, dtype=float)
    states = np.asarray(record.states, dtype=float)
    torques = np.asarray(record.torques, dtype=float)
    belt = {name: np.asarray(getattr(record, name), dtype=float) for name in BELT_COLUMNS}
    problems = []
    if time.ndim != 1 or time.size < 2:
        problems.append(f"record.times: expected shape (N,) with N >= 2, found {time.shape}")
    n = time.shape[0] if time.ndim == 1 else -1
    expected = {
        "states": (states, (n, _NUM_STATES)),
        "torques": (torques, (n, _NUM_TORQUES)),
        **{name: (values, (n,)) for name, values in belt.items()},
    }
    for name, (values, shape) in expected.items():
        if values.shape != shape:
            problems.append(f"record.{name}: expected shape {shape}, found {values.shape}")
    for name, values in (("times", time), *((k, v[0]) for k, v in expected.items())):
        if not np.all(np.isfinite(values)):
            problems.append(f"record.{name}: has {int((~np.isfinite(values)).sum())} NaN/inf")
    if problems:
        raise ValueError("cannot convert the walking record: " + "; ".join(problems))
    q, u = states[:, :_NUM_COORDINATES], states[:, _NUM_COORDINATES:]
    columns = np.column_stack([q[:, 3:], u[:, 3:], q[:, :3], belt["belt_speed"]])
    columns = np.column_stack([columns, belt["belt_position"], u[:, :3], torques])
    names = JOINT_ANGLE_COLUMNS + JOINT_RATE_COLUMNS + TRUNK_COLUMNS + BELT_COLUMNS
    frame = pd.DataFrame(columns, columns=list(names + TRUNK_RATE_COLUMNS + TORQUE_COLUMNS))
    grf = getattr(record, "ground_reactions", None)
    if grf is not None:
        grf = np.asarray(grf, dtype=float)
        if grf.shape != (n, len(GRF_COLUMNS)):
            raise ValueError(
                f"cannot convert the walking record: record.ground_reactions: expected shape "
                f"{(n, len(GRF_COLUMNS))}, found {grf.shape}"
            )
        frame[list(GRF_COLUMNS)] = grf
    return time, frame[[c for c in SIGNAL_COLUMNS if c in frame.columns]]


def _uniform_grid(time: np.ndarray, sample_rate: float) -> np.ndarray:
    # The small tolerance keeps the last sample when the span is a whole number of steps.
    count = int(math.floor((time[-1] - time[0]) * sample_rate + 1e-9)) + 1
    return time[0] + np.arange(count) / sample_rate


def record_to_trial(
    record: WalkingRecord,
    *,
    noise_std: float | Mapping[str, float] | None = None,
    seed: int,
    metadata: Mapping[str, Any] | None = None,
    sample_rate: float | None = 100.0,
) -> Trial:
    """Convert a closed-loop walking record to a trial with simulated sensor noise.

    Parameters
    ----------
    record : WalkingRecord
        E.g. :class:`colloc.gait.closed_loop.ClosedLoopRecord`.
    noise_std : float, mapping or None
        Sensor noise; see :func:`resolve_noise_std` and :data:`DEFAULT_NOISE_STD`.
    seed : int
        Seed of the noise (``numpy.random.default_rng(seed)``), >= 0.
    metadata : mapping, optional
        Further metadata, e.g. from :func:`colloc.gait.metadata.synthetic_metadata`; its
        keys win over the
        ``sample_rate``/``noise`` entries this function adds.
    sample_rate : float or None
        Resample the record onto ``times[0] + k / sample_rate`` by linear interpolation
        (heel strikes after the last sample are dropped); ``None`` keeps the record's
        times, which must then be uniform.

    Returns
    -------
    Trial
        Signals = truth + noise; heel strikes copied from the record; metadata with
        ``sample_rate``, ``noise`` (``seed``, ``std`` per group, ``groups``), ``package_versions``
        and everything in ``metadata``.

    Raises
    ------
    ValueError
        If the record's arrays have wrong shapes or NaNs, ``seed`` is not a non-negative
        int, ``sample_rate`` is not positive, or ``noise_std`` is invalid.
    """
    problems = []
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        problems.append(f"seed: expected a non-negative int, found {seed!r}")
    if sample_rate is not None and not (_non_negative(sample_rate) and sample_rate > 0):
        problems.append(
            f"sample_rate: expected a positive finite number or None, found {sample_rate!r}"
        )
    if problems:
        raise ValueError("; ".join(problems))
    std = resolve_noise_std(noise_std)
    time, truth = true_signals(record)
    if sample_rate is not None:
        grid = _uniform_grid(time, float(sample_rate))
        truth = pd.DataFrame(
            {name: np.interp(grid, time, truth[name].to_numpy()) for name in truth.columns}
        )
        time = grid
    rng = np.random.default_rng(seed)
    measured = truth.copy()
    # The controller's own phase (causal: reset at each detected right heel strike, rising
    # at the previous stride's rate) differs slightly from the phase a lab computes from
    # the next strike; it is kept, noise-free, so identification can use the true one.
    phase = getattr(record, "phase", None)
    if phase is not None:
        measured[CONTROLLER_PHASE_COLUMN] = np.interp(
            time, np.asarray(record.times, float), np.asarray(phase, float)
        )
    for group, names in NOISE_GROUPS.items():
        # One draw per group, always, so a group's noise does not depend on other groups' levels.
        draw = rng.standard_normal((time.size, len(names)))
        if all(name in truth.columns for name in names):
            measured[list(names)] = truth[list(names)].to_numpy() + std[group] * draw
    strikes = {}
    for side in SIDES:
        values = np.asarray(getattr(record, f"{side}_heel_strikes"), dtype=float).ravel()
        strikes[side] = values[(values >= time[0]) & (values <= time[-1])]
    info: dict[str, Any] = {
        "sample_rate": float(1.0 / np.median(np.diff(time)))
        if sample_rate is None
        else sample_rate,
        "noise": {
            "seed": int(seed),
            "std": std,
            "groups": {group: list(names) for group, names in NOISE_GROUPS.items()},
            "rate_bandwidth_hz": RATE_BANDWIDTH_HZ,
        },
        "package_versions": package_versions(),
    }
    info.update(metadata or {})
    return Trial(time, measured, strikes["right"], strikes["left"], info)
