"""Implicit midpoint: second order at the cost of backward Euler; the identification default."""

from __future__ import annotations

import casadi as ca

from colloc.transcription.base import IntervalView, Residual, Scheme


class Midpoint(Scheme):
    """``F((x1 - x0)/h, (x0 + x1)/2, r_mid, t0 + h/2) = 0`` on each interval. Order 2."""

    order = 2
    interval_evaluation = 0.5

    def interval_defects(self, F: Residual, iv: IntervalView) -> ca.SX:
        """Residual at the interval midpoint with the central difference for ``x'``."""
        xdot = (iv.end.x - iv.start.x) / iv.h
        return F(xdot, 0.5 * (iv.start.x + iv.end.x), iv.r_mid, iv.t0 + 0.5 * iv.h)
