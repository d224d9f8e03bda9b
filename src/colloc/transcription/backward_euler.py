"""Backward (implicit) Euler: the scheme of the 2014 study; first order."""

from __future__ import annotations

import casadi as ca

from colloc.transcription.base import IntervalView, Residual, Scheme


class BackwardEuler(Scheme):
    """``F((x1 - x0)/h, x1, r1, t1) = 0`` on each interval. Order 1; robust on stiff systems."""

    order = 1
    interval_evaluation = 1.0
    dynamics_at_nodes = True

    def interval_defects(self, F: Residual, iv: IntervalView) -> ca.SX:
        """Residual at the interval end with the backward difference for ``x'``."""
        xdot = (iv.end.x - iv.start.x) / iv.h
        return F(xdot, iv.end.x, iv.end.r, iv.t0 + iv.h)
