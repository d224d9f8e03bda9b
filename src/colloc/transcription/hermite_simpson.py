"""Hermite-Simpson collocation (separated form) with derivative variables."""

from __future__ import annotations

import casadi as ca
import numpy as np

from colloc.transcription.base import IntervalView, NodeView, Residual, Scheme, TimeGrid


class HermiteSimpson(Scheme):
    """Separated Hermite-Simpson: midpoint state ``x_m`` and derivative ``v_m`` per interval.

    Per interval: ``x_m = (x0 + x1)/2 + h (v0 - v1)/8``, ``x1 - x0 = h (v0 + 4 v_m + v1)/6``
    and ``F(v_m, x_m, r_mid, t0 + h/2) = 0``; at every node ``F(v, x, r, t) = 0``. Order 4.
    """

    order = 4
    interval_evaluation = 0.5
    node_derivatives = True
    dynamics_at_nodes = True

    def num_interval_variables(self, num_states: int) -> int:
        """``x_m`` and ``v_m``."""
        return 2 * num_states

    def interval_variable_names(self, state_names: list[str]) -> list[str]:
        """``x_mid`` then ``x'_mid`` for each state."""
        return [f"{s}_mid" for s in state_names] + [f"{s}'_mid" for s in state_names]

    def interval_guess(self, states: np.ndarray, grid: TimeGrid) -> np.ndarray:
        """Interpolated midpoint states and secant slopes."""
        slopes = np.diff(states, axis=0) / grid.steps[:, None]
        return np.hstack([grid.midpoint_values(states), slopes])

    def interval_defects(self, F: Residual, iv: IntervalView) -> ca.SX:
        """Hermite interpolation, Simpson quadrature and the residual at the midpoint."""
        assert iv.start.v is not None and iv.end.v is not None
        n = iv.start.x.numel()
        x_m, v_m = iv.extra[:n], iv.extra[n:]
        x0, x1, v0, v1, h = iv.start.x, iv.end.x, iv.start.v, iv.end.v, iv.h
        return ca.vertcat(
            x_m - 0.5 * (x0 + x1) - h / 8 * (v0 - v1),
            x1 - x0 - h / 6 * (v0 + 4 * v_m + v1),
            F(v_m, x_m, iv.r_mid, iv.t0 + 0.5 * h),
        )

    def node_defects(self, F: Residual, nv: NodeView) -> ca.SX:
        """The model residual at the node."""
        assert nv.v is not None
        return F(nv.v, nv.x, nv.r, nv.t)
