"""Every validation error path of Model construction, close_loop and StateFeedback.

Also: several problems in one definition are reported together, and the constructors
that succeed agree with independent references (Kane vs Lagrange, a hand-closed loop).
"""

from __future__ import annotations

import re

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
    dynamicsymbols,
)

from colloc import Model, ModelError, StateFeedback

t = dynamicsymbols._t
q, u, r, w = dynamicsymbols("q u r w")
k, c, m = sm.symbols("k c m")


def spring_residual():
    """``q' = u``, ``m u' + c u + k q = r``."""
    return [q.diff(t) - u, m * u.diff(t) + c * u + k * q - r]


def spring(**kwargs):
    kwargs.setdefault("controlled_inputs", [r])
    return Model.from_equations(spring_residual(), [q, u], **kwargs)


# --------------------------------------------------------------------------- from_equations
@pytest.mark.parametrize(
    ("residual", "states", "kwargs", "pattern"),
    [
        (
            [q.diff(t) - u, u.diff(t)],
            [q, sm.Symbol("u")],
            {},
            r"states: expected functions of time such as q\(t\).*found \['u'\]",
        ),
        ([q.diff(t) - u, u.diff(t) + q], [q, q], {}, r"states: listed more than once: \['q'\]"),
        (
            [q.diff(t) - u, u.diff(t) + r],
            [q, u],
            {"controlled_inputs": [r], "known_inputs": [r]},
            r"r is declared both in controlled_inputs and in known_inputs",
        ),
        ([], [q], {}, r"residual: expected at least one equation, found none"),
        (
            [q.diff(t) - u],
            [q, u],
            {},
            r"residual has 1 equation\(s\) but there are 2 state\(s\); expected one equation",
        ),
        (
            [q.diff(t) - u, u.diff(t) + w],
            [q, u],
            {"infer_inputs": False},
            r"unknown functions of time in the residual \(declare each as a state or an input\): "
            r"\['w'\]",
        ),
        (
            [q.diff(t) - u, u.diff(t) + r.diff(t)],
            [q, u],
            {"known_inputs": [r]},
            r"the residual differentiates r, which is not a state",
        ),
        (
            [q.diff(t, 2) + q, u.diff(t) - u],
            [q, u],
            {},
            r"derivative of order 2 of q; write the model in first-order form",
        ),
        ([q - u, u + q], [q, u], {}, r"contains no state derivative x'\(t\); nothing evolves"),
        (
            [q.diff(t) - u, u.diff(t) + sm.Symbol("q") * q],
            [q, u],
            {},
            r"symbol\(s\) \['q'\] are used both as a constant and as a function of time",
        ),
        (
            [q.diff(t) - u, u.diff(t) + k * q],
            [q, u],
            {"parameters": [k, t]},
            r"parameters: expected constant sympy Symbols, found \['t'\]",
        ),
        (
            [q.diff(t) - u, u.diff(t) + k * q],
            [q, u],
            {"parameters": [k, q]},
            r"parameters: \['q\(t\)'\] are also states or inputs",
        ),
        (
            [q.diff(t) - u, m * u.diff(t) + k * q],
            [q, u],
            {"parameters": [k]},
            r"unknown symbols in the residual \(not among the given parameters\): \['m'\]",
        ),
        (
            [q.diff(t) - u, u.diff(t) + q],
            [q, u],
            {"outputs": {w: 3.0}},
            r"output w: expected a SymPy expression, found 3.0",
        ),
        (
            [q.diff(t) - u, u.diff(t) + q + r],
            [q, u],
            {"outputs": {w: q + r + dynamicsymbols("v")}, "known_inputs": [r]},
            r"output w depends on \['v'\], which are neither states nor inputs; "
            r"outputs are y = g\(x, r, t\)",
        ),
        (
            [q.diff(t) - u, u.diff(t) + q],
            [q, u],
            {"outputs": {w: q.diff(t)}},
            r"output w: derivatives are not allowed in outputs",
        ),
    ],
    ids=[
        "state-not-function",
        "duplicate-state",
        "input-in-two-groups",
        "empty-residual",
        "equation-count",
        "undeclared-function",
        "derivative-of-input",
        "second-derivative",
        "no-derivative",
        "constant-function-clash",
        "parameter-not-symbol",
        "parameter-is-state",
        "missing-parameter",
        "output-not-expression",
        "output-not-of-states-or-inputs",
        "output-with-derivative",
    ],
)
def test_from_equations_rejects(residual, states, kwargs, pattern):
    with pytest.raises(ModelError, match=pattern) as info:
        Model.from_equations(residual, states, **kwargs)
    assert isinstance(info.value, ValueError)
    assert info.value.problems  # every message is also available as data


