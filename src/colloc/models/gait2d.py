"""Planar walking plant: 7 rigid segments, 9 degrees of freedom, heel/toe contact on a belt.

Conventions follow van den Bogert's gait2d. Ground frame: x forward, y up. Coordinates
``q = [qax, qay, qa, qb, qc, qd, qe, qf, qg]``:

====  ==========================================================================
qax   hip x position [m]
qay   hip y position [m]
qa    trunk angle to the vertical, counter-clockwise (leaning back) positive
qb    right hip angle (flexion positive)
qc    right knee angle (extension positive, so flexion is negative)
qd    right ankle angle (dorsiflexion positive; 0 with the foot at 90 deg to the shank)
qe    left hip angle
qf    left knee angle
qg    left ankle angle
====  ==========================================================================

Speeds ``u = q'`` (``uax, uay, ua, ..., ug``). Joint torques ``Tb .. Tg`` (right hip, knee,
ankle, left hip, knee, ankle) act +T on the distal segment and -T on the proximal one.
The floor is a treadmill belt whose surface moves *backward* at the known input
``v(t)`` (the treadmill speed, positive when walking forward on it); the contact slip of
a point moving forward at ``x'`` is therefore ``x' + v``.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from colloc.models.gait2d_contact import ContactSymbols, contact_force
from colloc.models.gait2d_params import Gait2DParameters

if TYPE_CHECKING:
    from colloc.model.model import Model

COORDINATE_NAMES: tuple[str, ...] = ("qax", "qay", "qa", "qb", "qc", "qd", "qe", "qf", "qg")
SPEED_NAMES: tuple[str, ...] = ("uax", "uay", "ua", "ub", "uc", "ud", "ue", "uf", "ug")
TORQUE_NAMES: tuple[str, ...] = ("Tb", "Tc", "Td", "Te", "Tf", "Tg")
CONTACT_POINT_NAMES: tuple[str, ...] = ("right_heel", "right_toe", "left_heel", "left_toe")


@dataclass(frozen=True)
class SegmentSymbols:
    """Constants of the segments (left and right legs share them)."""

    g: sm.Symbol
    m_trunk: sm.Symbol
    I_trunk: sm.Symbol
    c_trunk: sm.Symbol  # CoM above the hip
    m_thigh: sm.Symbol
    I_thigh: sm.Symbol
    l_thigh: sm.Symbol
    c_thigh: sm.Symbol  # CoM below the hip
    m_shank: sm.Symbol
    I_shank: sm.Symbol
    l_shank: sm.Symbol
    c_shank: sm.Symbol  # CoM below the knee
    m_foot: sm.Symbol
    I_foot: sm.Symbol
    x_foot: sm.Symbol  # CoM in front of the ankle
    y_foot: sm.Symbol  # CoM below the ankle
    x_heel: sm.Symbol  # heel contact point in front of the ankle (negative: behind)
    x_toe: sm.Symbol
    h_ankle: sm.Symbol  # ankle above the sole

    @classmethod
    def create(cls) -> SegmentSymbols:
        """One fresh symbol per field, named like the field (real; positive but ``x_heel``)."""
        return cls(
            *(
                sm.Symbol(f.name, real=True)
                if f.name == "x_heel"
                else sm.Symbol(f.name, positive=True)
                for f in fields(cls)
            )
        )

    def values(self, p: Gait2DParameters) -> dict[sm.Symbol, float]:
        """Map each symbol to its number in ``p``."""
        numbers = {
            "g": p.gravity,
            "x_foot": p.foot_com_x,
            "y_foot": p.foot_com_y,
            "x_heel": p.heel_x,
            "x_toe": p.toe_x,
            "h_ankle": p.ankle_height,
        }
        for seg in ("trunk", "thigh", "shank", "foot"):
            sp = getattr(p, seg)
            numbers |= {f"m_{seg}": sp.mass, f"I_{seg}": sp.inertia}
            if seg != "foot":
                numbers[f"c_{seg}"] = sp.com
            if seg in ("thigh", "shank"):
                numbers[f"l_{seg}"] = sp.length
        return {getattr(self, k): float(v) for k, v in numbers.items()}

    def as_tuple(self) -> tuple[sm.Symbol, ...]:
        """The symbols in field order."""
        return tuple(getattr(self, f.name) for f in fields(self))


@dataclass(frozen=True)
class Gait2D:
    """The derived planar gait model and its helper expressions.

    Attributes
    ----------
    kane : KanesMethod
        With ``kanes_equations`` already formed.
    coordinates, speeds : tuple
        ``q(t)`` and ``u(t)`` (9 each).
    torques : tuple
        ``Tb .. Tg`` (6): right hip, knee, ankle, left hip, knee, ankle.
    belt_speed : sympy.Function
        ``v(t)``, treadmill speed (belt surface moving backward), a known input.
    constants : tuple
        Every constant symbol, in a fixed order (segments first, then contact).
    segment_symbols : SegmentSymbols
    contact_symbols : ContactSymbols
    contact_points : dict
        Point name -> ``(x, y)`` position in the ground frame.
    contact_velocities : dict
        Point name -> ``(x', y')`` velocity in the ground frame.
    contact_forces : dict
        Point name -> ``(Fx, Fy)`` force of the floor on the point.
    energy : sympy.Expr
        Kinetic plus gravitational potential energy (zero height at the floor).
    center_of_mass : tuple
        ``(x, y)`` of the whole-body centre of mass.
    total_mass : sympy.Expr
    """

    kane: me.KanesMethod
    coordinates: tuple[sm.Function, ...]
    speeds: tuple[sm.Function, ...]
    torques: tuple[sm.Function, ...]
    belt_speed: sm.Function
    constants: tuple[sm.Symbol, ...]
    segment_symbols: SegmentSymbols
    contact_symbols: ContactSymbols
    contact_points: dict[str, tuple[sm.Expr, sm.Expr]]
    contact_velocities: dict[str, tuple[sm.Expr, sm.Expr]]
    contact_forces: dict[str, tuple[sm.Expr, sm.Expr]]
    energy: sm.Expr
    center_of_mass: tuple[sm.Expr, sm.Expr]
    total_mass: sm.Expr

    def constant_values(
        self, params: Gait2DParameters, overrides: Mapping[sm.Symbol, float] | None = None
    ) -> dict[sm.Symbol, float]:
        """Numbers for every constant symbol.

        Parameters
        ----------
        params : Gait2DParameters
            From :func:`colloc.models.gait2d_params.load_parameters`.
        overrides : mapping, optional
            Symbol -> value replacing individual constants (e.g. a smoother contact).

        Returns
        -------
        dict
            Symbol -> float, one entry per symbol in :attr:`constants`.

        Raises
        ------
        ValueError
            If ``overrides`` names a symbol that is not a constant of this model.
        """
        values = self.segment_symbols.values(params) | self.contact_symbols.values(params.contact)
        extra = [str(s) for s in (overrides or {}) if s not in values]
        if extra:
            raise ValueError(
                f"overrides: expected constants of the gait2d model "
                f"({', '.join(map(str, self.constants))}), found unknown {', '.join(extra)}"
            )
        values |= {s: float(v) for s, v in (overrides or {}).items()}
        return {s: values[s] for s in self.constants}

    def constant_array(
        self, params: Gait2DParameters, overrides: Mapping[sm.Symbol, float] | None = None
    ) -> np.ndarray:
        """:meth:`constant_values` as an array in the order of :attr:`constants`."""
        return np.array(list(self.constant_values(params, overrides).values()))

    def lambdify(self, exprs: Any) -> Callable[..., Any]:
        """Compile expressions to a NumPy function ``f(q, u, T, v, p)``.

        Parameters
        ----------
        exprs : sympy expression, matrix or nested sequence of them
            Written in the coordinates, speeds, torques, belt speed and constants.

        Returns
        -------
        callable
            ``f(q, u, T, v, p)`` with ``q``, ``u`` of length 9, ``T`` of length 6, ``v`` a
            float and ``p`` ordered like :attr:`constants` (see :meth:`constant_array`).
        """
        q, u, r = (sm.symbols(f"{c}:{n}") for c, n in (("q", 9), ("u", 9), ("T", 6)))
        v = sm.Symbol("v")
        plain = dict(zip(self.coordinates + self.speeds + self.torques, q + u + r, strict=True))
        plain[self.belt_speed] = v
        return sm.lambdify(
            (q, u, r, v, self.constants), _xreplace(exprs, plain), modules="numpy", cse=True
        )

    def dynamics_function(self) -> Callable[..., tuple[np.ndarray, np.ndarray]]:
        """NumPy function ``(q, u, T, v, p) -> (M, f)`` with ``M(q) u' = f(q, u, T, v)``."""
        f = self.lambdify([self.kane.mass_matrix, self.kane.forcing])

        def mass_matrix_and_forcing(q, u, torques, belt_speed, constants):
            mass, forcing = f(q, u, torques, belt_speed, constants)
            return np.asarray(mass, dtype=float), np.asarray(forcing, dtype=float).ravel()

        return mass_matrix_and_forcing

    def to_model(self) -> Model:
        """The colloc :class:`~colloc.model.model.Model` ``F(x', x, r, p) = 0`` of this plant.

        States ``[q, u]``; controlled inputs the six joint torques; known input the belt
        speed; parameters :attr:`constants`; outputs the coordinates.
        """
        from colloc.model.model import Model

        return Model.from_kane(
            self.kane,
            controlled_inputs=self.torques,
            known_inputs=(self.belt_speed,),
            parameters=self.constants,
        )


