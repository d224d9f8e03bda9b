"""Smooth compliant point contact with a moving floor (Ackermann & van den Bogert 2010).

A contact point at height ``y`` above the floor (negative: inside it), moving with vertical
speed ``y'`` and slipping over the floor surface at ``s``, feels

.. math::

    d   &= \\tfrac12\\left(\\sqrt{y^2 + \\varepsilon^2} - y\\right) \\\\
    F_y &= (k d^3 - b y)(1 - c\\,y') \\\\
    F_x &= -\\mu F_y \\tanh\\!\\left(\\frac{s}{2 v_s}\\right)

``d`` is the penetration ``(|y| - y)/2`` with ``|y|`` rounded off by ``epsilon`` so that every
expression has exact derivatives of all orders (the original form is not twice
differentiable at ``y = 0``). ``- b y`` is the weak (1 N/m) bidirectional spring of the
original model; it keeps gradients non-zero while a foot is in the air. ``tanh(s / 2 v_s)``
equals the published ``2 / (1 + exp(-s / v_s)) - 1``. A larger ``v_s`` or ``epsilon`` gives a
smoother, faster-to-optimise but less realistic contact.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import sympy as sm

from colloc.models.gait2d_params import ContactParameters


@dataclass(frozen=True)
class ContactSymbols:
    """The constants of the contact law as SymPy symbols (names match :class:`ContactParameters`).

    Attributes
    ----------
    stiffness, damping, linear_stiffness, friction_coefficient, friction_velocity, smoothing
        ``k``, ``c``, ``b``, ``mu``, ``v_s``, ``epsilon``.
    """

    stiffness: sm.Symbol
    damping: sm.Symbol
    linear_stiffness: sm.Symbol
    friction_coefficient: sm.Symbol
    friction_velocity: sm.Symbol
    smoothing: sm.Symbol

    @classmethod
    def create(cls) -> ContactSymbols:
        """Fresh symbols ``k_c, c_c, b_c, mu_c, v_s, eps_c``.

        ``k_c``, ``v_s`` and ``eps_c`` are positive, the others non-negative; the assumptions
        let SymPy see at once that the contact expressions are real.
        """
        return cls(
            sm.Symbol("k_c", positive=True),
            sm.Symbol("c_c", nonnegative=True),
            sm.Symbol("b_c", nonnegative=True),
            sm.Symbol("mu_c", nonnegative=True),
            sm.Symbol("v_s", positive=True),
            sm.Symbol("eps_c", positive=True),
        )

    def as_tuple(self) -> tuple[sm.Symbol, ...]:
        """The symbols in field order."""
        return tuple(getattr(self, f.name) for f in fields(self))

    def values(self, contact: ContactParameters) -> dict[sm.Symbol, float]:
        """Map each symbol to the matching number of ``contact``."""
        return {getattr(self, f.name): float(getattr(contact, f.name)) for f in fields(self)}


def penetration(height: sm.Expr, smoothing: sm.Expr) -> sm.Expr:
    """Smooth penetration ``(sqrt(y^2 + eps^2) - y) / 2`` of a point at ``height`` ``y``."""
    return (sm.sqrt(height**2 + smoothing**2) - height) / 2


def contact_force(
    height: sm.Expr, height_rate: sm.Expr, slip: sm.Expr, constants: ContactSymbols
) -> tuple[sm.Expr, sm.Expr]:
    """Horizontal and vertical force the floor exerts on one contact point.

    Parameters
    ----------
    height : sympy.Expr
        Height ``y`` of the point above the floor surface [m].
    height_rate : sympy.Expr
        Its time derivative ``y'`` [m/s].
    slip : sympy.Expr
        Horizontal velocity of the point relative to the floor surface, forward positive [m/s].
    constants : ContactSymbols

    Returns
    -------
    (Fx, Fy) : tuple of sympy.Expr
        Forward and upward force on the point [N].
    """
    c = constants
    d = penetration(height, c.smoothing)
    fy = (c.stiffness * d**3 - c.linear_stiffness * height) * (1 - c.damping * height_rate)
    fx = -c.friction_coefficient * fy * sm.tanh(slip / (2 * c.friction_velocity))
    return fx, fy
