"""A simulated walking record as a gait-lab trial: canonical columns, sensor noise, metadata.

A gait lab's processing gives joint angles and rates (inverse kinematics), trunk position
and orientation, belt speed and position, heel-strike times and, from inverse dynamics,
joint torques. :func:`record_to_trial` turns a closed-loop simulation record into exactly
that, with seeded Gaussian sensor noise added to every sampled signal, so that the noise-free
truth is never in the trial file. :func:`synthetic_metadata` records what generated the
trial (above all the true controller); :func:`controller_from_metadata` reads it back.

Mapping from the gait2d state ``[q, u]`` (see :mod:`colloc.models.gait2d`):

=================================  ========================================
trial column                       source
=================================  ========================================
``right_hip/knee/ankle_angle``     ``qb, qc, qd`` (``q[3:6]``)
``left_hip/knee/ankle_angle``      ``qe, qf, qg`` (``q[6:9]``)
``<side>_<joint>_rate``            ``ub .. ug`` (``u[3:9]``)
``trunk_x``, ``trunk_y``           hip position ``qax, qay``
``trunk_angle``                    ``qa``
``belt_speed``, ``belt_position``  the record's belt signals
``<side>_<joint>_torque``          ``Tb .. Tg``
=================================  ========================================

Both use the same sign conventions, so no sign changes are needed.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, Protocol

import numpy as np
import pandas as pd

from colloc.data.columns import (
    BELT_COLUMNS,
    JOINT_ANGLE_COLUMNS,
    JOINT_RATE_COLUMNS,
    SIDES,
    SIGNAL_COLUMNS,
    TORQUE_COLUMNS,
    TRUNK_COLUMNS,
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
    "belt_speed": 0.005,
    "belt_position": 0.001,
    "joint_torque": 1.0,
}

#: Columns in each noise group.
NOISE_GROUPS: dict[str, tuple[str, ...]] = {
    "joint_angle": JOINT_ANGLE_COLUMNS,
    "joint_rate": JOINT_RATE_COLUMNS,
    "trunk_position": TRUNK_COLUMNS[:2],
    "trunk_angle": TRUNK_COLUMNS[2:],
    "belt_speed": BELT_COLUMNS[:1],
    "belt_position": BELT_COLUMNS[1:],
    "joint_torque": TORQUE_COLUMNS,
}

#: How the controller's schedule relates to the trial (written into the metadata).
PHASE_CONVENTION = (
    "phi in [0, 1): 0 at a right heel strike, rising linearly in time to 1 at the next "
    "right heel strike (colloc.data.gait_phase with the right heel strikes); schedule point p "
    "sits at phi = p / P and T*, K are interpolated linearly and periodically in phi"
)

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
        ``belt_position (N,)``.

    Returns
    -------
    time : ndarray, shape (N,)
    signals : DataFrame
        One column per name of :data:`colloc.data.columns.SIGNAL_COLUMNS`.

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
    columns = np.column_stack([columns, belt["belt_position"], torques])
    names = JOINT_ANGLE_COLUMNS + JOINT_RATE_COLUMNS + TRUNK_COLUMNS + BELT_COLUMNS
    frame = pd.DataFrame(columns, columns=list(names + TORQUE_COLUMNS))
    return time, frame[list(SIGNAL_COLUMNS)]


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
        Further metadata, e.g. from :func:`synthetic_metadata`; its keys win over the
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


#: Name of each gait-model state ``[q, u]`` as the trial calls the signal (the trunk's
#: velocities are not trial columns; they are named ``<column>_rate``).
STATE_SIGNAL_NAMES: tuple[str, ...] = (
    TRUNK_COLUMNS
    + JOINT_ANGLE_COLUMNS
    + tuple(f"{name}_rate" for name in TRUNK_COLUMNS)
    + JOINT_RATE_COLUMNS
)


def controller_metadata(
    Tstar: np.ndarray,
    K: np.ndarray,
    mask: np.ndarray,
    *,
    structure: str | None = None,
    phase_convention: str = PHASE_CONVENTION,
    feedback: Sequence[str] | None = None,
) -> dict[str, Any]:
    """The true controller ``T = T*(phi) - K(phi) s`` as plain nested lists.

    Parameters
    ----------
    Tstar : array_like, shape (P, 6)
        Scheduled torques [N·m].
    K : array_like, shape (P, 6, n_s)
        Scheduled gains on ``s``.
    mask : array_like of bool, shape (6, n_s)
        Which gains exist (the structure); gains outside it must be zero.
    structure : str, optional
        Name of the structure (``"full"``, ``"joint-isolated"``), recorded as is.
    phase_convention : str
        How the controller's phase was computed; default :data:`PHASE_CONVENTION`.
    feedback : sequence of str, optional
        Names of the fed-back signals ``s`` (see :data:`STATE_SIGNAL_NAMES`); default the six
        joint angles then the six joint rates.

    Returns
    -------
    dict
        ``law``, ``num_points``, ``phase_convention``, ``inputs`` (torque columns),
        ``feedback`` (angle then rate columns), ``structure``, ``mask``, ``Tstar``, ``K``.

    Raises
    ------
    ValueError
        If the shapes disagree, values are not finite, or ``K`` is nonzero outside ``mask``.
    """
    Tstar, K, mask = np.asarray(Tstar, float), np.asarray(K, float), np.asarray(mask)
    names = list(JOINT_ANGLE_COLUMNS + JOINT_RATE_COLUMNS) if feedback is None else list(feedback)
    m, ns = len(TORQUE_COLUMNS), len(names)
    P = Tstar.shape[0] if Tstar.ndim == 2 else -1
    problems = []
    unknown = [n for n in names if n not in STATE_SIGNAL_NAMES]
    if unknown or len(set(names)) != len(names):
        problems.append(
            f"feedback: expected distinct names from {list(STATE_SIGNAL_NAMES)}, found {names}"
        )
    if Tstar.shape != (P, m) or P < 1:
        problems.append(f"Tstar: expected shape (P, {m}), found {Tstar.shape}")
    if K.shape != (P, m, ns):
        problems.append(f"K: expected shape ({P}, {m}, {ns}) with P from Tstar, found {K.shape}")
    if mask.shape != (m, ns) or mask.dtype != bool:
        problems.append(
            f"mask: expected a bool array of shape ({m}, {ns}), found {mask.dtype} {mask.shape}"
        )
    for name, values in (("Tstar", Tstar), ("K", K)):
        if not np.all(np.isfinite(values)):
            problems.append(f"{name}: expected finite values, found NaN/inf")
    if not problems and np.any(K[:, ~mask] != 0):
        problems.append("K: has nonzero gains outside mask")
    if problems:
        raise ValueError("controller: " + "; ".join(problems))
    return {
        "law": "T(t) = Tstar(phi) - K(phi) s(t)",
        "num_points": int(P),
        "phase_convention": str(phase_convention),
        "inputs": list(TORQUE_COLUMNS),
        "feedback": names,
        "structure": structure,
        "mask": mask.tolist(),
        "Tstar": Tstar.tolist(),
        "K": K.tolist(),
    }


def controller_from_metadata(
    metadata: Mapping[str, Any],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Read the true controller back from a synthetic trial's metadata.

    Parameters
    ----------
    metadata : mapping
        ``Trial.metadata`` of a trial made by :func:`synthetic_metadata`.

    Returns
    -------
    Tstar : ndarray, shape (P, 6)
    K : ndarray, shape (P, 6, n_s)
        Gains on the signals named in ``metadata["controller"]["feedback"]``.
    mask : ndarray of bool, shape (6, n_s)

    Raises
    ------
    KeyError
        If the metadata has no ``controller`` entry with ``Tstar``, ``K`` and ``mask``.
    """
    controller = metadata.get("controller")
    missing = [
        k
        for k in ("Tstar", "K", "mask")
        if not isinstance(controller, Mapping) or k not in controller
    ]
    if missing:
        raise KeyError(
            f"metadata: expected a 'controller' mapping with {missing} (a synthetic trial), "
            f"found keys {sorted(metadata)}"
        )
    assert isinstance(controller, Mapping)
    return (
        np.asarray(controller["Tstar"], dtype=float),
        np.asarray(controller["K"], dtype=float),
        np.asarray(controller["mask"], dtype=bool),
    )