def test_every_problem_is_reported_at_once():
    with pytest.raises(ModelError, match=r"the model has 3 problem\(s\)") as info:
        Model.from_equations(
            [q.diff(t) - u, u.diff(t) + w + m * q],
            [q, u],
            parameters=[k],
            outputs={r: 1.5},
            infer_inputs=False,
        )
    text = str(info.value)
    assert "unknown functions of time in the residual" in text and "['w']" in text
    assert "not among the given parameters): ['m']" in text
    assert "output r: expected a SymPy expression" in text
    assert len(info.value.problems) == 3


def test_valid_definition_collects_parameters_and_default_outputs():
    model = spring()
    assert model.parameters == (c, k, m)  # sorted by name
    assert model.outputs == {q: q, u: u}
    assert model.state_derivatives == (q.diff(t), u.diff(t))
    assert model.inputs == (r,)


# --------------------------------------------------------------------------- Kane / Lagrange
def pendulum_frames():
    theta, omega = dynamicsymbols("theta omega")
    mass, length, g = sm.symbols("mass length g")
    torque = dynamicsymbols("torque")
    N = ReferenceFrame("N")
    A = N.orientnew("A", "Axis", (theta, N.z))
    origin = Point("O")
    origin.set_vel(N, 0)
    P = origin.locatenew("P", -length * A.y)
    return theta, omega, mass, length, g, torque, N, A, origin, P


def test_from_kane_requires_kanes_equations():
    theta, omega, mass, length, g, torque, N, A, origin, P = pendulum_frames()
    kane = KanesMethod(N, [theta], [omega], kd_eqs=[theta.diff(t) - omega])
    with pytest.raises(TypeError, match=r"kane: expected a KanesMethod whose kanes_equations"):
        Model.from_kane(kane)


def test_from_lagrange_requires_lagranges_equations():
    theta, *_ = pendulum_frames()
    lag = LagrangesMethod(theta.diff(t) ** 2 / 2, [theta])
    with pytest.raises(
        TypeError, match=r"lagrange: expected a LagrangesMethod whose form_lagranges_equations"
    ):
        Model.from_lagrange(lag)


def test_kane_and_lagrange_models_give_the_same_accelerations():
    models, theta, mass, length, g, torque = _pendulum_models(controlled_inputs="torque")
    kane_model, lag_model = models["kane"], models["lagrange"]
    assert len(lag_model.states) == 2 and lag_model.outputs == {theta: theta}

    rng = np.random.default_rng(0)
    for _ in range(3):
        th, om, tq = (sm.Float(v) for v in rng.normal(size=3))
        values = {mass: sm.Float(1.3), length: sm.Float(0.7), g: sm.Float(9.81)}
        values.update({torque: tq, theta: th})
        accelerations = []
        for model in (kane_model, lag_model):
            xd = sm.symbols("xd0 xd1")
            res = model.residual.xreplace(dict(zip(model.state_derivatives, xd, strict=True)))
            res = res.xreplace({**values, model.states[1]: om})
            sol = sm.solve(list(res), list(xd), dict=True)[0]
            accelerations.append(float(sol[xd[1]]))
        expected = (float(tq) - 1.3 * 9.81 * 0.7 * np.sin(float(th))) / (1.3 * 0.7**2)
        np.testing.assert_allclose(accelerations, [expected, expected], rtol=1e-12)


