"""Gain-scheduled state feedback ``T(t) = T*(phi) - K(phi) s(t)`` over a periodic phase.

``T*`` (``m`` values) and ``K`` (``m x n_s``) are given at ``P`` points of the cycle and
interpolated linearly and periodically in the phase ``phi``. Closing a model's loop makes
them model parameters; the residual uses two slots per parameter (see
:class:`colloc.model.schedule.ParameterSchedule`), so each collocation node depends only
on the two schedule points around its phase.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc.model.schedule import ParameterSchedule
from colloc.model.symbols import as_tuple, name_of

if TYPE_CHECKING:
    from colloc.model.model import Model


def joint_isolated_mask(num_inputs: int) -> np.ndarray:
    """Each input fed back from its own angle and rate (``s = [angles, rates]``)."""
    mask = np.zeros((num_inputs, 2 * num_inputs), dtype=bool)
    idx = np.arange(num_inputs)
    mask[idx, idx] = True
    mask[idx, num_inputs + idx] = True
    return mask


#: Named structures of the gain matrix.
STRUCTURES = {
    "full": lambda m, ns: np.ones((m, ns), dtype=bool),
    "joint-isolated": lambda m, ns: joint_isolated_mask(m),
}


class GainScheduled:
    """``T(t) = T*(phi) - K(phi) s(t)`` with ``T*``, ``K`` scheduled at ``P`` points.

    Parameters
    ----------
    num_points : int
        ``P``: schedule points, equally spaced in ``phi`` over ``[0, 1)``.
    feedback : sequence of functions of time
        ``s``: the fed-back states (for gait: six joint angles, then six joint rates).
    inputs : sequence of functions of time
        The driven inputs, in row order (for gait: the six joint torques).
    phase : function of time, optional
        ``Phi(t)``, the unwrapped phase in cycles (``phi = Phi mod 1``); default ``phi(t)``.
        Closing a loop adds it to the model's known inputs.
    structure : {"full", "joint-isolated"} or bool array
        Which gains exist: all, each input from its own angle and rate only (``s`` ordered
        angles then rates), or an ``m x n_s`` mask.
    name : str
        Prefix of the symbols: ``{name}T_{p}_{j}`` and ``{name}K_{p}_{j}_{i}``.
    """

    def __init__(
        self,
        num_points: int,
        feedback: Sequence[sm.Basic],
        inputs: Sequence[sm.Basic],
        *,
        phase: sm.Basic | None = None,
        structure: str | np.ndarray = "full",
        name: str = "",
    ) -> None:
        problems = []
        if (
            isinstance(num_points, bool)
            or not isinstance(num_points, int | np.integer)
            or num_points < 2
        ):
            problems.append(f"num_points: expected an integer >= 2, found {num_points!r}")
        self.feedback, self.inputs = as_tuple(feedback), as_tuple(inputs)
        m, ns = len(self.inputs), len(self.feedback)
        if m == 0 or ns == 0:
            problems.append(f"inputs/feedback: expected at least one each, found {m} and {ns}")
        if isinstance(structure, str):
            if structure not in STRUCTURES:
                problems.append(
                    f"structure: expected one of {sorted(STRUCTURES)} or a mask, found {structure!r}"
                )
                mask = np.ones((m, ns), dtype=bool)
            elif structure == "joint-isolated" and ns != 2 * m:
                problems.append(
                    f"structure: 'joint-isolated' needs feedback = {m} angles then {m} rates, "
                    f"found {ns} feedback states"
                )
                mask = np.ones((m, ns), dtype=bool)
            else:
                mask = STRUCTURES[structure](m, ns)
        else:
            mask = np.asarray(structure, dtype=bool)
            if mask.shape != (m, ns):
                problems.append(
                    f"structure: expected a mask of shape ({m}, {ns}), found {mask.shape}"
                )
                mask = np.ones((m, ns), dtype=bool)
        if problems:
            raise ValueError("GainScheduled: " + "; ".join(problems))
        self.num_points = int(num_points)
        self.mask = mask
        self.phase = phase if phase is not None else dynamicsymbols(f"{name}phi")
        self._gain_index = [tuple(ij) for ij in np.argwhere(mask)]
        size = m + len(self._gain_index)
        points = tuple(
            tuple(sm.Symbol(f"{name}T_{p}_{j}") for j in range(m))
            + tuple(sm.Symbol(f"{name}K_{p}_{i}_{k}") for i, k in self._gain_index)
            for p in range(self.num_points)
        )
        slots_a = tuple(sm.Symbol(f"_{name}slot_a{c}") for c in range(size))
        slots_b = tuple(sm.Symbol(f"_{name}slot_b{c}") for c in range(size))
        weight = dynamicsymbols(f"_{name}w_{name_of(self.phase)}")
        self.schedule = ParameterSchedule(self.phase, weight, slots_a, slots_b, points)

    # ------------------------------------------------------------------ Controller protocol
    @property
    def parameters(self) -> tuple[sm.Symbol, ...]:
        """``T*`` and ``K`` at every point, point-major (``T*`` first within a point)."""
        return self.schedule.parameters

    @property
    def schedules(self) -> tuple[ParameterSchedule, ...]:
        """The schedule the engine binds per node."""
        return (self.schedule,)

    def control_law(self, model: Model) -> Mapping[sm.Basic, sm.Expr]:
        """``{input: (1 - w)(T*_a - K_a s) + w (T*_b - K_b s)}`` for each driven input."""
        missing = [name_of(s) for s in self.feedback if s not in model.states]
        if missing:
            raise ValueError(f"feedback: {missing} are not states of the model")
        m = len(self.inputs)
        w = self.schedule.weight

        def law(slots: tuple[sm.Symbol, ...]) -> list[sm.Expr]:
            out = list(slots[:m])
            for c, (i, k) in enumerate(self._gain_index):
                out[i] = out[i] - slots[m + c] * self.feedback[k]
            return out

        low, high = law(self.schedule.slots_a), law(self.schedule.slots_b)
        return {r: (1 - w) * a + w * b for r, a, b in zip(self.inputs, low, high, strict=True)}

    # ------------------------------------------------------------------ numbers
    def parameter_values(self, Tstar: np.ndarray, K: np.ndarray) -> dict[sm.Symbol, float]:
        """Symbol -> value from ``Tstar`` ``(P, m)`` and ``K`` ``(P, m, n_s)`` arrays.

        Gains outside the structure must be zero (they do not exist in the controller).
        """
        Tstar, K = np.asarray(Tstar, float), np.asarray(K, float)
        P, m, ns = self.num_points, len(self.inputs), len(self.feedback)
        if Tstar.shape != (P, m) or K.shape != (P, m, ns):
            raise ValueError(
                f"Tstar, K: expected shapes ({P}, {m}) and ({P}, {m}, {ns}), "
                f"found {Tstar.shape} and {K.shape}"
            )
        if np.any(K[:, ~self.mask] != 0):
            raise ValueError("K: has nonzero gains outside the controller's structure")
        values = np.hstack([Tstar, K[:, self.mask]])
        return dict(zip(self.parameters, values.ravel(), strict=True))

    def arrays(self, values: Mapping[sm.Symbol, float]) -> tuple[np.ndarray, np.ndarray]:
        """Inverse of :meth:`parameter_values`: ``(Tstar (P, m), K (P, m, n_s))``."""
        P, m, ns = self.num_points, len(self.inputs), len(self.feedback)
        flat = np.array([values[p] for p in self.parameters], float).reshape(P, -1)
        K = np.zeros((P, m, ns))
        K[:, self.mask] = flat[:, m:]
        return flat[:, :m].copy(), K

    def interpolate(
        self, phase: np.ndarray | float, Tstar: np.ndarray, K: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """``T*(phi)`` and ``K(phi)`` at (unwrapped) phases, periodic linear interpolation."""
        a, b, w = self.schedule.bracket(np.atleast_1d(phase))
        Ts = (1 - w)[:, None] * Tstar[a] + w[:, None] * Tstar[b]
        Kp = (1 - w)[:, None, None] * K[a] + w[:, None, None] * K[b]
        return Ts, Kp

    def torque(
        self, phase: np.ndarray | float, s: np.ndarray, Tstar: np.ndarray, K: np.ndarray
    ) -> np.ndarray:
        """``T*(phi) - K(phi) s`` for phases ``(k,)`` and feedback states ``(k, n_s)``."""
        Ts, Kp = self.interpolate(phase, Tstar, K)
        return Ts - np.einsum("kij,kj->ki", Kp, np.atleast_2d(s))

    def __repr__(self) -> str:
        return (
            f"GainScheduled(P={self.num_points}, inputs={[name_of(r) for r in self.inputs]}, "
            f"feedback={len(self.feedback)}, gains per point={int(self.mask.sum())})"
        )
