"""colloc.model.linearize against analytic results, a second method and finite differences."""

from dataclasses import replace

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import (
    KanesMethod,
    LagrangesMethod,
    Lagrangian,
    Particle,
    Point,
    ReferenceFrame,
    RigidBody,
    dynamicsymbols,
    inertia,
)

from colloc.model.linearize import linearize
from colloc.model.model import Model
from colloc.model.op_point import (
    OperatingPointError,
    resolve_mapping,
    resolve_sequence,
    variable_name,
)
from colloc.model.state_space import StateSpace

t = dynamicsymbols._t


# --------------------------------------------------------------------------- systems
def nonminimal_pendulum(g):
    """The source document's pendulum: coordinates x, y of the bob, one length constraint."""
    q1, q2 = dynamicsymbols("q1:3")
    L, m = sm.symbols("L m")
    N = ReferenceFrame("N")
    origin = Point("O")
    origin.set_vel(N, 0)
    bob = origin.locatenew("P", q1 * N.x + q2 * N.y)
    bob.set_vel(N, bob.pos_from(origin).dt(N))
    lm = LagrangesMethod(
        Lagrangian(N, Particle("pP", bob, m)),
        [q1, q2],
        hol_coneqs=sm.Matrix([q1**2 + q2**2 - L**2]),
        forcelist=[(bob, m * g * N.x)],
        frame=N,
    )
    lm.form_lagranges_equations()
    return lm, q1, q2, L, m


def cart_pendulum(n, method="kane"):
    """Cart (mass m0, spring k, damper c, force F) carrying n inverted massless links with
    point masses m_i, joint torques T_i between neighbouring links, absolute angles."""
    q = dynamicsymbols(f"q0:{n + 1}")
    u = dynamicsymbols(f"u0:{n + 1}") if method == "kane" else [qi.diff(t) for qi in q]
    F = dynamicsymbols("F")
    T = dynamicsymbols(f"T1:{n + 1}")
    m = sm.symbols(f"m0:{n + 1}")
    lengths = sm.symbols(f"l1:{n + 1}")
    g, k, c = sm.symbols("g k c")
    N = ReferenceFrame("N")
    origin = Point("O")
    origin.set_vel(N, 0)
    joint = origin.locatenew("P0", q[0] * N.x)
    joint.set_vel(N, u[0] * N.x)
    particles = [Particle("pa0", joint, m[0])]
    loads = [(joint, (F - k * q[0] - c * u[0]) * N.x - m[0] * g * N.y)]
    previous = None
    for i in range(1, n + 1):
        frame = N.orientnew(f"A{i}", "Axis", [q[i], N.z])
        frame.set_ang_vel(N, u[i] * N.z)
        point = joint.locatenew(f"P{i}", lengths[i - 1] * frame.y)
        point.v2pt_theory(joint, N, frame)
        particles.append(Particle(f"pa{i}", point, m[i]))
        loads += [(point, -m[i] * g * N.y), (frame, T[i - 1] * N.z)]
        if previous is not None:
            loads.append((previous, -T[i - 1] * N.z))
        previous, joint = frame, point
    constants = dict(zip(m, [2.0, 0.7, 0.5, 0.3][: n + 1], strict=True))
    constants.update(zip(lengths, [0.9, 0.6, 0.5][:n], strict=True))
    constants.update({g: 9.81, k: 3.0, c: 0.4})
    if method == "kane":
        km = KanesMethod(N, q, u, kd_eqs=[qi.diff(t) - ui for qi, ui in zip(q, u, strict=True)])
        km.kanes_equations(particles, loads)
        return km, constants
    lm = LagrangesMethod(Lagrangian(N, *particles), q, forcelist=loads, frame=N)
    lm.form_lagranges_equations()
    return lm, constants


