"""How inputs reach a model: inferred when undeclared, and functions of a time symbol other
than SymPy's default. (Inputs through a derivative: tests/gallery, the pendulum on a moving
support.)"""

from __future__ import annotations

import pytest
import sympy as sm
import sympy.physics.mechanics as me

from colloc import Model, ModelError

t = me.dynamicsymbols._t
q, u, w = me.dynamicsymbols("q u w")


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