def derive() -> Gait2D:
    """Derive the equations of motion of the planar gait model with Kane's method.

    Returns
    -------
    Gait2D
    """
    # Real (and, for constants, positive) assumptions let SymPy decide at once that
    # tanh/sqrt of the contact expressions are real; without them its assumption queries run
    # polynomial gcds on the whole contact expression and the derivation takes minutes.
    q = me.dynamicsymbols(COORDINATE_NAMES, real=True)
    u = me.dynamicsymbols(SPEED_NAMES, real=True)
    torques = me.dynamicsymbols(TORQUE_NAMES, real=True)
    belt = me.dynamicsymbols("v", real=True)
    s = SegmentSymbols.create()
    cs = ContactSymbols.create()

    ground = me.ReferenceFrame("N")
    origin = me.Point("O")
    origin.set_vel(ground, 0)
    hip = origin.locatenew("hip", q[0] * ground.x + q[1] * ground.y)
    hip.set_vel(ground, u[0] * ground.x + u[1] * ground.y)

    trunk = me.ReferenceFrame("A")
    trunk.orient_axis(ground, ground.z, q[2])
    trunk.set_ang_vel(ground, u[2] * ground.z)
    trunk_com = hip.locatenew("trunk_com", s.c_trunk * trunk.y)
    trunk_com.v2pt_theory(hip, ground, trunk)

    bodies = [_body("trunk", trunk_com, trunk, s.m_trunk, s.I_trunk)]
    loads: list[tuple[Any, Any]] = []
    contact_points, contact_velocities, contact_forces = {}, {}, {}
    for side, (i_hip, i_knee, i_ankle) in (("right", (3, 4, 5)), ("left", (6, 7, 8))):
        frames, coms = _leg(side, ground, trunk, hip, q, u, (i_hip, i_knee, i_ankle), s)
        thigh, shank, foot = frames
        for frame, com, mass, inertia, name in zip(
            frames,
            coms[:3],
            (s.m_thigh, s.m_shank, s.m_foot),
            (s.I_thigh, s.I_shank, s.I_foot),
            ("thigh", "shank", "foot"),
            strict=True,
        ):
            bodies.append(_body(f"{side}_{name}", com, frame, mass, inertia))
        for child, parent, torque in zip(
            frames, (trunk, thigh, shank), torques[i_hip - 3 : i_ankle - 2], strict=True
        ):
            loads += [(child, torque * ground.z), (parent, -torque * ground.z)]
        for point in coms[3:]:
            name = point.name
            pos = point.pos_from(origin)
            vel = point.vel(ground)
            x, y = pos.dot(ground.x), pos.dot(ground.y)
            xd, yd = vel.dot(ground.x), vel.dot(ground.y)
            fx, fy = contact_force(y, yd, xd + belt, cs)
            contact_points[name] = (x, y)
            contact_velocities[name] = (xd, yd)
            contact_forces[name] = (fx, fy)
            loads.append((point, fx * ground.x + fy * ground.y))
    loads += [(b.masscenter, -b.mass * s.g * ground.y) for b in bodies]

    kane = me.KanesMethod(
        ground,
        q_ind=q,
        u_ind=u,
        kd_eqs=[qi.diff(me.dynamicsymbols._t) - ui for qi, ui in zip(q, u, strict=True)],
    )
    kane.kanes_equations(bodies, loads)

    total_mass = sum((b.mass for b in bodies), sm.Integer(0))
    com_pos = [b.masscenter.pos_from(origin) for b in bodies]
    center = tuple(
        sum((b.mass * p.dot(axis) for b, p in zip(bodies, com_pos, strict=True)), sm.Integer(0))
        / total_mass
        for axis in (ground.x, ground.y)
    )
    kinetic = sum((b.kinetic_energy(ground) for b in bodies), sm.Integer(0))
    energy = kinetic + total_mass * s.g * center[1]
    constants = s.as_tuple() + cs.as_tuple()
    return Gait2D(
        kane=kane,
        coordinates=tuple(q),
        speeds=tuple(u),
        torques=tuple(torques),
        belt_speed=belt,
        constants=constants,
        segment_symbols=s,
        contact_symbols=cs,
        contact_points=contact_points,
        contact_velocities=contact_velocities,
        contact_forces=contact_forces,
        energy=energy,
        center_of_mass=center,  # type: ignore[arg-type]
        total_mass=total_mass,
    )


