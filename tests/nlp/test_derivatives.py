"""Exact derivatives of the assembled NLP against central finite differences.

For every scheme, a small damped-pendulum problem with an unknown parameter, a known and a
free input trajectory, tracking, integral and terminal costs and nonlinear instance
constraints (coupling nodes and a parameter) is built on a non-uniform grid; the gradient,
the Jacobian and the Lagrangian Hessian are compared with central differences at random
points and random multipliers.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
from nlp_derivatives import central_difference, dense_hessian, dense_jacobian
from sympy.physics.mechanics import dynamicsymbols

from colloc import IntegralCost, Model, Problem, TerminalCost, Tracking
from colloc.transcription import BackwardEuler, HermiteSimpson, Midpoint, Trapezoidal

SCHEMES = [BackwardEuler(), Midpoint(), Trapezoidal(), HermiteSimpson()]


def pendulum_problem(scheme, seed=0):
    """Damped, driven pendulum: unknown c and l, known force F(t), free torque T(t)."""
    theta, omega, T, F = dynamicsymbols("theta omega T F")
    m, g, ell, c = sm.symbols("m g l c")
    t = dynamicsymbols._t
    residual = [
        theta.diff(t) - omega,
        m * ell**2 * omega.diff(t)
        + c * omega
        + m * g * ell * sm.sin(theta)
        - T
        - ell * F * sm.cos(t),
    ]
    model = Model.from_equations(
        residual,
        [theta, omega],
        controlled_inputs=[T],
        known_inputs=[F],
        outputs={theta: theta, omega: ell * omega},
    )
    rng = np.random.default_rng(seed)
    num_nodes = 15
    times = np.cumsum(np.r_[0.0, rng.uniform(0.05, 0.15, num_nodes - 1)])
    tf = float(times[-1])
    objective = [
        Tracking({theta: np.sin(times), omega: np.cos(times)}, weights={theta: 2.0, omega: 0.5}),
        IntegralCost(T**2 + c * theta**2 * omega),
        TerminalCost(ell * (theta - 1) ** 2),
    ]
    constraints = [
        theta.func(0.0) - 0.1,
        theta.func(0.0) ** 2 + c * omega.func(float(times[5])) - 0.3,
        sm.sin(theta.func(tf)) * ell - omega.func(0.0) * T.func(tf),
    ]
    problem = Problem(
        model,
        times,
        scheme=scheme,
        known_trajectories={F: np.cos(3 * times)},
        known_parameters={m: 1.3, g: 9.81},
        unknown_parameters=[c, ell],
        objective=objective,
        instance_constraints=constraints,
        cache=False,
    )
    return problem


def random_point(problem, rng):
    z = rng.uniform(-1.0, 1.0, problem.layout.num_variables)
    # ell stays away from zero so that the scales of the entries are comparable
    z[problem.layout.variable_index("l")] = rng.uniform(0.5, 1.5)
    return z


@pytest.fixture(scope="module", params=SCHEMES, ids=lambda s: s.name)
def problem(request):
    return pendulum_problem(request.param)


def test_gradient_matches_finite_differences(problem):
    nlp = problem.nlp
    rng = np.random.default_rng(1)
    for _ in range(2):
        z = random_point(problem, rng)
        fd = central_difference(lambda v: np.atleast_1d(nlp.objective(v)), z)[0]
        np.testing.assert_allclose(nlp.gradient(z), fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())


def test_jacobian_matches_finite_differences(problem):
    nlp = problem.nlp
    rng = np.random.default_rng(2)
    rows, cols = nlp.jacobianstructure()
    assert rows.size == cols.size == nlp.jacobian(np.zeros(nlp.n)).size
    assert nlp.m == problem.layout.num_constraints
    for _ in range(2):
        z = random_point(problem, rng)
        fd = central_difference(nlp.constraints, z)
        J = dense_jacobian(nlp, z)
        assert J.shape == fd.shape
        np.testing.assert_allclose(J, fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())


def test_hessian_matches_finite_differences_of_lagrangian_gradient(problem):
    nlp = problem.nlp
    rng = np.random.default_rng(3)
    rows, cols = nlp.hessianstructure()
    assert np.all(rows >= cols), "IPOPT expects the lower triangle"
    assert np.unique(rows * nlp.n + cols).size == rows.size
    for _ in range(2):
        z = random_point(problem, rng)
        lam = rng.normal(size=nlp.m)
        sigma = float(rng.uniform(0.5, 2.0))

        def lagrangian_gradient(v, lam=lam, sigma=sigma):
            return sigma * nlp.gradient(v) + dense_jacobian(nlp, v).T @ lam

        fd = central_difference(lagrangian_gradient, z)
        fd = 0.5 * (fd + fd.T)
        H = dense_hessian(nlp, z, lam, sigma)
        np.testing.assert_allclose(H, fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())


def test_hessian_is_linear_in_multipliers_and_objective_factor(problem):
    """Independent of FD: H(lam, sigma) = sigma H_f + sum_j lam_j H_gj."""
    nlp = problem.nlp
    rng = np.random.default_rng(4)
    z = random_point(problem, rng)
    lam = rng.normal(size=nlp.m)
    whole = dense_hessian(nlp, z, lam, 0.7)
    objective_only = dense_hessian(nlp, z, np.zeros(nlp.m), 1.0)
    constraints_only = dense_hessian(nlp, z, lam, 0.0)
    np.testing.assert_allclose(whole, 0.7 * objective_only + constraints_only, atol=1e-12)
    assert np.abs(objective_only).max() > 0 and np.abs(constraints_only).max() > 0


def test_objective_value_against_direct_sum(problem):
    """The assembled objective equals the costs summed by hand from the layout."""
    rng = np.random.default_rng(5)
    z = random_point(problem, rng)
    lay, t = problem.layout, problem.grid.times
    X = lay.node_matrix(z)
    th, om, T = (X[:, lay.node_names.index(n)] for n in ("theta", "omega", "T"))
    c, l_ = z[lay.variable_index("c")], z[lay.variable_index("l")]
    tracking = np.sum(2.0 * (th - np.sin(t)) ** 2 + 0.5 * (l_ * om - np.cos(t)) ** 2)
    integrand = T**2 + c * th**2 * om
    integral = np.sum(0.5 * np.diff(t) * (integrand[:-1] + integrand[1:]))
    terminal = l_ * (th[-1] - 1) ** 2
    assert problem.nlp.objective(z) == pytest.approx(tracking + integral + terminal, rel=1e-12)
