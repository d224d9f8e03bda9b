"""A Gaussian prior on unknown parameters, and parameters that only an output holds.

Reference: the conjugate normal model. A constant ``c`` measured ``N`` times with noise
``sigma`` under the prior ``N(m, s^2)`` has the posterior mean
``(sum y / sigma^2 + m / s^2) / (N / sigma^2 + 1 / s^2)`` and standard deviation
``(N / sigma^2 + 1 / s^2)^-1/2``, in closed form.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc import Model, ModelError, ParameterPrior, Problem, Tracking, cramer_rao_bound
from colloc.nlp.residuals import tracking_residuals

t = dynamicsymbols._t
x, v, y, z_out = dynamicsymbols("x v y z_out")
k, c, d = sm.symbols("k c d")
TIMES = np.linspace(0.0, 2.0, 41)
SIGMA, PRIOR_MEAN, PRIOR_STD = 0.2, 0.3, 0.1


def plant() -> Model:
    # a decaying state, measured directly; the offset c only in a second output
    return Model.from_equations([x.diff(t) + k * x], [x], parameters=[k])


def offset_model() -> Model:
    return plant().with_outputs({y: x, z_out: x + c}, parameters=[c])


def test_output_parameters_join_the_model_sorted_by_name():
    model = plant().with_outputs({y: x + d * x, z_out: x + c}, parameters=[d, c])
    assert model.parameters == (c, d, k)
    assert plant().with_outputs({y: x}).parameters == (k,)


@pytest.mark.parametrize(
    ("outputs", "parameters", "message"),
    [
        ({y: x + c}, [k], "k is already a parameter"),
        ({y: x + c}, [c, d], "d appears in no output"),
        ({y: x + c}, [c, c], "given twice"),
        ({y: x + c}, [x], "plain SymPy symbols"),
    ],
)
def test_output_parameters_are_checked(outputs, parameters, message):
    with pytest.raises(ModelError, match=message):
        plant().with_outputs(outputs, parameters=parameters)


def test_the_prior_gives_the_conjugate_posterior_and_its_bound():
    rng = np.random.default_rng(3)
    truth = np.exp(-0.7 * TIMES)
    offset = 0.5
    data_x = truth + 1e-4 * rng.standard_normal(TIMES.size)
    data_z = truth + offset + SIGMA * rng.standard_normal(TIMES.size)
    prob = Problem(
        offset_model(),
        TIMES,
        known_parameters={k: 0.7},
        objective=[
            Tracking({y: data_x, z_out: data_z}, {y: 1e8, z_out: 1.0 / SIGMA**2}),
            ParameterPrior({c: PRIOR_MEAN}, PRIOR_STD),
        ],
        cache=False,
    )
    assert list(prob.layout.parameter_names) == ["c"]
    solution = prob.solve(prob.initial_guess({x: data_x}, {c: 0.0}))
    assert solution.stats["success"]
    # x is pinned to its own data, so c sees sum(z - x) as N measurements of itself
    precision = TIMES.size / SIGMA**2 + 1.0 / PRIOR_STD**2
    measured = np.sum(data_z - solution.trajectories[x]) / SIGMA**2
    mean = (measured + PRIOR_MEAN / PRIOR_STD**2) / precision
    assert solution.parameters[c] == pytest.approx(mean, abs=1e-6)
    assert abs(mean - offset) > 0.01  # the prior pulled it: the test can tell
    bound = cramer_rao_bound(prob, solution.z)
    assert bound.standard_errors[c] == pytest.approx(precision**-0.5, rel=2e-3)


def test_a_prior_alone_settles_a_parameter_the_data_cannot_see():
    # c enters no tracked output: without the prior the bound is singular, with it the
    # bound is the prior's own spread
    model = plant().with_outputs({y: x, z_out: x + c}, parameters=[c])
    data = np.exp(-0.7 * TIMES)
    base = {"known_parameters": {k: 0.7}, "cache": False}
    alone = Problem(model, TIMES, objective=Tracking({y: data}), **base)
    with pytest.raises(ValueError, match="singular"):
        cramer_rao_bound(alone, alone.initial_guess({x: data}, {c: 0.1}))
    prior = Problem(
        model, TIMES, objective=[Tracking({y: data}), ParameterPrior({c: 0.1}, 0.05)], **base
    )
    z = prior.initial_guess({x: data}, {c: 0.1})
    assert cramer_rao_bound(prior, z).standard_errors[c] == pytest.approx(0.05, rel=1e-9)
    kinds = {s.name: s.kind for s in tracking_residuals(prior, z)}
    assert kinds == {"y": "tracking", "prior c": "parameter prior"}
    (signal,) = tracking_residuals(prior, z, "parameter prior")
    assert np.count_nonzero(signal.weights) == 1


@pytest.mark.parametrize(
    ("means", "std", "message"),
    [
        ({}, 1.0, "non-empty"),
        ({c: float("nan")}, 1.0, "finite means"),
        ({c: 0.0}, 0.0, "positive finite"),
        ({c: 0.0}, {d: 1.0}, "no prior mean"),
    ],
)
def test_bad_priors_are_refused(means, std, message):
    with pytest.raises(ValueError, match=message):
        ParameterPrior(means, std)


def test_a_prior_on_a_symbol_that_is_not_a_parameter_is_refused():
    with pytest.raises(ValueError, match="not parameters of the model"):
        Problem(
            offset_model(),
            TIMES,
            known_parameters={k: 0.7},
            objective=[Tracking({y: TIMES}), ParameterPrior({d: 0.0}, 1.0)],
            cache=False,
        )
