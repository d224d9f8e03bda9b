"""An n-link inverted pendulum on a spring-damper cart (the seed's example plant).

A cart of mass ``m0`` moves along the inertial x axis and is tied to the origin by a linear
spring ``k`` and damper ``c``; an external force ``F(t)`` pushes it. The cart carries a chain of
``n`` massless links of lengths ``l0 .. l(n-1)`` with point masses ``m1 .. mn`` at the link
ends. Joint torque ``Ti`` acts between link ``i-1`` (the cart for ``i = 1``) and link ``i``.

Coordinates: ``q0`` is the cart position, ``qi`` (``i >= 1``) the *absolute* angle of link ``i``
from the upward vertical, positive counter-clockwise about the z axis (upright is ``qi = 0``,
hanging is ``qi = pi``). Speeds are ``ui = qi'``. With these conventions the one-link equations
``M u' - f = 0`` are exactly the seed's::

    c u0 + k q0 + l0 m1 u1**2 sin(q1) - l0 m1 cos(q1) u1' + (m0 + m1) u0' - F = 0
    -g l0 m1 sin(q1) + l0**2 m1 u1' - l0 m1 cos(q1) u0' - T1 = 0
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from numbers import Real
from typing import TYPE_CHECKING

import sympy as sm
import sympy.physics.mechanics as me

if TYPE_CHECKING:
    from colloc.model.model import Model

__all__ = ["PendulumCart", "derive", "DEFAULT_MASS", "DEFAULT_LENGTH"]

#: Default value of every mass ``m0 .. mn`` [kg].
DEFAULT_MASS = 1.0
#: Default value of every link length ``l0 .. l(n-1)`` [m].
DEFAULT_LENGTH = 1.0
_DEFAULT_SPRING = 10.0  # k [N/m]
_DEFAULT_DAMPER = 5.0  # c [N s/m]
_DEFAULT_GRAVITY = 9.81  # g [m/s^2]


@dataclass(frozen=True, eq=False)
class PendulumCart:
    """Symbolic equations of motion of the n-link pendulum on a cart.

    Attributes
    ----------
    kane : sympy.physics.mechanics.KanesMethod
        The Kane's method object after ``kanes_equations``; ``kane.mass_matrix @ u' -
        kane.forcing`` are the dynamic equations, ``q' - u`` the kinematic ones.
    coordinates : tuple of sympy.Function
        ``(q0, q1, ..., qn)``: cart position [m] and absolute link angles [rad].
    speeds : tuple of sympy.Function
        ``(u0, u1, ..., un)`` with ``ui = qi'``.
    torques : tuple of sympy.Function
        ``(T1, ..., Tn)``: joint torques [N m], the controlled inputs.
    force : sympy.Function
        ``F``: external force on the cart [N], the known (measured) input.
    constants : tuple of sympy.Symbol
        ``(m0, ..., mn, l0, ..., l(n-1), k, c, g)``.
    num_links : int
        Number of links ``n``.
    """

    kane: me.KanesMethod
    coordinates: tuple[sm.Function, ...]
    speeds: tuple[sm.Function, ...]
    torques: tuple[sm.Function, ...]
    force: sm.Function
    constants: tuple[sm.Symbol, ...]
    num_links: int

    @property
    def states(self) -> tuple[sm.Function, ...]:
        """The state vector ``x = (q0, ..., qn, u0, ..., un)``."""
        return self.coordinates + self.speeds

    def masses(self) -> tuple[sm.Symbol, ...]:
        """The mass symbols ``(m0, ..., mn)``."""
        return self.constants[: self.num_links + 1]

    def lengths(self) -> tuple[sm.Symbol, ...]:
        """The link length symbols ``(l0, ..., l(n-1))``."""
        return self.constants[self.num_links + 1 : 2 * self.num_links + 1]

    def default_constants(self, **overrides: float) -> dict[sm.Symbol, float]:
        """Numerical values of all constants: the defaults, with ``overrides`` applied.

        Defaults: every mass 1 kg, every length 1 m, ``k = 10`` N/m, ``c = 5`` N s/m,
        ``g = 9.81`` m/s^2.

        Parameters
        ----------
        **overrides : float
            Values keyed by constant name, e.g. ``m0=2.0, k=0.0``.

        Returns
        -------
        dict
            ``{Symbol: float}`` for every symbol in :attr:`constants`, in that order.

        Raises
        ------
        ValueError
            Listing every unknown name, non-finite value, non-positive mass or length and
            negative spring or damper constant.
        TypeError
            When a value is not a real number.
        """
        values: dict[str, float] = {}
        for s in self.masses():
            values[s.name] = DEFAULT_MASS
        for s in self.lengths():
            values[s.name] = DEFAULT_LENGTH
        values.update(k=_DEFAULT_SPRING, c=_DEFAULT_DAMPER, g=_DEFAULT_GRAVITY)

        problems: list[str] = []
        unknown = sorted(set(overrides) - set(values))
        if unknown:
            problems.append(f"unknown constant name(s) {unknown}; expected some of {list(values)}")
        bad_types = [
            f"{name}={value!r} ({type(value).__name__})"
            for name, value in overrides.items()
            if isinstance(value, bool) or not isinstance(value, Real)
        ]
        if bad_types:
            raise TypeError(f"overrides: expected real numbers, found {', '.join(bad_types)}")
        positive = {s.name for s in self.masses() + self.lengths()}
        for name, value in overrides.items():
            if name not in values:
                continue
            value = float(value)
            if not math.isfinite(value):
                problems.append(f"{name} must be finite, found {value}")
            elif name in positive and value <= 0.0:
                problems.append(f"{name} (mass or length) must be > 0, found {value}")
            elif name in ("k", "c") and value < 0.0:
                problems.append(f"{name} (spring/damper constant) must be >= 0, found {value}")
            values[name] = value
        if problems:
            raise ValueError("default_constants: " + "; ".join(problems))
        return {s: values[s.name] for s in self.constants}

    def to_model(self) -> Model:
        """The open-loop plant as a :class:`colloc.model.model.Model`.

        Joint torques are the controlled inputs, the cart force the known input; the
        outputs default to the coordinates.
        """
        from colloc.model.model import Model

        return Model.from_kane(
            self.kane,
            controlled_inputs=self.torques,
            known_inputs=(self.force,),
            outputs=None,
        )


def derive(num_links: int) -> PendulumCart:
    """Derive the equations of motion of the ``num_links``-link pendulum on a cart.

    Parameters
    ----------
    num_links : int
        Number of links ``n >= 1``.

    Returns
    -------
    PendulumCart
        The symbolic system (Kane's method). Results are cached per ``num_links``, so treat
        the returned object as read-only.

    Raises
    ------
    TypeError
        When ``num_links`` is not an integer.
    ValueError
        When ``num_links < 1``.
    """
    if isinstance(num_links, bool) or not isinstance(num_links, int):
        raise TypeError(
            f"num_links: expected an int >= 1, found {num_links!r} ({type(num_links).__name__})"
        )
    if num_links < 1:
        raise ValueError(f"num_links: expected an int >= 1, found {num_links}")
    return _derive(num_links)


@lru_cache(maxsize=8)
def _derive(n: int) -> PendulumCart:
    q = tuple(me.dynamicsymbols(f"q0:{n + 1}"))
    u = tuple(me.dynamicsymbols(f"u0:{n + 1}"))
    torques = tuple(me.dynamicsymbols(f"T1:{n + 1}"))
    force = me.dynamicsymbols("F")
    # Plain symbols (no assumptions) so that users who build ``Symbol("m0")`` by name get the
    # same objects back.
    m = sm.symbols(f"m0:{n + 1}")
    lengths = sm.symbols(f"l0:{n}")
    k, c, g = sm.symbols("k c g")

    inertial = me.ReferenceFrame("N")
    origin = me.Point("O")
    origin.set_vel(inertial, 0)

    cart = origin.locatenew("P0", q[0] * inertial.x)
    cart.set_vel(inertial, u[0] * inertial.x)
    bodies = [me.Particle("Pa0", cart, m[0])]
    loads: list[tuple] = [(cart, (force - k * q[0] - c * u[0]) * inertial.x)]

    # Each link frame is rotated by its absolute angle from the inertial frame, so the
    # angular velocity of link i is ui about z and the link points along its frame's y axis.
    frames = [inertial]
    point = cart
    for i in range(1, n + 1):
        frame = inertial.orientnew(f"A{i}", "Axis", (q[i], inertial.z))
        frame.set_ang_vel(inertial, u[i] * inertial.z)
        joint_end = point.locatenew(f"P{i}", lengths[i - 1] * frame.y)
        joint_end.v2pt_theory(point, inertial, frame)
        bodies.append(me.Particle(f"Pa{i}", joint_end, m[i]))
        loads.append((joint_end, -m[i] * g * inertial.y))
        # Ti acts on link i and reacts on link i-1; the cart does not rotate, so the reaction
        # on it does no work and is left out.
        loads.append((frame, torques[i - 1] * inertial.z))
        if i > 1:
            loads.append((frames[i - 1], -torques[i - 1] * inertial.z))
        frames.append(frame)
        point = joint_end

    kd = [qi.diff(me.dynamicsymbols._t) - ui for qi, ui in zip(q, u, strict=True)]
    kane = me.KanesMethod(inertial, q_ind=list(q), u_ind=list(u), kd_eqs=kd)
    kane.kanes_equations(bodies, loads)
    return PendulumCart(
        kane=kane,
        coordinates=q,
        speeds=u,
        torques=torques,
        force=force,
        constants=tuple(m) + tuple(lengths) + (k, c, g),
        num_links=n,
    )