def _body(
    name: str, com: me.Point, frame: me.ReferenceFrame, mass: sm.Symbol, inertia: sm.Symbol
) -> me.RigidBody:
    return me.RigidBody(name, com, frame, mass, (me.inertia(frame, 0, 0, inertia), com))


def _leg(
    side: str,
    ground: me.ReferenceFrame,
    trunk: me.ReferenceFrame,
    hip: me.Point,
    q: list,
    u: list,
    index: tuple[int, int, int],
    s: SegmentSymbols,
) -> tuple[tuple[me.ReferenceFrame, ...], tuple[me.Point, ...]]:
    """Frames (thigh, shank, foot) and points (3 CoMs, heel, toe) of one leg."""
    i_hip, i_knee, i_ankle = index
    # Absolute angular speeds are set directly so that SymPy never composes them along the tree.
    omega = u[2]
    frames = []
    parent = trunk
    for name, i in (("thigh", i_hip), ("shank", i_knee), ("foot", i_ankle)):
        frame = me.ReferenceFrame(f"{side}_{name}")
        frame.orient_axis(parent, parent.z, q[i])
        omega = omega + u[i]
        frame.set_ang_vel(ground, omega * ground.z)
        frames.append(frame)
        parent = frame
    thigh, shank, foot = frames

    thigh_com = hip.locatenew(f"{side}_thigh_com", -s.c_thigh * thigh.y)
    knee = hip.locatenew(f"{side}_knee", -s.l_thigh * thigh.y)
    shank_com = knee.locatenew(f"{side}_shank_com", -s.c_shank * shank.y)
    ankle = knee.locatenew(f"{side}_ankle", -s.l_shank * shank.y)
    foot_com = ankle.locatenew(f"{side}_foot_com", s.x_foot * foot.x - s.y_foot * foot.y)
    heel = ankle.locatenew(f"{side}_heel", s.x_heel * foot.x - s.h_ankle * foot.y)
    toe = ankle.locatenew(f"{side}_toe", s.x_toe * foot.x - s.h_ankle * foot.y)
    for point, base, frame in (
        (thigh_com, hip, thigh),
        (knee, hip, thigh),
        (shank_com, knee, shank),
        (ankle, knee, shank),
        (foot_com, ankle, foot),
        (heel, ankle, foot),
        (toe, ankle, foot),
    ):
        point.v2pt_theory(base, ground, frame)
    return (thigh, shank, foot), (thigh_com, shank_com, foot_com, heel, toe)


def _xreplace(exprs: Any, mapping: dict) -> Any:
    if isinstance(exprs, sm.Basic | sm.MatrixBase):
        return exprs.xreplace(mapping)
    if isinstance(exprs, Iterable):
        return [_xreplace(e, mapping) for e in exprs]
    return exprs
