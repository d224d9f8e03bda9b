"""The planar gait plant against independent hand computations in NumPy."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me
from scipy.integrate import solve_ivp
from scipy.optimize import fsolve

from colloc.models.gait2d import CONTACT_POINT_NAMES, derive
from colloc.models.gait2d_contact import ContactSymbols, contact_force
from colloc.models.gait2d_params import load_parameters

SIDES = {"right": (3, 4, 5), "left": (6, 7, 8)}


@pytest.fixture(scope="module")
def gait():
    return derive()


@pytest.fixture(scope="module")
def params():
    return load_parameters(75.0, 1.80)


@pytest.fixture(scope="module")
def dynamics(gait):
    return gait.dynamics_function()


@pytest.fixture(scope="module")
def contact_fn(gait):
    names = CONTACT_POINT_NAMES
    return gait.lambdify(
        [
            [gait.contact_points[n] for n in names],
            [gait.contact_velocities[n] for n in names],
            [gait.contact_forces[n] for n in names],
        ]
    )


# ------------------------------------------------------------ independent kinematics (NumPy)
def forward_kinematics(q, p):
    """Segment CoMs (with mass, inertia, absolute angle) and contact points, by hand."""

    def down(angle):  # unit vector along a segment's -y axis
        return np.array([np.sin(angle), -np.cos(angle)])

    hip = np.array([q[0], q[1]])
    a = q[2]
    segments = [(p.trunk.mass, p.trunk.inertia, a, hip - p.trunk.com * down(a))]
    points = {}
    for side, (ih, ik, ia) in SIDES.items():
        th = a + q[ih]
        sh = th + q[ik]
        ft = sh + q[ia]
        knee = hip + p.thigh.length * down(th)
        ankle = knee + p.shank.length * down(sh)
        ex = np.array([np.cos(ft), np.sin(ft)])
        ey = np.array([-np.sin(ft), np.cos(ft)])
        segments += [
            (p.thigh.mass, p.thigh.inertia, th, hip + p.thigh.com * down(th)),
            (p.shank.mass, p.shank.inertia, sh, knee + p.shank.com * down(sh)),
            (p.foot.mass, p.foot.inertia, ft, ankle + p.foot_com_x * ex - p.foot_com_y * ey),
        ]
        points[f"{side}_heel"] = ankle + p.heel_x * ex - p.ankle_height * ey
        points[f"{side}_toe"] = ankle + p.toe_x * ex - p.ankle_height * ey
        points[f"{side}_ankle"] = ankle
        points[f"{side}_knee"] = knee
    return segments, points


def numeric_mass_matrix(q, p, h=1e-6):
    """sum m J^T J + I w^T w with the Jacobians from central differences of the kinematics."""
    n = len(q)
    base = forward_kinematics(q, p)[0]
    jac = [np.zeros((2, n)) for _ in base]
    jw = [np.zeros(n) for _ in base]
    for j in range(n):
        dq = np.zeros(n)
        dq[j] = h
        plus = forward_kinematics(q + dq, p)[0]
        minus = forward_kinematics(q - dq, p)[0]
        for i, (sp, sm_) in enumerate(zip(plus, minus, strict=True)):
            jac[i][:, j] = (sp[3] - sm_[3]) / (2 * h)
            jw[i][j] = (sp[2] - sm_[2]) / (2 * h)
    return sum(
        m * J.T @ J + inertia * np.outer(w, w)
        for (m, inertia, _, _), J, w in zip(base, jac, jw, strict=True)
    )


def random_state(seed, hip_y=1.0):
    rng = np.random.default_rng(seed)
    q = rng.uniform(-0.8, 0.8, 9)
    q[0], q[1] = rng.uniform(-1, 1), hip_y
    return q, rng.normal(0, 1.0, 9)


# ------------------------------------------------------------------------------- tests
def test_sizes_and_symbols(gait):
    assert len(gait.coordinates) == len(gait.speeds) == 9
    assert [str(T.func) for T in gait.torques] == ["Tb", "Tc", "Td", "Te", "Tf", "Tg"]
    assert gait.kane.mass_matrix.shape == (9, 9)
    assert len(gait.constants) == len(set(gait.constants)) == 25
    free = (gait.kane.forcing.free_symbols | gait.kane.mass_matrix.free_symbols) - {
        me.dynamicsymbols._t
    }
    assert free == set(gait.constants)


def test_total_mass_and_center_of_mass(gait, params):
    values = gait.constant_values(params)
    assert float(gait.total_mass.xreplace(values)) == pytest.approx(
        75.0 * (0.678 + 2 * (0.1 + 0.0465 + 0.0145)), rel=1e-14
    )
    com = gait.lambdify(list(gait.center_of_mass))
    pv = gait.constant_array(params)
    for seed in range(3):
        q, u = random_state(seed)
        segments, _ = forward_kinematics(q, p=params)
        masses = np.array([s[0] for s in segments])
        expected = sum(s[0] * s[3] for s in segments) / masses.sum()
        got = np.array(com(q, u, np.zeros(6), 0.0, pv), dtype=float)
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-14)


def test_mass_matrix_symmetric_positive_definite_and_matches_jacobians(gait, params, dynamics):
    pv = gait.constant_array(params)
    for seed in range(4):
        q, u = random_state(seed)
        mass, _ = dynamics(q, u, np.zeros(6), 0.0, pv)
        np.testing.assert_allclose(mass, mass.T, rtol=0, atol=1e-12)
        assert np.linalg.eigvalsh(mass).min() > 0
        np.testing.assert_allclose(mass, numeric_mass_matrix(q, params), rtol=0, atol=1e-7)


def test_contact_points_and_velocities_match_hand_kinematics(gait, params, contact_fn):
    pv = gait.constant_array(params)
    q, u = random_state(7)
    pos, vel, _ = contact_fn(q, u, np.zeros(6), 0.0, pv)
    _, points = forward_kinematics(q, params)
    h = 1e-6
    _, ahead = forward_kinematics(q + h * u, params)
    _, behind = forward_kinematics(q - h * u, params)
    for i, name in enumerate(CONTACT_POINT_NAMES):
        np.testing.assert_allclose(np.array(pos[i], float), points[name], atol=1e-14)
        rate = (ahead[name] - behind[name]) / (2 * h)
        np.testing.assert_allclose(np.array(vel[i], float), rate, atol=1e-8)


def test_contact_force_matches_published_formula(gait, params, contact_fn):
    k, c, mu, vs = 5e7, 0.85, 1.0, 0.01
    q, u = random_state(3, hip_y=0.90)  # some points inside the floor, some above it
    belt = 1.3
    for eps in (1e-4, 1e-12):
        pv = gait.constant_array(params, {gait.contact_symbols.smoothing: eps})
        pos, vel, forces = contact_fn(q, u, np.zeros(6), belt, pv)
        heights = [y for _, y in pos]
        assert min(heights) < -0.005 and max(heights) > 0.005  # both regimes exercised
        for (_, y), (xd, yd), (fx, fy) in zip(pos, vel, forces, strict=True):
            d = (np.hypot(y, eps) - y) / 2
            fy_ref = (k * d**3 - 1.0 * y) * (1 - c * yd)
            fx_ref = -mu * fy_ref * (2 / (1 + np.exp(-(xd + belt) / vs)) - 1)
            assert fy == pytest.approx(fy_ref, rel=1e-12, abs=1e-12)
            assert fx == pytest.approx(fx_ref, rel=1e-9, abs=1e-9)
            if eps == 1e-12:  # the smoothing vanishes: the non-smooth published (|y| - y) / 2
                d_exact = (abs(y) - y) / 2
                assert fy == pytest.approx(
                    (k * d_exact**3 - y) * (1 - c * yd), rel=1e-10, abs=1e-10
                )


def test_contact_force_has_finite_second_derivative_at_touchdown():
    y = sm.Symbol("y", real=True)
    cs = ContactSymbols.create()
    _, fy = contact_force(y, sm.Integer(0), sm.Integer(0), cs)
    values = {cs.stiffness: 5e7, cs.linear_stiffness: 1.0, cs.damping: 0.85, cs.smoothing: 1e-3}
    second = float(fy.diff(y, 2).xreplace(values).subs(y, 0))
    f = sm.lambdify(y, fy.xreplace(values))
    h = 1e-5
    fd = (f(h) - 2 * f(0.0) + f(-h)) / h**2
    assert np.isfinite(second)
    assert second == pytest.approx(fd, rel=1e-4)


def test_friction_opposes_slip_relative_to_belt(gait, params, contact_fn):
    # Standing still on a treadmill whose surface moves backward at v > 0: the belt drags
    # the feet backward (Fx < 0); moving forward (v < 0) drags them forward.
    pv = gait.constant_array(params)
    q = np.zeros(9)
    q[1] = params.thigh.length + params.shank.length + params.ankle_height - 0.01
    for belt, sign in ((1.0, -1.0), (-1.0, 1.0)):
        _, _, forces = contact_fn(q, np.zeros(9), np.zeros(6), belt, pv)
        for fx, fy in forces:
            assert fy > 0
            assert np.sign(fx) == sign
            assert abs(fx) == pytest.approx(fy * np.tanh(1.0 / 0.02), rel=1e-12)
    _, _, forces = contact_fn(q, np.zeros(9), np.zeros(6), 0.0, pv)
    assert all(fx == 0.0 for fx, _ in forces)


def test_energy_conserved_in_free_flight(gait, params, dynamics):
    s = gait.contact_symbols
    # Contact "off": the weak linear spring removed, feet 2 m above the floor (k d^3 ~ 1e-20 N).
    pv = gait.constant_array(params, {s.linear_stiffness: 0.0})
    energy = gait.lambdify(gait.energy)
    q0, u0 = random_state(11, hip_y=3.0)
    u0[1] = 5.0  # thrown upward: stays above 3 m for the whole second

    def rhs(_, x):
        mass, forcing = dynamics(x[:9], x[9:], np.zeros(6), 0.0, pv)
        return np.concatenate([x[9:], np.linalg.solve(mass, forcing)])

    sol = solve_ivp(
        rhs,
        (0.0, 1.0),
        np.concatenate([q0, u0]),
        method="DOP853",
        rtol=1e-10,
        atol=1e-10,
        dense_output=True,
    )
    assert sol.success
    states = sol.sol(np.linspace(0.0, 1.0, 21)).T
    e = np.array([energy(x[:9], x[9:], np.zeros(6), 0.0, pv) for x in states])
    assert sol.y[1].min() > 2.5  # really in flight
    assert np.abs(e - e[0]).max() / abs(e[0]) < 1e-6
    # and the energy expression itself: 1/2 u^T M u + m g y_com from the hand kinematics
    mass_num = numeric_mass_matrix(q0, params)
    segments, _ = forward_kinematics(q0, params)
    potential = params.gravity * sum(m * pos[1] for m, _, _, pos in segments)
    assert e[0] == pytest.approx(0.5 * u0 @ mass_num @ u0 + potential, rel=1e-8)


def test_static_standing_supports_body_weight_and_inverse_dynamics(
    gait, params, dynamics, contact_fn
):
    pv = gait.constant_array(params)
    zero_u = np.zeros(9)

    def pose(z):  # feet flat: the body leans by z[1] about the ankles
        hip_y, lean = z
        return np.array([0.0, hip_y, lean, 0.0, 0.0, -lean, 0.0, 0.0, -lean])

    def root_equations(z):
        _, forcing = dynamics(pose(z), zero_u, np.zeros(6), 0.0, pv)
        return forcing[1:3]  # vertical force and whole-body moment balance

    leg = params.thigh.length + params.shank.length + params.ankle_height
    z, _, ok, msg = fsolve(root_equations, [leg - 0.01, 0.0], full_output=True, xtol=1e-13)
    assert ok == 1, msg
    q = pose(z)
    pos, _, forces = contact_fn(q, zero_u, np.zeros(6), 0.0, pv)
    fy = np.array([f[1] for f in forces])
    weight = 75.0 * (0.678 + 2 * (0.1 + 0.0465 + 0.0145)) * 9.81
    assert fy.sum() == pytest.approx(weight, rel=1e-9)
    assert all(f[0] == 0.0 for f in forces)
    # feet flat, so heel and toe sink equally
    assert pos[0][1] == pytest.approx(pos[1][1], abs=1e-14)

    # inverse dynamics: the forcing is affine in the torques, solve the six joint rows
    f0 = dynamics(q, zero_u, np.zeros(6), 0.0, pv)[1]
    basis = np.array([dynamics(q, zero_u, e, 0.0, pv)[1] - f0 for e in np.eye(6)]).T
    torques = np.linalg.solve(basis[3:], -f0[3:])
    assert abs(f0[0]) < 1e-9  # no horizontal force

    # hand statics: the torque on each distal chain balances the moments of its loads
    segments, points = forward_kinematics(q, params)
    g = params.gravity
    for side, (ih, ik, ia) in SIDES.items():
        offset = 1 if side == "right" else 4
        thigh, shank, foot = segments[offset : offset + 3]
        heel, toe = forces[0 if side == "right" else 2], forces[1 if side == "right" else 3]
        loads = [(seg[3], np.array([0.0, -seg[0] * g])) for seg in (thigh, shank, foot)]
        loads += [(points[f"{side}_heel"], np.array(heel)), (points[f"{side}_toe"], np.array(toe))]
        joints = {
            ih: np.array([q[0], q[1]]),
            ik: points[f"{side}_knee"],
            ia: points[f"{side}_ankle"],
        }
        for index, chain in ((ih, loads), (ik, loads[1:]), (ia, loads[2:])):
            r0 = joints[index]
            moment = sum((r - r0)[0] * f[1] - (r - r0)[1] * f[0] for r, f in chain)
            assert torques[index - 3] == pytest.approx(-moment, rel=1e-9, abs=1e-9)


def test_to_model_residual_vanishes_on_the_equations_of_motion(gait, params, dynamics):
    model = gait.to_model()
    assert model.num_states == 18
    assert model.controlled_inputs == gait.torques
    assert model.known_inputs == (gait.belt_speed,)
    assert set(model.parameters) == set(gait.constants)
    q, u = random_state(5, hip_y=0.97)
    torques = np.linspace(-20, 20, 6)
    pv = gait.constant_array(params)
    mass, forcing = dynamics(q, u, torques, 0.7, pv)
    udot = np.linalg.solve(mass, forcing)
    values = dict(zip(model.states, np.concatenate([q, u]), strict=True))
    values |= dict(zip(model.state_derivatives, np.concatenate([u, udot]), strict=True))
    values |= dict(zip(model.inputs, [*torques, 0.7], strict=True))
    values |= gait.constant_values(params)
    ordered = list(values)
    plain = sm.symbols(f"z:{len(ordered)}")
    residual = model.residual.xreplace(dict(zip(ordered, plain, strict=True)))
    f = sm.lambdify([plain], residual, cse=True)
    np.testing.assert_allclose(np.ravel(f([values[k] for k in ordered])), 0.0, atol=1e-8)


def test_unknown_override_raises(gait, params):
    with pytest.raises(ValueError, match=r"overrides: expected constants .* found unknown zz"):
        gait.constant_values(params, {sm.Symbol("zz"): 1.0})