# --------------------------------------------------------------------------- close_loop
class _DrivesState:
    parameters = ()

    def control_law(self, model):
        return {u: -q}


class _ClashingController:
    parameters = (k,)

    def control_law(self, model):
        return {r: -k * q}


def test_close_loop_rejects_a_law_for_a_non_controlled_input():
    with pytest.raises(ModelError, match=r"controller drives u, which is not a controlled input"):
        spring().close_loop(_DrivesState())


def test_close_loop_rejects_controller_parameters_used_by_the_model():
    with pytest.raises(ModelError, match=r"controller parameter k is already used by the model"):
        spring().close_loop(_ClashingController())


def test_close_loop_substitutes_the_feedback_law():
    g1, g2 = sm.symbols("g1 g2")
    closed = spring().close_loop(StateFeedback([[g1, g2]], x_eq=[0.5, 0]))
    hand = sm.Matrix(spring_residual()).xreplace({r: g1 * (0.5 - q) + g2 * (0 - u)})
    assert sm.simplify(closed.residual - hand) == sm.zeros(2, 1)
    assert closed.controlled_inputs == ()
    assert closed.controller_parameters == (g1, g2)
    assert set(closed.parameters) == {c, k, m, g1, g2}


def test_close_loop_puts_the_law_into_outputs_on_the_driven_input():
    g1, g2 = sm.symbols("g1 g2")
    model = spring(outputs={q: q, w: 2 * r})  # a measured input, e.g. a joint torque
    closed = model.close_loop(StateFeedback([[g1, g2]], x_eq=[0.5, 0]))
    assert sm.expand(closed.outputs[w] - 2 * (g1 * (0.5 - q) - g2 * u)) == 0
    assert closed.outputs[q] == q
    # an input that stays an input keeps its output as it was
    kept = Model.from_equations(
        spring_residual(), [q, u], known_inputs=[r], outputs={w: r}
    ).with_outputs({w: r, q: q})
    assert kept.outputs[w] == r


# --------------------------------------------------------------------------- StateFeedback
def test_state_feedback_rejects_empty_gain():
    with pytest.raises(ValueError, match=r"K: expected a non-empty 2-D gain matrix, found shape"):
        StateFeedback(np.zeros((0, 2)))


def test_state_feedback_rejects_one_dimensional_gain():
    with pytest.raises(ValueError, match=r"K: expected a 2-D gain matrix, found 1 dimension"):
        StateFeedback([1.0, 2.0])


def test_state_feedback_rejects_text_entries():
    with pytest.raises(TypeError, match=r"K: expected numbers or SymPy expressions, found 'k1'"):
        StateFeedback([["k1", 2.0]])


def test_state_feedback_rejects_text_set_point():
    with pytest.raises(TypeError, match=r"x_eq: expected numbers or SymPy expressions"):
        StateFeedback([[1.0, 2.0]], x_eq=["0", 0])


@pytest.mark.parametrize("bad", [0, -1, 1.5])
def test_symbolic_gain_needs_positive_integer_sizes(bad):
    with pytest.raises(ValueError, match=r"num_inputs: expected a positive integer"):
        StateFeedback.symbolic(bad, 2)
    with pytest.raises(ValueError, match=r"num_states: expected a positive integer"):
        StateFeedback.symbolic(1, bad)


def test_state_feedback_reports_shape_states_and_set_point_together():
    fb = StateFeedback([[1.0, 2.0, 3.0]], x_eq=[0.0, 0.0], states=[q, w, u])
    with pytest.raises(ValueError, match=r"StateFeedback: ") as info:
        spring().close_loop(fb)
    text = str(info.value)
    assert "states: ['w'] are not states of the model" in text
    assert "x_eq: expected 3 values, found 2" in text
    fb = StateFeedback([[1.0, 2.0, 3.0]])
    with pytest.raises(ValueError, match=r"K: expected shape \(1, 2\)"):
        spring().close_loop(fb)