def synthetic_metadata(
    *,
    controller: Mapping[str, Any],
    cycle_speed: float,
    cycle_duration: float,
    body_mass: float,
    height: float,
    belt: Mapping[str, Any],
    fell: bool,
    message: str = "",
    extra: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """Metadata of a synthetic perturbed-walking trial.

    Parameters
    ----------
    controller : mapping
        From :func:`controller_metadata`.
    cycle_speed, cycle_duration : float
        Walking speed [m/s] and stride duration [s] of the periodic cycle the controller
        was designed around.
    body_mass, height : float
        The simulated subject [kg], [m].
    belt : mapping
        Where the belt-speed input came from and how it was rescaled, e.g.
        ``{"source": ..., "mean_speed": ..., "deviation_scale": ...}``.
    fell : bool
        Whether the simulation stopped because the walker fell.
    message : str
        The simulation's message.
    extra : mapping, optional
        Anything else, merged last.

    Returns
    -------
    dict
        ``synthetic: True``, ``body_mass``, ``height``, ``controller``, ``cycle``, ``belt``,
        ``simulation``, then ``extra``.
    """
    metadata: dict[str, Any] = {
        "synthetic": True,
        "body_mass": float(body_mass),
        "height": float(height),
        "controller": dict(controller),
        "cycle": {"speed": float(cycle_speed), "duration": float(cycle_duration)},
        "belt": dict(belt),
        "simulation": {"fell": bool(fell), "message": str(message)},
    }
    metadata.update(extra or {})
    return metadata
