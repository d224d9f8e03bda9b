"""GainScheduled: periodic interpolation, parameter bookkeeping, structures and errors.

References are hand-computed brackets and weights, NumPy's periodic ``np.interp`` and
explicit loops; the closed-loop law is checked by substituting numbers into SymPy.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc import GainScheduled, Model

t = dynamicsymbols._t


def two_mass_model():
    q1, q2, u1, u2, T1, T2 = dynamicsymbols("q1 q2 u1 u2 T1 T2")
    m1, m2, k, c = sm.symbols("m1 m2 k c")
    residual = [
        q1.diff(t) - u1,
        q2.diff(t) - u2,
        m1 * u1.diff(t) + c * u1 + k * (q1 - q2) - T1,
        m2 * u2.diff(t) + c * u2 + k * (q2 - q1) - T2,
    ]
    model = Model.from_equations(residual, [q1, q2, u1, u2], controlled_inputs=[T1, T2])
    return model, (q1, q2, u1, u2), (T1, T2)


def random_schedule(P, m, ns, seed, mask=None):
    rng = np.random.default_rng(seed)
    Tstar = rng.normal(size=(P, m))
    K = rng.normal(size=(P, m, ns))
    if mask is not None:
        K[:, ~mask] = 0.0
    return Tstar, K


@pytest.fixture
def controller():
    _, s, r = two_mass_model()
    return GainScheduled(4, s, r)


# (phase, lower point, upper point, weight of the upper point) for P = 4 (points at 0, .25,
# .5, .75), worked out by hand: 0.3 is 1/5 of the way from 0.25 to 0.5, 0.9 is 3/5 of the
# way from 0.75 to 1 = point 0 (the periodic wrap), 2.3 and 1.9 are 0.3 and 0.9 two and one
# cycles later, -0.1 is 0.9 one cycle earlier.
HAND_BRACKETS = [
    (0.3, 1, 2, 0.2),
    (0.9, 3, 0, 0.6),
    (2.3, 1, 2, 0.2),
    (1.9, 3, 0, 0.6),
    (-0.1, 3, 0, 0.6),
    (0.125, 0, 1, 0.5),
    (0.8, 3, 0, 0.2),
]


@pytest.mark.parametrize(("phase", "a", "b", "w"), HAND_BRACKETS)
def test_interpolate_matches_hand_computed_linear_interpolation(controller, phase, a, b, w):
    Tstar, K = random_schedule(4, 2, 4, seed=1)
    Ts, Kp = controller.interpolate(phase, Tstar, K)
    np.testing.assert_allclose(Ts[0], (1 - w) * Tstar[a] + w * Tstar[b], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(Kp[0], (1 - w) * K[a] + w * K[b], rtol=1e-12, atol=1e-12)


def test_interpolate_matches_numpy_periodic_interp_on_many_phases(controller):
    Tstar, K = random_schedule(4, 2, 4, seed=2)
    phase = np.linspace(-1.3, 3.7, 257)
    Ts, Kp = controller.interpolate(phase, Tstar, K)
    xp = np.arange(4) / 4
    for j in range(2):
        ref = np.interp(phase, xp, Tstar[:, j], period=1.0)
        np.testing.assert_allclose(Ts[:, j], ref, rtol=1e-12, atol=1e-12)
        for i in range(4):
            ref = np.interp(phase, xp, K[:, j, i], period=1.0)
            np.testing.assert_allclose(Kp[:, j, i], ref, rtol=1e-12, atol=1e-12)


def test_values_at_schedule_points_are_exact_in_every_cycle(controller):
    Tstar, K = random_schedule(4, 2, 4, seed=3)
    for cycle in (0, 1, 5):
        phase = cycle + np.arange(4) / 4
        Ts, Kp = controller.interpolate(phase, Tstar, K)
        np.testing.assert_allclose(Ts, Tstar, rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(Kp, K, rtol=1e-13, atol=1e-13)


def test_interpolation_is_continuous_across_the_wrap(controller):
    Tstar, K = random_schedule(4, 2, 4, seed=4)
    eps = 1e-9
    below, _ = controller.interpolate(1.0 - eps, Tstar, K)
    above, _ = controller.interpolate(1.0 + eps, Tstar, K)
    np.testing.assert_allclose(below, Tstar[None, 0], atol=1e-7)
    np.testing.assert_allclose(above, Tstar[None, 0], atol=1e-7)


def test_torque_against_explicit_loops(controller):
    Tstar, K = random_schedule(4, 2, 4, seed=5)
    rng = np.random.default_rng(6)
    phase = np.array([0.3, 0.9, 2.3, 0.5, 1.0])
    s = rng.normal(size=(5, 4))
    T = controller.torque(phase, s, Tstar, K)
    xp = np.arange(4) / 4
    for k in range(5):
        for j in range(2):
            ref = np.interp(phase[k], xp, Tstar[:, j], period=1.0)
            for i in range(4):
                ref -= np.interp(phase[k], xp, K[:, j, i], period=1.0) * s[k, i]
            assert T[k, j] == pytest.approx(ref, rel=1e-12, abs=1e-12)


def test_parameter_values_names_and_round_trip(controller):
    Tstar, K = random_schedule(4, 2, 4, seed=7)
    values = controller.parameter_values(Tstar, K)
    assert len(values) == len(controller.parameters) == 4 * (2 + 8)
    assert values[sm.Symbol("T_2_1")] == Tstar[2, 1]
    assert values[sm.Symbol("K_3_1_2")] == K[3, 1, 2]
    # point-major, T* first within a point
    assert [str(p) for p in controller.parameters[:3]] == ["T_0_0", "T_0_1", "K_0_0_0"]
    Ts, Kb = controller.arrays(values)
    np.testing.assert_array_equal(Ts, Tstar)
    np.testing.assert_array_equal(Kb, K)


def test_joint_isolated_mask_and_parameters():
    _, s, r = two_mass_model()
    gs = GainScheduled(3, s, r, structure="joint-isolated")
    expected = np.array([[1, 0, 1, 0], [0, 1, 0, 1]], dtype=bool)
    np.testing.assert_array_equal(gs.mask, expected)
    names = {str(p) for p in gs.parameters}
    assert len(names) == 3 * (2 + 4)
    for p in range(3):
        assert {f"K_{p}_0_0", f"K_{p}_0_2", f"K_{p}_1_1", f"K_{p}_1_3"} <= names
        assert not {f"K_{p}_0_1", f"K_{p}_0_3", f"K_{p}_1_0", f"K_{p}_1_2"} & names
    Tstar, K = random_schedule(3, 2, 4, seed=8, mask=expected)
    Ts, Kb = gs.arrays(gs.parameter_values(Tstar, K))
    np.testing.assert_array_equal(Ts, Tstar)
    np.testing.assert_array_equal(Kb, K)


def test_joint_isolated_three_joints_mask():
    angles = dynamicsymbols("a0:3")
    rates = dynamicsymbols("w0:3")
    torques = dynamicsymbols("tau0:3")
    gs = GainScheduled(2, list(angles) + list(rates), torques, structure="joint-isolated")
    for i in range(3):
        assert set(np.flatnonzero(gs.mask[i])) == {i, 3 + i}


def test_custom_mask_array():
    _, s, r = two_mass_model()
    mask = np.array([[1, 1, 0, 0], [0, 0, 0, 1]], dtype=bool)
    gs = GainScheduled(2, s, r, structure=mask)
    assert {str(p) for p in gs.parameters} == {
        "T_0_0",
        "T_0_1",
        "K_0_0_0",
        "K_0_0_1",
        "K_0_1_3",
        "T_1_0",
        "T_1_1",
        "K_1_0_0",
        "K_1_0_1",
        "K_1_1_3",
    }


def test_closed_loop_law_substituted_numbers():
    """The closed residual, with slots bound to points 1 and 2 and w = 0.2, gives the torque."""
    model, s, r = two_mass_model()
    gs = GainScheduled(4, s, r)
    closed = model.close_loop(gs)
    assert closed.schedules == (gs.schedule,)
    assert gs.phase in closed.known_inputs
    assert set(gs.parameters) <= set(closed.parameters)
    assert not set(r) & set(closed.inputs)
    Tstar, K = random_schedule(4, 2, 4, seed=9)
    sched = gs.schedule
    rng = np.random.default_rng(10)
    x = rng.normal(size=4)
    xd = rng.normal(size=4)
    subs = {d: v for d, v in zip([si.diff(t) for si in s], xd, strict=True)}
    subs.update(zip(s, x, strict=True))
    subs.update({sm.Symbol("m1"): 1.0, sm.Symbol("m2"): 2.0, sm.Symbol("k"): 3.0})
    subs[sm.Symbol("c")] = 0.5
    subs[sched.weight] = 0.2
    point = dict(zip(gs.parameters, np.hstack([Tstar, K.reshape(4, -1)]).ravel(), strict=True))
    subs.update({a: point[p] for a, p in zip(sched.slots_a, sched.points[1], strict=True)})
    subs.update({b: point[p] for b, p in zip(sched.slots_b, sched.points[2], strict=True)})
    res = np.array([float(e) for e in closed.residual.subs(subs)])
    torque = 0.8 * (Tstar[1] - K[1] @ x) + 0.2 * (Tstar[2] - K[2] @ x)
    expected = [
        xd[0] - x[2],
        xd[1] - x[3],
        1.0 * xd[2] + 0.5 * x[2] + 3.0 * (x[0] - x[1]) - torque[0],
        2.0 * xd[3] + 0.5 * x[3] + 3.0 * (x[1] - x[0]) - torque[1],
    ]
    np.testing.assert_allclose(res, expected, rtol=1e-12, atol=1e-12)


def test_joint_isolated_closed_loop_torque_uses_own_joint_only():
    model, s, r = two_mass_model()
    closed = model.close_loop(GainScheduled(3, s, r, structure="joint-isolated"))
    q1, q2, u1, u2 = s
    # Row 2 is mass 1: q2 enters only through the spring k (q1 - q2), u2 not at all.
    row = closed.residual[2]
    assert sm.simplify(row.diff(q2) + sm.Symbol("k")) == 0
    assert row.diff(u2) == 0
    row = closed.residual[3]
    assert sm.simplify(row.diff(q1) + sm.Symbol("k")) == 0
    assert row.diff(u1) == 0


def test_two_named_controllers_close_one_loop_each():
    model, s, (T1, T2) = two_mass_model()
    right = GainScheduled(3, s[::2], [T1], name="R", structure="joint-isolated")
    left = GainScheduled(2, s[1::2], [T2], name="L")
    closed = model.close_loop(right).close_loop(left)
    assert len(closed.schedules) == 2
    assert {str(f.func) for f in closed.known_inputs} == {"Rphi", "Lphi"}
    assert sm.Symbol("RT_2_0") in closed.parameters
    assert sm.Symbol("LK_1_0_1") in closed.parameters


# ---------------------------------------------------------------------- errors
@pytest.mark.parametrize("num_points", [1, 0, -3, 2.5, True, "4"])
def test_num_points_must_be_an_integer_of_at_least_two(num_points):
    _, s, r = two_mass_model()
    with pytest.raises(ValueError, match=r"num_points: expected an integer >= 2"):
        GainScheduled(num_points, s, r)


def test_bad_structure_name():
    _, s, r = two_mass_model()
    with pytest.raises(ValueError, match=r"structure: expected one of .*'bogus'"):
        GainScheduled(3, s, r, structure="bogus")


def test_all_problems_reported_at_once():
    _, s, r = two_mass_model()
    with pytest.raises(ValueError, match=r"num_points.*found 1.*structure.*'diag'"):
        GainScheduled(1, s, r, structure="diag")


def test_wrong_mask_shape():
    _, s, r = two_mass_model()
    with pytest.raises(ValueError, match=r"mask of shape \(2, 4\), found \(4, 2\)"):
        GainScheduled(3, s, r, structure=np.ones((4, 2), bool))


def test_joint_isolated_needs_two_feedback_states_per_input():
    _, s, r = two_mass_model()
    with pytest.raises(ValueError, match=r"'joint-isolated' needs .*found 3 feedback states"):
        GainScheduled(3, s[:3], r, structure="joint-isolated")


def test_empty_inputs_or_feedback():
    _, s, _ = two_mass_model()
    with pytest.raises(ValueError, match=r"at least one each, found 0 and 4"):
        GainScheduled(3, s, [])


def test_nonzero_gain_outside_structure():
    _, s, r = two_mass_model()
    gs = GainScheduled(3, s, r, structure="joint-isolated")
    Tstar, K = random_schedule(3, 2, 4, seed=11)  # full K: off-structure gains nonzero
    with pytest.raises(ValueError, match=r"K: has nonzero gains outside"):
        gs.parameter_values(Tstar, K)


@pytest.mark.parametrize(
    ("tshape", "kshape"), [((3, 1), (3, 2, 4)), ((3, 2), (2, 2, 4)), ((3, 2), (3, 4, 2))]
)
def test_wrong_array_shapes(tshape, kshape):
    _, s, r = two_mass_model()
    gs = GainScheduled(3, s, r)
    with pytest.raises(ValueError, match=r"expected shapes \(3, 2\) and \(3, 2, 4\), found"):
        gs.parameter_values(np.zeros(tshape), np.zeros(kshape))


def test_feedback_must_be_states_of_the_model():
    model, s, r = two_mass_model()
    stranger = dynamicsymbols("z")
    gs = GainScheduled(3, [s[0], stranger, s[2], s[3]], r)
    with pytest.raises(ValueError, match=r"feedback: \['z'\] are not states of the model"):
        model.close_loop(gs)


def test_same_controller_twice_clashes():
    model, s, r = two_mass_model()
    closed = model.close_loop(GainScheduled(2, s[::2], r[:1]))
    with pytest.raises(ValueError, match=r"T_0_0 is already used by the model"):
        closed.close_loop(GainScheduled(2, s[1::2], r[1:]))
