"""Trapezoidal collocation with derivative variables at the nodes."""

from __future__ import annotations

import casadi as ca

from colloc.transcription.base import IntervalView, NodeView, Residual, Scheme


class Trapezoidal(Scheme):
    """``x1 - x0 = h (v0 + v1)/2`` per interval and ``F(v, x, r, t) = 0`` at every node.

    The derivative variables ``v`` keep implicit models implicit (no mass-matrix solve).
    Order 2.
    """

    order = 2
    node_derivatives = True
    dynamics_at_nodes = True

    def interval_defects(self, F: Residual, iv: IntervalView) -> ca.SX:
        """The trapezoidal quadrature of the derivative variables."""
        assert iv.start.v is not None and iv.end.v is not None
        return iv.end.x - iv.start.x - 0.5 * iv.h * (iv.start.v + iv.end.v)

    def node_defects(self, F: Residual, nv: NodeView) -> ca.SX:
        """The model residual at the node."""
        assert nv.v is not None
        return F(nv.v, nv.x, nv.r, nv.t)
