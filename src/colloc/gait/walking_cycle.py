"""One periodic stride of the planar gait model: states, torques and forces at nodes.

Made by :func:`colloc.gait.cycle.find_walking_cycle` (collocation) or
:func:`colloc.gait.settle.settle_cycle` (closed-loop simulation); stored as ``.npz``.
"""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline

from colloc.gait.strikes import vertical_foot_forces

_ARRAYS = ("times", "states", "torques", "contact_forces", "belt_speed", "duration")
_STATS_IN_FILE = (  # scalars and small lists; the IPOPT log and history stay in memory
    *("status", "success", "iterations", "objective", "constraint_violation", "build_time"),
    *("solve_time", "scheme", "num_nodes", "rms_angle_error_deg", "peak_vertical_grf_bw"),
    *("rms_angle_error_by_joint_deg", "stages", "source", "settle_residual"),
    *("settle_duration_change", "hip_drift_per_stride", "num_strides", "stride_durations"),
    "cycle_nodes",
)


@dataclass
class WalkingCycle:
    """One periodic stride of the planar gait model on a treadmill.

    Attributes
    ----------
    times : ndarray, shape (N,)
        Node times, ``0 .. duration`` (the last node repeats the first state).
    states : ndarray, shape (N, 18)
        ``q`` (``qax, qay, qa .. qg``) then ``u`` at the nodes.
    torques : ndarray, shape (N, 6)
        Joint torques ``Tb .. Tg`` [N m].
    contact_forces : ndarray, shape (N, 8)
        ``Fx, Fy`` of the floor on the right heel, right toe, left heel, left toe [N].
    belt_speed : float
        Treadmill speed [m/s].
    duration : float
        Stride duration [s].
    stats : dict
        IPOPT statistics of the final stage, ``stages`` (one entry per homotopy stage),
        ``rms_angle_error_deg`` and ``peak_vertical_grf_bw``.
    """

    times: np.ndarray
    states: np.ndarray
    torques: np.ndarray
    contact_forces: np.ndarray
    belt_speed: float
    duration: float
    stats: dict[str, Any] = field(default_factory=dict)

    @property
    def vertical_grf(self) -> np.ndarray:
        """Total vertical floor force on the right and left foot, shape (N, 2) [N]."""
        return vertical_foot_forces(self.contact_forces)

    def state_at(self, phase: float | np.ndarray) -> np.ndarray:
        """States at a gait phase by periodic cubic interpolation.

        Parameters
        ----------
        phase : float or array_like
            Fraction of the stride, wrapped into ``[0, 1)`` (0: the first node).

        Returns
        -------
        ndarray, shape (18,) or (len(phase), 18)
        """
        x = self.states.copy()
        x[-1] = x[0]  # equal to solver tolerance already; exactly equal for the spline
        spline = CubicSpline(self.times / self.duration, x, axis=0, bc_type="periodic")
        return spline(np.mod(np.asarray(phase, dtype=float), 1.0))

    def to_npz(self, path: str | os.PathLike[str]) -> None:
        """Write the cycle to ``path`` (NumPy ``.npz``), atomically (temp file + rename)."""
        target = Path(path)
        kept = {k: self.stats[k] for k in _STATS_IN_FILE if k in self.stats}
        fd, tmp = tempfile.mkstemp(dir=target.parent, suffix=".tmp.npz")
        try:
            with os.fdopen(fd, "wb") as fh:
                arrays = {name: getattr(self, name) for name in _ARRAYS}
                np.savez(fh, **arrays, stats=np.array(json.dumps(kept, default=str)))
            os.replace(tmp, target)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise

    @classmethod
    def from_npz(cls, path: str | os.PathLike[str]) -> WalkingCycle:
        """Read a cycle written by :meth:`to_npz`."""
        with np.load(path, allow_pickle=False) as data:
            values: dict[str, Any] = {name: np.array(data[name]) for name in _ARRAYS}
            values["belt_speed"], values["duration"] = map(
                float, (values["belt_speed"], values["duration"])
            )
            return cls(**values, stats=json.loads(str(data["stats"])))


__all__ = ["WalkingCycle"]