def chaplygin_sled():
    """Planar body on a knife edge at P (no sideways slip), mass centre a ahead of P,
    drag c on the mass centre, thrust F along the blade, yaw torque T."""
    x, y, th = dynamicsymbols("x y theta")
    u1, u2, u3 = dynamicsymbols("u1:4")
    F, T = dynamicsymbols("F T")
    m, izz, a, c = sm.symbols("m I_zz a c")
    N = ReferenceFrame("N")
    B = N.orientnew("B", "Axis", [th, N.z])
    B.set_ang_vel(N, u3 * N.z)
    origin = Point("O")
    origin.set_vel(N, 0)
    contact = origin.locatenew("P", x * N.x + y * N.y)
    contact.set_vel(N, u1 * N.x + u2 * N.y)
    centre = contact.locatenew("G", a * B.x)
    centre.v2pt_theory(contact, N, B)
    body = RigidBody("sled", centre, B, m, (inertia(B, 0, 0, izz), centre))
    loads = [(contact, F * B.x), (centre, -c * centre.vel(N)), (B, T * N.z)]
    km = KanesMethod(
        N,
        [x, y, th],
        [u1, u3],
        kd_eqs=[x.diff(t) - u1, y.diff(t) - u2, th.diff(t) - u3],
        u_dependent=[u2],
        velocity_constraints=[contact.vel(N).dot(B.y)],
    )
    km.kanes_equations([body], loads)
    constants = {m: 1.5, izz: 0.2, a: 0.3, c: 0.8}
    return km, constants


# --------------------------------------------------------------------------- references
def kane_rhs(km, constants, u_ind, u_dep):
    """Nonlinear x' = f(x, r) on x = [q, u_ind] with u_dep from the motion constraints."""
    q, u = list(km.q), list(km.u)
    r = sorted(
        {s for s in km.forcing.atoms(sm.Function) if s.args == (t,)} - set(q) - set(u), key=str
    )
    full_m = km.mass_matrix_full.xreplace(constants)
    full_f = km.forcing_full.xreplace(constants)
    args = q + u + r
    m_fun, f_fun = sm.lambdify(args, full_m), sm.lambdify(args, full_f)
    dep_fun = None
    if u_dep:
        sol = sm.solve(list(km.to_linearizer().f_v), list(u_dep), dict=True)[0]
        dep_fun = sm.lambdify(q + list(u_ind), [sol[v] for v in u_dep])
    n = len(q)

    def f(xv, rv):
        qv, uiv = list(xv[:n]), list(xv[n:])
        values = dict(zip(u_ind, uiv, strict=True))
        if dep_fun is not None:
            values.update(zip(u_dep, dep_fun(*qv, *uiv), strict=True))
        uv = [values[v] for v in u]
        a = np.asarray(m_fun(*qv, *uv, *rv), dtype=float)
        b = np.asarray(f_fun(*qv, *uv, *rv), dtype=float).ravel()
        xd = np.linalg.solve(a, b)
        return np.concatenate([xd[:n], [xd[n + u.index(v)] for v in u_ind]])

    return f, r


def central_jacobians(f, x0, r0, h=1e-6):
    f0 = f(x0, r0)
    a = np.zeros((f0.size, x0.size))
    b = np.zeros((f0.size, r0.size))
    for j in range(x0.size):
        e = np.zeros(x0.size)
        e[j] = h
        a[:, j] = (f(x0 + e, r0) - f(x0 - e, r0)) / (2 * h)
    for j in range(r0.size):
        e = np.zeros(r0.size)
        e[j] = h
        b[:, j] = (f(x0, r0 + e) - f(x0, r0 - e)) / (2 * h)
    return a, b


# --------------------------------------------------------------------------- tests
def test_document_pendulum_multiplier_substituted():
    lm, q1, q2, L, m = nonminimal_pendulum(9.8)
    op = {q1: L, q2: 0, q1.diff(t): 0, q2.diff(t): 0}
    ss = linearize(lm, op, q_ind=[q2], q_dep=[q1], equilibrium=True)
    assert isinstance(ss, StateSpace)
    assert ss.state_names == ("q2", "q2_dot")
    assert ss.input_names == ()
    assert sm.simplify(ss.A - sm.Matrix([[0, 1], [-9.8 / L, 0]])) == sm.zeros(2, 2)
    assert ss.B.shape == (2, 0)
    # The multiplier enforcing |OP| = L carries the weight: 2 lam L = m g, lam = m g / (2 L).
    lam = lm.lam_vec[0]
    assert sm.simplify(ss.op_point[lam] - 4.9 * m / L) == 0