def test_symbolic_feedback_sizes_itself_from_the_model():
    closed = spring().close_loop(StateFeedback())
    assert closed.controller_parameters == (sm.Symbol("k_0_0"), sm.Symbol("k_0_1"))
    fb = StateFeedback.symbolic(1, 2, name="K")
    assert fb.K.shape == (1, 2) and re.fullmatch(r"K_0_1", str(fb.K[0, 1]))


def test_an_unknown_input_in_no_equation_is_refused():
    with pytest.raises(ModelError, match=r"unknown_inputs: \['w'\] appear in no equation"):
        Model.from_equations([q.diff(t) - u, u.diff(t) + k * q - r], [q, u], unknown_inputs=[r, w])


def _pendulum_models(controlled_inputs=None):
    """The same point-mass pendulum from Kane's and from Lagrange's method; its torque is
    controlled (``controlled_inputs="torque"``) or unknown."""
    theta, omega, mass, length, g, torque, N, A, origin, P = pendulum_frames()
    A.set_ang_vel(N, omega * N.z)
    P.v2pt_theory(origin, N, A)
    kane = KanesMethod(N, [theta], [omega], kd_eqs=[theta.diff(t) - omega])
    kane.kanes_equations([Particle("bob", P, mass)], [(P, -mass * g * N.y), (A, torque * N.z)])
    A2 = N.orientnew("A2", "Axis", (theta, N.z))
    P2 = origin.locatenew("P2", -length * A2.y)
    P2.v2pt_theory(origin, N, A2)
    bob2 = Particle("bob2", P2, mass)
    bob2.potential_energy = mass * g * P2.pos_from(origin).dot(N.y)
    lag = LagrangesMethod(Lagrangian(N, bob2), [theta], forcelist=[(A2, torque * N.z)], frame=N)
    lag.form_lagranges_equations()
    kind = "controlled_inputs" if controlled_inputs else "unknown_inputs"
    models = {
        "kane": Model.from_kane(kane, **{kind: [torque]}),
        "lagrange": Model.from_lagrange(lag, **{kind: [torque]}),
    }
    return models, theta, mass, length, g, torque


@pytest.mark.parametrize("method", ["kane", "lagrange"])
def test_a_negative_known_mass_is_refused_by_the_problem(method):
    """A known mass of -1 solved "successfully" to k3 = -2845 (issue 32 item 15)."""
    from colloc import Problem, ProblemDefinitionError, Tracking

    models, theta, mass, length, g, _ = _pendulum_models()
    model = models[method]
    assert model.inertia is not None
    times = np.linspace(0.0, 1.0, 11)
    track = Tracking({theta: np.zeros(times.size)})
    for bad in (-1.0, -1e-6):
        with pytest.raises(ProblemDefinitionError, match=r"not positive definite.*mass=-1") as err:
            Problem(
                model, times, objective=track, known_parameters={mass: bad, length: 0.7, g: 9.81}
            )
        assert "smallest eigenvalue" in str(err.value)
    Problem(model, times, objective=track, known_parameters={mass: 1.0, length: 0.7, g: 9.81})
    # unknown mass: nothing to check at construction
    Problem(model, times, objective=track, known_parameters={length: 0.7, g: 9.81})


def test_the_pendulum_on_a_cart_has_a_mass_matrix_checked_and_plain_equations_none():
    from colloc.model.inertia import inertia_problems
    from colloc.models.pendulum_cart import derive

    model = derive(2).to_model()
    assert model.inertia is not None
    values = {p: 1.0 for p in model.parameters}
    assert inertia_problems(model, values) == []
    negative = dict(values)
    first_mass = next(p for p in model.parameters if str(p).startswith("m"))
    negative[first_mass] = -5.0
    assert "not positive definite" in inertia_problems(model, negative)[0]
    plain = Model.from_equations([q.diff(t) - u, m * u.diff(t) + k * q], [q, u])
    assert plain.inertia is None and inertia_problems(plain, {m: -1.0, k: 1.0}) == []
