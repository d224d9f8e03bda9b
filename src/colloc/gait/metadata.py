"""The true controller and the simulation in a synthetic trial's metadata.

:func:`controller_metadata` writes the known controller ``T = T*(phi) - K(phi) s`` as plain
lists (with the names of the fed-back signals and the phase convention),
:func:`controller_from_metadata` reads it back, and :func:`synthetic_metadata` gathers it
with the cycle, subject, belt and outcome of the simulation.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from colloc.data.columns import (
    JOINT_ANGLE_COLUMNS,
    JOINT_RATE_COLUMNS,
    TORQUE_COLUMNS,
    TRUNK_COLUMNS,
)

#: How the controller's schedule relates to the trial (written into the metadata).
PHASE_CONVENTION = (
    "phi in [0, 1): 0 at a right heel strike, rising linearly in time to 1 at the next "
    "right heel strike (colloc.data.gait_phase with the right heel strikes); schedule point p "
    "sits at phi = p / P and T*, K are interpolated linearly and periodically in phi"
)

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
    phase_at_strike: float | None = None,
    stride_duration: float | None = None,
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
    phase_at_strike, stride_duration : float, optional
        A causal phase's ``phi_0`` and ``D`` (:func:`colloc.data.causal_gait_phase`),
        recorded when given: with them an identification reproduces the controller's phase
        from the heel strikes.

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
    if phase_at_strike is not None and not 0 <= phase_at_strike < 1:
        problems.append(f"phase_at_strike: expected a number in [0, 1), found {phase_at_strike}")
    if stride_duration is not None and not 0 < stride_duration < np.inf:
        problems.append(f"stride_duration: expected seconds > 0, found {stride_duration}")
    if problems:
        raise ValueError("controller: " + "; ".join(problems))
    causal = {
        key: float(value)
        for key, value in (
            ("phase_at_strike", phase_at_strike),
            ("stride_duration", stride_duration),
        )
        if value is not None
    }
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
        **causal,
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
    ValueError
        If they are not numeric arrays of consistent shapes (``Tstar`` (P, 6), ``K``
        (P, 6, n_s), ``mask`` (6, n_s), ``feedback`` naming the n_s signals when given).
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
    arrays, problems = {}, []
    for key, dtype in (("Tstar", float), ("K", float), ("mask", bool)):
        try:
            arrays[key] = np.asarray(controller[key], dtype=dtype)
        except (TypeError, ValueError) as error:
            problems.append(f"controller {key!r}: not a numeric array ({error})")
    if not problems:
        Tstar, K, mask = arrays["Tstar"], arrays["K"], arrays["mask"]
        if Tstar.ndim != 2 or Tstar.shape[1] != 6:
            problems.append(f"controller 'Tstar': expected shape (P, 6), found {Tstar.shape}")
        if K.ndim != 3 or K.shape[1] != 6 or (Tstar.ndim == 2 and K.shape[0] != Tstar.shape[0]):
            problems.append(
                f"controller 'K': expected shape (P, 6, n_s) with P = {Tstar.shape[0]} "
                f"(Tstar's), found {K.shape}"
            )
        elif mask.shape != K.shape[1:]:
            problems.append(f"controller 'mask': expected shape {K.shape[1:]}, found {mask.shape}")
        elif np.any(K[:, ~mask] != 0):
            outside = int(np.count_nonzero(K[:, ~mask]))
            problems.append(
                f"controller 'K': {outside} non-zero gains where 'mask' allows none (the "
                "controller's structure says they are zero)"
            )
        feedback = controller.get("feedback")
        if feedback is not None and K.ndim == 3 and len(feedback) != K.shape[2]:
            problems.append(
                f"controller 'feedback': names {len(feedback)} signals, K has {K.shape[2]} columns"
            )
        if not np.all(np.isfinite(Tstar)) or not np.all(np.isfinite(K)):
            problems.append("controller 'Tstar'/'K': hold NaN or infinite values")
    if problems:
        raise ValueError("metadata: " + "; ".join(problems))
    return arrays["Tstar"], arrays["K"], arrays["mask"]


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