def test_document_pendulum_symbolic_gravity_and_names():
    g = sm.Symbol("g")
    lm, q1, q2, L, m = nonminimal_pendulum(g)
    op = {"q1": L, "q2": 0, "q1_dot": 0, "q2_dot": 0, "q1_ddot": 0, "q2_ddot": 0}
    ss = linearize(lm, op, q_dep=["q1"])
    assert sm.simplify(ss.A - sm.Matrix([[0, 1], [-g / L, 0]])) == sm.zeros(2, 2)
    A, B = ss.to_numpy({"g": 9.81, L: 0.5})
    np.testing.assert_allclose(A, [[0, 1], [-9.81 / 0.5, 0]])
    assert B.shape == (2, 0)
    num = linearize(lm, op, q_dep=["q1"], constants={g: 9.81, "L": 0.5})
    assert num.is_numeric
    np.testing.assert_allclose(num.A, [[0, 1], [-19.62, 0]])
    # Bob on the side: q2 = L, q1 = 0 makes q1 the bad dependent choice.
    side = {"q1": 0, "q2": L, "q1_dot": 0, "q2_dot": 0, "q1_ddot": 0, "q2_ddot": 0}
    with pytest.raises(
        OperatingPointError, match=r"q_dep: the constraints cannot be solved for \['q1'\]"
    ):
        linearize(lm, side, q_dep=["q1"])


def test_document_pendulum_not_an_equilibrium():
    lm, q1, q2, L, m = nonminimal_pendulum(9.8)
    c, s = sm.cos(sm.Rational(1, 3)), sm.sin(sm.Rational(1, 3))
    op = {q1: L * c, q2: L * s, q1.diff(t): 0, q2.diff(t): 0}
    with pytest.raises(
        OperatingPointError,
        match=r"(?s)not an equilibrium, dynamic equation 0 has residual -1.049.*q2_ddot = -3.03",
    ):
        linearize(lm, op, q_dep=[q1], equilibrium=True, constants={L: 1, m: 1})


