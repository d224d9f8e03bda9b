"""Tests of the n-link pendulum on a cart against the seed and against hand mechanics."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.integrate
import scipy.linalg
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc.model.model import Model
from colloc.models.pendulum_cart import PendulumCart, derive

T = dynamicsymbols._t
# The seed's LQR gains for the 1-link system (Q = I, R = I, default constants).
SEED_GAINS = np.array([-4.71764346, 19.67083668, -3.69402157, 5.57114809])


def _numeric_dynamics(sys: PendulumCart, values: dict, zero_inputs: bool = True):
    """Lambdified mass matrix and forcing of the dynamic equations, args (q, u, r)."""
    kane = sys.kane
    r = list(sys.torques) + [sys.force]
    mm = kane.mass_matrix.xreplace(values)
    fo = kane.forcing.xreplace(values)
    args = (list(sys.coordinates), list(sys.speeds), r)
    return sm.lambdify(args, mm, "numpy"), sm.lambdify(args, fo, "numpy")


def test_one_link_equations_equal_the_seed() -> None:
    sys = derive(1)
    q0, q1 = sys.coordinates
    u0, u1 = sys.speeds
    (t1,) = sys.torques
    f = sys.force
    m0, m1, l0, k, c, g = sys.constants
    ud0, ud1 = u0.diff(T), u1.diff(T)
    seed = sm.Matrix(
        [
            c * u0
            + k * q0
            + l0 * m1 * u1**2 * sm.sin(q1)
            - l0 * m1 * sm.cos(q1) * ud1
            + (m0 + m1) * ud0
            - f,
            -g * l0 * m1 * sm.sin(q1) + l0**2 * m1 * ud1 - l0 * m1 * sm.cos(q1) * ud0 - t1,
        ]
    )
    mine = sys.kane.mass_matrix * sm.Matrix([ud0, ud1]) - sys.kane.forcing
    assert sm.simplify(mine - seed) == sm.zeros(2, 1)
    assert [s.name for s in sys.constants] == ["m0", "m1", "l0", "k", "c", "g"]


def test_lqr_on_default_one_link_reproduces_the_seed_gains() -> None:
    # The seed's published gains come from LQR (Q = I, R = I) on this plant with the
    # default constants, so they check the plant, its sign conventions and the defaults.
    sys = derive(1)
    values = sys.default_constants()
    x = list(sys.coordinates) + list(sys.speeds)
    (t1,) = sys.torques
    mm = sys.kane.mass_matrix_full.xreplace(values)
    rhs = mm.LUsolve(sys.kane.forcing_full.xreplace(values))
    at_zero = {s: 0 for s in x + [t1, sys.force]}
    a = np.array(rhs.jacobian(x).xreplace(at_zero), dtype=float)
    b = np.array(rhs.jacobian([t1]).xreplace(at_zero), dtype=float)
    p = scipy.linalg.solve_continuous_are(a, b, np.eye(4), np.eye(1))
    np.testing.assert_allclose((b.T @ p).ravel(), SEED_GAINS, rtol=1e-7)


def _energy_two_links(state: np.ndarray, m: np.ndarray, lengths: np.ndarray, g: float) -> float:
    # Positions written out by hand: cart at (q0, 0), link i points along (-sin qi, cos qi).
    q0, q1, q2, u0, u1, u2 = state
    vx1 = u0 - lengths[0] * np.cos(q1) * u1
    vy1 = -lengths[0] * np.sin(q1) * u1
    vx2 = vx1 - lengths[1] * np.cos(q2) * u2
    vy2 = vy1 - lengths[1] * np.sin(q2) * u2
    y1 = lengths[0] * np.cos(q1)
    y2 = y1 + lengths[1] * np.cos(q2)
    kinetic = 0.5 * (m[0] * u0**2 + m[1] * (vx1**2 + vy1**2) + m[2] * (vx2**2 + vy2**2))
    return kinetic + g * (m[1] * y1 + m[2] * y2)


def test_free_two_link_system_conserves_energy() -> None:
    sys = derive(2)
    values = sys.default_constants(m0=1.5, m1=0.7, m2=1.2, l0=0.8, l1=1.1, k=0.0, c=0.0)
    mass, forcing = _numeric_dynamics(sys, values)
    r = [0.0, 0.0, 0.0]

    def rhs(_t: float, s: np.ndarray) -> np.ndarray:
        q, u = s[:3], s[3:]
        return np.concatenate([u, np.linalg.solve(mass(q, u, r), forcing(q, u, r).ravel())])

    s0 = np.array([0.3, 0.4, -0.9, 0.5, 1.0, -2.0])
    sol = scipy.integrate.solve_ivp(rhs, (0, 5), s0, method="DOP853", rtol=1e-12, atol=1e-12)
    assert sol.success
    m = np.array([1.5, 0.7, 1.2])
    lengths = np.array([0.8, 1.1])
    energies = np.array([_energy_two_links(s, m, lengths, 9.81) for s in sol.y.T])
    assert np.ptp(sol.y[2]) > 1.0  # the motion is not trivial
    np.testing.assert_allclose(energies, energies[0], rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("num_links", [1, 2, 3])
def test_hanging_down_with_spring_preload_is_static_equilibrium(num_links: int) -> None:
    sys = derive(num_links)
    values = sys.default_constants(k=7.0, c=2.0, m0=2.0)
    mass, forcing = _numeric_dynamics(sys, values)
    force = 3.5
    q = np.array([force / 7.0] + [np.pi] * num_links)
    u = np.zeros(num_links + 1)
    r = [0.0] * num_links + [force]
    np.testing.assert_allclose(forcing(q, u, r).ravel(), 0.0, atol=1e-12)
    # A nudge away from equilibrium must produce a restoring acceleration of the cart.
    q[0] += 0.1
    assert np.linalg.solve(mass(q, u, r), forcing(q, u, r).ravel())[0] < 0


def test_joint_torques_holding_tilted_links_match_hand_statics() -> None:
    # With absolute angles, the statics of link i read
    # T_i - T_(i+1) + g l_(i-1) sin(q_i) * (m_i + ... + m_n) = 0.
    sys = derive(3)
    m = np.array([1.0, 0.6, 1.3, 0.9])
    lengths = np.array([0.7, 1.2, 0.5])
    g = 9.81
    values = sys.default_constants(
        m0=m[0], m1=m[1], m2=m[2], m3=m[3], l0=lengths[0], l1=lengths[1], l2=lengths[2]
    )
    angles = np.array([0.3, -0.8, 1.9])
    torques = np.zeros(4)
    for i in (3, 2, 1):
        torques[i - 1] = torques[i] - g * lengths[i - 1] * np.sin(angles[i - 1]) * m[i:].sum()
    _, forcing = _numeric_dynamics(sys, values)
    q = np.concatenate([[0.0], angles])
    r = list(torques[:3]) + [0.0]
    np.testing.assert_allclose(forcing(q, np.zeros(4), r).ravel(), 0.0, atol=1e-12)
    r[1] += 0.1
    assert np.abs(forcing(q, np.zeros(4), r).ravel()).max() > 0.05


def test_mass_matrix_is_symmetric_positive_definite() -> None:
    rng = np.random.default_rng(3)
    sys = derive(3)
    for _ in range(5):
        draws = rng.uniform(0.2, 3.0, size=7)
        names = ["m0", "m1", "m2", "m3", "l0", "l1", "l2"]
        values = sys.default_constants(**dict(zip(names, draws, strict=True)))
        mass, _ = _numeric_dynamics(sys, values)
        q = rng.uniform(-np.pi, np.pi, size=4)
        u = rng.normal(size=4)
        mm = np.asarray(mass(q, u, [0.0] * 4), dtype=float)
        np.testing.assert_allclose(mm, mm.T, atol=1e-14)
        assert np.linalg.eigvalsh(mm).min() > 0
        # The cart row sums every mass: the total horizontal momentum's coefficient.
        assert mm[0, 0] == pytest.approx(draws[:4].sum())


def test_to_model_stacks_kinematic_and_dynamic_equations() -> None:
    sys = derive(2)
    model = sys.to_model()
    assert isinstance(model, Model)
    assert model.states == sys.coordinates + sys.speeds
    assert model.controlled_inputs == sys.torques
    assert model.known_inputs == (sys.force,)
    assert set(model.parameters) == set(sys.constants)
    assert set(model.outputs) == set(sys.coordinates)
    ud = sm.Matrix([u.diff(T) for u in sys.speeds])
    qd = sm.Matrix([q.diff(T) for q in sys.coordinates])
    expected = (qd - sm.Matrix(sys.speeds)).col_join(sys.kane.mass_matrix * ud - sys.kane.forcing)
    assert sm.simplify(model.residual - expected) == sm.zeros(6, 1)


def test_default_constants_values_and_overrides() -> None:
    sys = derive(2)
    values = sys.default_constants(l1=0.5, g=0.0)
    by_name = {s.name: v for s, v in values.items()}
    assert by_name == {
        "m0": 1.0,
        "m1": 1.0,
        "m2": 1.0,
        "l0": 1.0,
        "l1": 0.5,
        "k": 10.0,
        "c": 5.0,
        "g": 0.0,
    }
    assert tuple(values) == sys.constants


def test_default_constants_reports_every_problem() -> None:
    sys = derive(1)
    with pytest.raises(ValueError, match=r"unknown constant name\(s\) \['m5'\]") as info:
        sys.default_constants(m5=1.0, m1=0.0, k=-1.0, l0=float("nan"))
    message = str(info.value)
    assert "m1 (mass or length) must be > 0, found 0.0" in message
    assert "k (spring/damper constant) must be >= 0, found -1.0" in message
    assert "l0 must be finite" in message


def test_default_constants_rejects_non_numbers() -> None:
    with pytest.raises(TypeError, match=r"expected real numbers, found m0='2'"):
        derive(1).default_constants(m0="2")


@pytest.mark.parametrize(
    ("value", "error", "pattern"),
    [
        (0, ValueError, r"num_links: expected an int >= 1, found 0"),
        (1.0, TypeError, r"num_links: expected an int >= 1, found 1.0 \(float\)"),
        (True, TypeError, r"found True \(bool\)"),
    ],
)
def test_derive_rejects_bad_num_links(value: object, error: type, pattern: str) -> None:
    with pytest.raises(error, match=pattern):
        derive(value)  # type: ignore[arg-type]
