"""How inputs reach a model: through a derivative, inferred when undeclared, and functions of
a time symbol other than SymPy's default.

Reference: the pendulum hanging from an accelerating support, whose equation
``L u' = -(g sin q + a cos q)`` is derived by hand.
"""

from __future__ import annotations

import pytest
import sympy as sm
import sympy.physics.mechanics as me

from colloc import Model, ModelError

t = me.dynamicsymbols._t
q, u, v, a, w = me.dynamicsymbols("q u v a w")
m, g, L = sm.symbols("m g L", positive=True)


def support_pendulum() -> me.KanesMethod:
    """A bob on a massless rod from a support moving along x at the known speed ``v(t)``."""
    N = me.ReferenceFrame("N")
    B = N.orientnew("B", "Axis", (q, N.z))
    support = me.Point("support")
    support.set_vel(N, v * N.x)
    P = support.locatenew("P", -L * B.y)
    P.v2pt_theory(support, N, B)
    kane = me.KanesMethod(N, [q], [u], kd_eqs=[q.diff(t) - u])
    kane.kanes_equations([me.Particle("bob", P, m)], [(P, -m * g * N.y)])
    return kane


def test_an_input_through_its_derivative_is_accepted_with_input_derivatives():
    kane = support_pendulum()
    assert v.diff(t) in kane.forcing.atoms(sm.Derivative)
    with pytest.raises(ModelError, match=r"differentiates v.*input_derivatives=\{v: a\}"):
        Model.from_kane(kane, known_inputs=[v])
    model = Model.from_kane(kane, known_inputs=[v], input_derivatives={v: a})
    assert a in model.known_inputs and v in model.known_inputs
    assert not any(d.expr == v for d in model.residual.atoms(sm.Derivative))
    acceleration = sm.solve(model.residual[1], u.diff(t))[0]
    assert sm.simplify(acceleration + (g * sm.sin(q) + a * sm.cos(q)) / L) == 0


def test_input_derivatives_are_validated():
    kane = support_pendulum()
    with pytest.raises(ModelError, match="input_derivatives: expected each value"):
        Model.from_kane(kane, known_inputs=[v], input_derivatives={v: sm.Symbol("a")})
    with pytest.raises(ModelError, match="input_derivatives: expected a mapping"):
        Model.from_kane(kane, known_inputs=[v], input_derivatives=[(v, a)])  # type: ignore[arg-type]


def test_undeclared_functions_of_time_become_known_inputs_with_a_warning():
    residual = [q.diff(t) - u, u.diff(t) + sm.sin(q) - w]
    with pytest.warns(UserWarning, match=r"\['w'\].*taken as known inputs"):
        model = Model.from_equations(residual, [q, u])
    assert model.known_inputs == (w,)
    with pytest.raises(ModelError, match="unknown functions of time"):
        Model.from_equations(residual, [q, u], infer_inputs=False)


def test_another_time_symbol_is_named_in_the_error_and_accepted_as_t():
    tau = sm.Symbol("tau")
    x, y = sm.Function("x")(tau), sm.Function("y")(tau)
    residual = [x.diff(tau) - y, y.diff(tau) + x]
    with pytest.raises(ModelError, match=r"not functions of the model's time symbol t.*t="):
        Model.from_equations(residual, [x, y])
    model = Model.from_equations(residual, [x, y], t=tau)
    assert model.states == (x, y) and model.t == tau
