"""Radau IIA with two stages: stiffly accurate, L-stable, order 3."""

from __future__ import annotations

import casadi as ca
import numpy as np

from colloc.transcription.base import IntervalView, Residual, Scheme, TimeGrid

#: Butcher tableau of the two-stage Radau IIA method: stages at ``c`` of the interval.
C = (1.0 / 3.0, 1.0)
A = ((5.0 / 12.0, -1.0 / 12.0), (3.0 / 4.0, 1.0 / 4.0))
#: Weights of the inputs at the interval's start, midpoint and end that give them at
#: ``c[0]`` (quadratic interpolation: third order, which keeps the scheme's order; for
#: inputs that are linear on the interval it is the linear interpolation).
INPUT_WEIGHTS = (2.0 / 9.0, 8.0 / 9.0, -1.0 / 9.0)


class RadauIIA(Scheme):
    """Two-stage Radau IIA: a stage state ``X1`` and the stage derivatives ``V1``, ``V2``
    per interval.

    Per interval: ``X1 = x0 + h (5/12 V1 - 1/12 V2)``, ``x1 = x0 + h (3/4 V1 + 1/4 V2)``,
    ``F(V1, X1, r(t0 + h/3), t0 + h/3) = 0`` and ``F(V2, x1, r1, t1) = 0``: the second stage
    is the interval's end node: stiffly accurate and L-stable, as backward Euler is. Order 3. The inputs at ``t0 + h/3`` are interpolated
    quadratically from the interval's start, midpoint and end (:data:`INPUT_WEIGHTS`).

    A scheduled parameter is bracketed once per interval, at its midpoint, while the
    residual is evaluated at a third and at the end of the interval.
    """

    order = 3
    interval_evaluation = None
    dynamics_at_nodes = True

    def num_interval_variables(self, num_states: int) -> int:
        """``X1``, ``V1`` and ``V2``."""
        return 3 * num_states

    def interval_variable_names(self, state_names: list[str]) -> list[str]:
        """``x_stage`` then ``x'_stage1`` and ``x'_stage2`` for each state."""
        return (
            [f"{s}_stage" for s in state_names]
            + [f"{s}'_stage1" for s in state_names]
            + [f"{s}'_stage2" for s in state_names]
        )

    def interval_guess(self, states: np.ndarray, grid: TimeGrid) -> np.ndarray:
        """Stage states on the chords, the secant slopes for both stage derivatives."""
        slopes = np.diff(states, axis=0) / grid.steps[:, None]
        stage = states[:-1] + C[0] * np.diff(states, axis=0)
        return np.hstack([stage, slopes, slopes])

    def interval_defects(self, F: Residual, iv: IntervalView) -> ca.SX:
        """The two stage relations and the residual at both stages."""
        n = iv.start.x.numel()
        X1, V1, V2 = iv.extra[:n], iv.extra[n : 2 * n], iv.extra[2 * n :]
        x0, x1, h = iv.start.x, iv.end.x, iv.h
        w0, wm, w1 = INPUT_WEIGHTS
        r1 = w0 * iv.start.r + wm * iv.r_mid + w1 * iv.end.r
        return ca.vertcat(
            X1 - x0 - h * (A[0][0] * V1 + A[0][1] * V2),
            x1 - x0 - h * (A[1][0] * V1 + A[1][1] * V2),
            F(V1, X1, r1, iv.t0 + C[0] * h),
            F(V2, x1, iv.end.r, iv.t0 + h),
        )