@pytest.mark.parametrize("n", [1, 2, 3])
def test_cart_pendulum_matches_finite_differences(n):
    km, constants = cart_pendulum(n)
    f, r = kane_rhs(km, constants, list(km.u), [])
    rng = np.random.default_rng(100 + n)
    x0 = rng.normal(scale=0.5, size=2 * (n + 1))
    r0 = rng.normal(size=n + 1)
    xd0 = f(x0, r0)
    op = dict(zip(list(km.q) + list(km.u), x0, strict=True))
    op.update({ui.diff(t): v for ui, v in zip(km.u, xd0[n + 1 :], strict=True)})
    op.update(zip(r, r0, strict=True))
    ss = linearize(km, op, constants=constants)
    a_fd, b_fd = central_jacobians(f, x0, r0)
    assert ss.input_names == tuple(str(v.func) for v in r)
    np.testing.assert_allclose(ss.A, a_fd, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(ss.B, b_fd, rtol=1e-6, atol=1e-6)
    # One explicit step of the nonlinear system from a perturbed state agrees with the
    # linear prediction to second order in the perturbation.
    dx, dr, h = 1e-4 * rng.normal(size=x0.size), 1e-4 * rng.normal(size=r0.size), 0.01
    step_nl = (x0 + dx + h * f(x0 + dx, r0 + dr)) - (x0 + h * xd0)
    step_lin = dx + h * (ss.A @ dx + ss.B @ dr)
    np.testing.assert_allclose(step_nl, step_lin, atol=1e-8)


def test_cart_pendulum_equilibrium_and_lqr_shapes():
    km, constants = cart_pendulum(2)
    ss = linearize(
        km,
        {"q0": 0, "q1": 0, "q2": 0, "u0": 0, "u1": 0, "u2": 0},
        constants=constants,
        equilibrium=True,
        inputs=["T1", "T2"],
    )
    f, r = kane_rhs(km, constants, list(km.u), [])
    a_fd, b_fd = central_jacobians(f, np.zeros(6), np.zeros(3))
    np.testing.assert_allclose(ss.A, a_fd, atol=1e-6)
    np.testing.assert_allclose(ss.B, b_fd[:, [r.index(v) for v in ss.inputs]], atol=1e-6)
    assert ss.input_names == ("T1", "T2")
    # Upright links are unstable.
    assert np.max(np.linalg.eigvals(ss.A).real) > 0.1
    with pytest.raises(
        OperatingPointError, match=r"(?s)dynamic equation 0 has residual -0.6.*u0_dot = -0.3"
    ):
        linearize(
            km,
            {"q0": 0.2, "q1": 0, "q2": 0, "u0": 0, "u1": 0, "u2": 0},
            constants=constants,
            equilibrium=True,
        )


def test_kane_and_lagrange_agree_symbolically():
    km, _ = cart_pendulum(1)
    lm, _ = cart_pendulum(1, method="lagrange")
    zeros_k = {v: 0 for v in list(km.q) + list(km.u)}
    zeros_l = {v: 0 for v in list(lm.q) + [qi.diff(t) for qi in lm.q]}
    sk = linearize(km, zeros_k, equilibrium=True)
    sl = linearize(lm, zeros_l, equilibrium=True)
    assert sk.input_names == sl.input_names == ("F", "T1")
    assert sl.state_names == ("q0", "q1", "q0_dot", "q1_dot")
    assert sm.simplify(sk.A - sl.A) == sm.zeros(4, 4)
    assert sm.simplify(sk.B - sl.B) == sm.zeros(4, 2)


def test_kane_and_lagrange_agree_numerically_off_equilibrium():
    km, constants = cart_pendulum(2)
    lm, _ = cart_pendulum(2, method="lagrange")
    f, r = kane_rhs(km, constants, list(km.u), [])
    x0 = np.array([0.1, 0.3, -0.2, 0.5, -0.4, 0.2])
    r0 = np.array([0.3, -0.1, 0.2])
    xd0 = f(x0, r0)
    op_k = dict(zip(list(km.q) + list(km.u), x0, strict=True))
    op_k.update({v.diff(t): a for v, a in zip(km.u, xd0[3:], strict=True)})
    qd = [qi.diff(t) for qi in lm.q]
    op_l = dict(zip(list(lm.q) + qd, x0, strict=True))
    op_l.update({v.diff(t): a for v, a in zip(qd, xd0[3:], strict=True)})
    for op in (op_k, op_l):
        op.update(zip(r, r0, strict=True))
    sk = linearize(km, op_k, constants=constants)
    sl = linearize(lm, op_l, constants=constants)
    np.testing.assert_allclose(sk.A, sl.A, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(sk.B, sl.B, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("theta", [0.0, 0.4])
def test_nonholonomic_sled_matches_finite_differences(theta):
    km, constants = chaplygin_sled()
    u1, u2, u3 = dynamicsymbols("u1:4")
    f, r = kane_rhs(km, constants, [u1, u3], [u2])
    x0 = np.array([0.5, -0.2, theta, 1.2, 0.3])
    r0 = np.array([0.7, -0.2])
    xd0 = f(x0, r0)
    ud0 = {u1: xd0[3], u3: xd0[4]}
    # u2 = tan(theta) u1 on the constraint; its derivative by the chain rule.
    sec2 = 1 / np.cos(theta) ** 2
    ud0[u2] = sec2 * x0[4] * x0[3] + np.tan(theta) * xd0[3]
    op = {
        "x": 0.5,
        "y": -0.2,
        "theta": theta,
        "u1": 1.2,
        "u3": 0.3,
        "u2": np.tan(theta) * 1.2,
        "F": 0.7,
        "T": -0.2,
    }
    op.update({v.diff(t): val for v, val in ud0.items()})
    ss = linearize(km, op, constants=constants)
    assert ss.state_names == ("x", "y", "theta", "u1", "u3")
    a_fd, b_fd = central_jacobians(f, x0, r0)
    np.testing.assert_allclose(ss.A, a_fd, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(ss.B, b_fd, rtol=1e-6, atol=1e-6)


def test_nonholonomic_sled_other_split_and_steady_motion():
    km, constants = chaplygin_sled()
    u1, u2, u3 = dynamicsymbols("u1:4")
    theta = 0.4
    # Choose u1 dependent instead of Kane's u2; the state becomes [q, u2, u3].
    # Kane's speeds are ordered [u1, u3, u2]; u3 then u2 is a cyclic reordering.
    f, r = kane_rhs(km, constants, [u3, u2], [u1])
    x0 = np.array([0.0, 0.0, theta, -0.3, 0.5])
    r0 = np.array([0.2, 0.1])
    xd0 = f(x0, r0)
    u1_0 = 0.5 / np.tan(theta)
    f_full, _ = kane_rhs(km, constants, [u1, u3], [u2])
    ud_full = f_full(np.array([0.0, 0.0, theta, u1_0, -0.3]), r0)
    op = {
        "x": 0,
        "y": 0,
        "theta": theta,
        "u1": u1_0,
        "u2": 0.5,
        "u3": -0.3,
        "F": 0.2,
        "T": 0.1,
        "u1_dot": ud_full[3],
        "u2_dot": xd0[4],
        "u3_dot": xd0[3],
    }
    ss = linearize(km, op, u_dep=["u1"], constants=constants)
    assert ss.state_names == ("x", "y", "theta", "u3", "u2")
    a_fd, b_fd = central_jacobians(f, x0, r0)
    np.testing.assert_allclose(ss.A, a_fd, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(ss.B, b_fd, rtol=1e-6, atol=1e-6)
    # Straight steady motion at speed v with thrust F = c v balancing the drag.
    v = 2.0
    steady = {"x": 0, "y": 0, "theta": 0, "u1": v, "u2": 0, "u3": 0, "F": 0.8 * v, "T": 0}
    ss = linearize(km, steady, constants=constants, equilibrium=True)
    a_fd, _ = central_jacobians(f_full, np.array([0, 0, 0, v, 0.0]), np.array([0.8 * v, 0]))
    np.testing.assert_allclose(ss.A, a_fd, atol=1e-6)
    # At theta = 0 the constraint does not involve u1: u1 cannot be the dependent speed.
    with pytest.raises(
        OperatingPointError, match=r"u_dep: the constraints cannot be solved for \['u1'\]"
    ):
        linearize(km, steady, u_dep=[u1], constants=constants, equilibrium=True)
    with pytest.raises(OperatingPointError, match=r"op_point: violates motion constraint 0"):
        linearize(km, {**steady, "u2": 1.0}, constants=constants, equilibrium=True)


def test_model_path_matches_kane():
    km, constants = cart_pendulum(2)
    model = Model.from_kane(
        km, controlled_inputs=dynamicsymbols("T1:3"), known_inputs=[dynamicsymbols("F")]
    )
    f, r = kane_rhs(km, constants, list(km.u), [])
    x0 = np.array([0.1, 0.3, -0.2, 0.5, -0.4, 0.2])
    r0 = np.array([0.3, -0.1, 0.2])
    xd0 = f(x0, r0)
    op = dict(zip(model.states, x0, strict=True))
    op.update(zip(model.state_derivatives, xd0, strict=True))
    op.update(zip(r, r0, strict=True))
    sm_ss = linearize(model, op, constants=constants, inputs=r)
    op_k = {k: v for k, v in op.items() if k not in [q.diff(t) for q in km.q]}
    sk = linearize(km, op_k, constants=constants)
    assert sm_ss.state_names == sk.state_names
    np.testing.assert_allclose(sm_ss.A, sk.A, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(sm_ss.B, sk.B, rtol=1e-9, atol=1e-9)
    eq = linearize(model, {v: 0 for v in model.states}, equilibrium=True, constants=constants)
    a_fd, b_fd = central_jacobians(f, np.zeros(6), np.zeros(3))
    np.testing.assert_allclose(eq.A, a_fd, atol=1e-6)
    assert eq.input_names == ("T1", "T2", "F")
    np.testing.assert_allclose(eq.B, b_fd[:, [1, 2, 0]], atol=1e-6)
    with pytest.raises(OperatingPointError, match=r"residual row 4 is"):
        linearize(
            model,
            {**{variable_name(v): 0 for v in model.states}, "q1": 0.3},
            equilibrium=True,
            constants=constants,
        )


def test_model_errors():
    lm, q1, q2, L, m = nonminimal_pendulum(9.8)
    model = Model.from_lagrange(lm)
    op = {variable_name(v): 0 for v in model.states + model.state_derivatives}
    op["q1"] = 1
    with pytest.raises(OperatingPointError, match=r"dF/dx' is singular.*\['lam1'\]"):
        linearize(model, op, constants={m: 1})
    km, _ = cart_pendulum(1)
    with pytest.raises(
        OperatingPointError, match=r"(?s)q_ind: a colloc.Model.*u_dep: a colloc.Model"
    ):
        linearize(
            Model.from_kane(km, known_inputs=dynamicsymbols("F T1")), {}, q_ind=["q0"], u_dep=["u0"]
        )


def test_op_point_errors_name_every_problem():
    km, constants = cart_pendulum(1)
    with pytest.raises(OperatingPointError) as info:
        linearize(km, {"q0": 0, "u0": "0", "w": 1, sm.Symbol("z"): 2}, constants=constants)
    msg = str(info.value)
    assert "missing entries for ['q1', 'u1', 'u0_dot', 'u1_dot']" in msg
    assert "unexpected entries ['w', 'z']" in msg
    assert "value of u0 must be a number" in msg
    with pytest.raises(
        OperatingPointError, match=r"equilibrium=True needs zero derivatives.*u1_dot = 1"
    ):
        linearize(km, {"q0": 0, "q1": 0, "u0": 0, "u1": 0, "u1_dot": 1}, equilibrium=True)
    with pytest.raises(
        OperatingPointError, match=r"constants: .*found unknown|unexpected entries \['mass'\]"
    ):
        linearize(km, {"q0": 0, "q1": 0, "u0": 0, "u1": 0}, equilibrium=True, constants={"mass": 1})
    with pytest.raises(OperatingPointError, match=r"inputs: expected entries from \['F', 'T1'\]"):
        linearize(km, {"q0": 0, "q1": 0, "u0": 0, "u1": 0}, equilibrium=True, inputs=["T2"])
    with pytest.raises(OperatingPointError, match=r"numeric: expected numbers only.*\['g', 'l1'"):
        linearize(
            km,
            {"q0": 0, "q1": 0, "u0": 0, "u1": 0},
            equilibrium=True,
            numeric=True,
            constants={"m0": 1, "m1": 1, "k": 1, "c": 1},
        )


def test_split_errors():
    lm, q1, q2, L, m = nonminimal_pendulum(9.8)
    op = {q1: L, q2: 0, q1.diff(t): 0, q2.diff(t): 0}
    with pytest.raises(
        OperatingPointError, match=r"q_dep: the system has 1 configuration constraint"
    ):
        linearize(lm, op, equilibrium=True)
    with pytest.raises(OperatingPointError, match=r"q_dep: expected 1 entries.*found 2"):
        linearize(lm, op, q_dep=[q1, q2], equilibrium=True)
    with pytest.raises(OperatingPointError, match=r"both independent and dependent"):
        linearize(lm, op, q_ind=[q1, q2], q_dep=[q1], equilibrium=True)
    with pytest.raises(
        OperatingPointError,
        match=r"q_ind: expected entries from \['q1', 'q2'\], found unknown \['q3'\]",
    ):
        linearize(lm, op, q_ind=["q3"], q_dep=[q1], equilibrium=True)
    with pytest.raises(OperatingPointError, match=r"listed more than once"):
        linearize(lm, op, q_dep=[q1, "q1"], equilibrium=True)


def test_type_errors():
    with pytest.raises(TypeError, match=r"system: expected a KanesMethod.*found dict"):
        linearize({}, {})
    q, u = dynamicsymbols("q u")
    km = KanesMethod(ReferenceFrame("N"), [q], [u], kd_eqs=[q.diff(t) - u])
    with pytest.raises(TypeError, match=r"kanes_equations\(\) has been called"):
        linearize(km, {q: 0, u: 0})


def test_state_space_helpers():
    g = sm.Symbol("g")
    lm, q1, q2, L, m = nonminimal_pendulum(g)
    ss = linearize(
        lm,
        {q1: L, q2: 0, q1.diff(t): 0, q2.diff(t): 0},
        q_dep=[q1],
        equilibrium=True,
        numeric=False,
    )
    assert not ss.is_numeric
    assert "StateSpace(symbolic" in repr(ss) and "q2_dot" in repr(ss)
    assert {variable for variable in ss.free_symbols()} == {g, L}
    with pytest.raises(OperatingPointError, match=r"subs: missing values for \['g'\]"):
        ss.to_numpy({L: 1})
    with pytest.raises(OperatingPointError, match=r"subs: unexpected entries \['h'\]"):
        ss.to_numpy({L: 1, g: 1, "h": 2})
    a, b = ss.to_numpy({"L": 2, "g": 8})
    np.testing.assert_allclose(a, [[0, 1], [-4, 0]])


def polar_particle():
    """Particle in the plane in polar coordinates: mass matrix diag(m, m r^2), singular at r = 0."""
    r, th = dynamicsymbols("r theta")
    ur, uth = dynamicsymbols("u_r u_theta")
    m = sm.Symbol("m")
    N = ReferenceFrame("N")
    A = N.orientnew("A", "Axis", [th, N.z])
    A.set_ang_vel(N, uth * N.z)
    origin = Point("O")
    origin.set_vel(N, 0)
    p = origin.locatenew("P", r * A.x)
    p.set_vel(N, ur * A.x + r * uth * A.y)
    km = KanesMethod(N, [r, th], [ur, uth], kd_eqs=[r.diff(t) - ur, th.diff(t) - uth])
    km.kanes_equations([Particle("pa", p, m)], [(p, -r * A.x)])
    return km, m


def test_singular_mass_matrix_errors():
    km, m = polar_particle()
    op = {"r": 0, "theta": 0, "u_r": 0, "u_theta": 0, "u_r_dot": 0, "u_theta_dot": 0}
    with pytest.raises(OperatingPointError, match=r"mass matrix M is singular"):
        linearize(km, op, constants={m: 1})
    with pytest.raises(OperatingPointError, match=r"mass matrix M is singular"):
        linearize(km, op, numeric=False)
    with pytest.raises(OperatingPointError, match=r"equations of motion cannot be solved"):
        linearize(km, {"r": 0, "theta": 0, "u_r": 0, "u_theta": 0}, equilibrium=True)
    # Away from r = 0: r'' = -r/m + r theta'^2, theta'' = -2 r' theta' / r.
    op = {"r": 1, "theta": 0, "u_r": 0, "u_theta": 0, "u_r_dot": -0.5, "u_theta_dot": 0}
    ss = linearize(km, op, constants={m: 2})
    np.testing.assert_allclose(ss.A[2], [-0.5, 0, 0, 0])


def test_undefined_linearization_and_model_shape():
    x = dynamicsymbols("x")
    model = Model.from_equations([x.diff(t) + sm.sqrt(x)], [x])
    with pytest.raises(OperatingPointError, match=r"undefined \(division by zero\)"):
        linearize(model, {"x": 0}, equilibrium=True)
    # x' = -sqrt(x): A = -1 / (2 sqrt(x)) = -0.25 at x = 4.
    np.testing.assert_allclose(linearize(model, {"x": 4, "x_dot": -2}).A, [[-0.25]])
    bad = replace(model, residual=sm.Matrix([x.diff(t), x]))
    with pytest.raises(OperatingPointError, match=r"one equation per state, found 2 equations"):
        linearize(bad, {"x": 0, "x_dot": 0})


def test_resolution_helpers_errors():
    q1 = dynamicsymbols("q1")
    clash = dynamicsymbols("q1_dot")
    problems = []
    resolve_mapping({}, [q1.diff(t), clash], "op_point", problems)
    assert any("share the name 'q1_dot'" in p for p in problems)
    problems = []
    resolve_mapping([1, 2], [q1], "op_point", problems)
    assert problems == ["op_point: expected a dict, found list"]
    problems = []
    assert resolve_mapping({q1: 1, "q1": 2}, [q1], "op_point", problems) == {q1: 1}
    assert problems == ["op_point: q1 is given twice (object and name)"]
    problems = []
    assert resolve_sequence(["q1"], [q1], "q_ind", problems) == (q1,)
    assert problems == []


def test_split_in_neither_and_lagrange_without_equations():
    lm, q1, q2, L, m = nonminimal_pendulum(9.8)
    op = {q1: L, q2: 0, q1.diff(t): 0, q2.diff(t): 0}
    with pytest.raises(OperatingPointError, match=r"\['q2'\] are in neither"):
        linearize(lm, op, q_ind=[], q_dep=[q1], equilibrium=True)
    fresh = LagrangesMethod(lm._L, [q1, q2], frame=lm.inertial)
    with pytest.raises(TypeError, match=r"form_lagranges_equations\(\) has been called"):
        linearize(fresh, op)
