"""Known-answer problems solved end to end (Problem -> IPOPT -> Solution).

* Identification: the damping (and gravity) of a damped pendulum recovered from a SciPy
  simulation with seeded noise, compared with the standard errors that the noise implies
  (Gauss-Newton covariance from finite-difference sensitivities of the SciPy solution).
* Optimal control with an analytic optimum: minimum-energy double integrator,
  ``u* = 6 - 12 t`` and ``J* = 12``.
* A pendulum swing-up with a torque bound that forces pumping.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
from scipy.integrate import solve_ivp
from sympy.physics.mechanics import dynamicsymbols

from colloc import IntegralCost, Model, Problem, Tracking
from colloc.transcription import HermiteSimpson, Midpoint

t = dynamicsymbols._t

# --------------------------------------------------------------------------- identification
TRUE = {"m": 1.2, "ell": 0.8, "g": 9.81, "c": 0.35}
THETA0 = 1.2
DURATION = 10.0
NUM_NODES = 201
SIGMA = 0.01  # rad, measurement noise


def damped_pendulum():
    theta, omega = dynamicsymbols("theta omega")
    m, ell, g, c = sm.symbols("m l g c")
    model = Model.from_equations(
        [
            theta.diff(t) - omega,
            m * ell**2 * omega.diff(t) + c * omega + m * g * ell * sm.sin(theta),
        ],
        [theta, omega],
        outputs=[theta],
    )
    return model, theta, omega, {"m": m, "ell": ell, "g": g, "c": c}


def simulate_angle(times, c=TRUE["c"], g=TRUE["g"]):
    m, ell = TRUE["m"], TRUE["ell"]

    def rhs(_, y):
        return [y[1], -(c * y[1] + m * g * ell * np.sin(y[0])) / (m * ell**2)]

    sol = solve_ivp(rhs, (times[0], times[-1]), [THETA0, 0.0], t_eval=times, rtol=1e-12, atol=1e-12)
    return sol.y[0]


@pytest.fixture(scope="module")
def measurement_setup():
    times = np.linspace(0.0, DURATION, NUM_NODES)
    clean = simulate_angle(times)
    # Gauss-Newton covariance of (c, g): sigma^2 (S^T S)^-1 with S = d theta / d (c, g)
    S = np.column_stack(
        [
            (simulate_angle(times, c=TRUE["c"] + 1e-6) - simulate_angle(times, c=TRUE["c"] - 1e-6))
            / 2e-6,
            (simulate_angle(times, g=TRUE["g"] + 1e-5) - simulate_angle(times, g=TRUE["g"] - 1e-5))
            / 2e-5,
        ]
    )
    cov_cg = SIGMA**2 * np.linalg.inv(S.T @ S)
    se_c_alone = SIGMA / np.linalg.norm(S[:, 0])
    return times, clean, se_c_alone, np.sqrt(np.diag(cov_cg))


def identify(times, measured, scheme, unknown=("c",), cache=False):
    model, theta, omega, sym = damped_pendulum()
    known = {sym[k]: TRUE[k] for k in ("m", "ell", "g", "c") if k not in unknown}
    problem = Problem(
        model,
        times,
        scheme=scheme,
        known_parameters=known,
        objective=Tracking({theta: measured}),
        cache=cache,
    )
    guess = problem.initial_guess(
        {theta: measured, omega: np.gradient(measured, times)},
        {sym[k]: 0.5 * TRUE[k] for k in unknown},
    )
    solution = problem.solve(guess)
    assert solution.success, solution.status
    return np.array([solution.parameters[sym[k]] for k in unknown])


def noisy(clean, seed):
    return clean + np.random.default_rng(seed).normal(0.0, SIGMA, clean.size)


def test_damping_from_noise_free_data_has_negligible_discretisation_bias(measurement_setup):
    times, clean, se_c, _ = measurement_setup
    (c_hat,) = identify(times, clean, HermiteSimpson())
    assert abs(c_hat - TRUE["c"]) < 0.05 * se_c


def test_damping_from_noisy_data_is_within_the_noise(measurement_setup):
    times, clean, se_c, _ = measurement_setup
    estimates = [identify(times, noisy(clean, seed), HermiteSimpson())[0] for seed in (11, 12)]
    for c_hat in estimates:
        assert abs(c_hat - TRUE["c"]) < 3.5 * se_c
        assert abs(c_hat - TRUE["c"]) < 0.02 * TRUE["c"]
    # a second noise realisation gives a different, equally close value
    assert abs(estimates[0] - estimates[1]) > 1e-3 * se_c


def test_spread_of_damping_estimates_matches_the_noise_standard_error(measurement_setup, tmp_path):
    times, clean, se_c, _ = measurement_setup
    estimates = np.array(
        [
            identify(times, noisy(clean, seed), HermiteSimpson(), cache=tmp_path)[0]
            for seed in range(16)
        ]
    )
    assert abs(estimates.mean() - TRUE["c"]) < 3.5 * se_c / np.sqrt(estimates.size)
    assert 0.55 * se_c < estimates.std(ddof=1) < 1.6 * se_c


def test_damping_and_gravity_together(measurement_setup):
    times, clean, _, se_cg = measurement_setup
    c_hat, g_hat = identify(times, noisy(clean, 21), HermiteSimpson(), unknown=("c", "g"))
    assert abs(c_hat - TRUE["c"]) < 3.5 * se_cg[0]
    assert abs(g_hat - TRUE["g"]) < 3.5 * se_cg[1]


def test_midpoint_bias_shrinks_at_second_order(measurement_setup):
    """Noise-free data: the discretisation bias of Midpoint falls by 4 when h halves."""
    times, clean, _, _ = measurement_setup
    fine = np.linspace(0.0, DURATION, 2 * NUM_NODES - 1)
    bias_coarse = identify(times, clean, Midpoint())[0] - TRUE["c"]
    bias_fine = identify(fine, simulate_angle(fine), Midpoint())[0] - TRUE["c"]
    assert 3.4 < bias_coarse / bias_fine < 4.6


# --------------------------------------------------------------------------- double integrator
def min_energy_double_integrator(scheme, num_nodes):
    x, v, u = dynamicsymbols("x v u")
    model = Model.from_equations([x.diff(t) - v, v.diff(t) - u], [x, v], unknown_inputs=[u])
    times = np.linspace(0.0, 1.0, num_nodes)
    problem = Problem(
        model,
        times,
        scheme=scheme,
        objective=IntegralCost(u**2),
        instance_constraints=[x.func(0.0), v.func(0.0), x.func(1.0) - 1, v.func(1.0)],
        cache=False,
    )
    solution = problem.solve(problem.initial_guess({x: times}))
    assert solution.success, solution.status
    return times, solution, (x, v, u)


@pytest.mark.parametrize("scheme", [HermiteSimpson(), Midpoint()], ids=lambda s: s.name)
def test_min_energy_double_integrator_matches_analytic_optimum(scheme):
    j_star = 12.0
    gaps = []
    for num_nodes in (21, 41):
        times, solution, (x, v, u) = min_energy_double_integrator(scheme, num_nodes)
        gaps.append(solution.stats["objective"] - j_star)
        u_hat = solution.trajectories[u]
        x_hat = solution.trajectories[x]
        assert np.max(np.abs(x_hat - (3 * times**2 - 2 * times**3))) < 1e-3
        # interior controls follow u* = 6 - 12 t; the end nodes carry half the quadrature weight
        assert np.max(np.abs(u_hat[1:-1] - (6 - 12 * times[1:-1]))) < 1.2 / (num_nodes - 1)
        assert np.max(np.abs(u_hat - (6 - 12 * times))) < 6.0 / (num_nodes - 1)
        assert solution.trajectories[x][-1] == pytest.approx(1.0, abs=1e-8)
        assert solution.trajectories[v][-1] == pytest.approx(0.0, abs=1e-8)
    assert abs(gaps[-1]) < 0.003 * j_star
    # the trapezoidal quadrature of u^2 makes J converge to J* at second order
    assert 3.5 < gaps[0] / gaps[1] < 4.5


# --------------------------------------------------------------------------- swing-up
def swing_up(scheme, torque_limit, num_nodes=101, duration=5.0):
    theta, omega, T = dynamicsymbols("theta omega T")
    g = 9.81
    model = Model.from_equations(
        [theta.diff(t) - omega, omega.diff(t) + g * sm.sin(theta) - T],
        [theta, omega],
        controlled_inputs=[T],
    )
    times = np.linspace(0.0, duration, num_nodes)
    problem = Problem(
        model,
        times,
        scheme=scheme,
        objective=IntegralCost(T**2),
        bounds={T: (-torque_limit, torque_limit)},
        instance_constraints=[
            theta.func(0.0),
            omega.func(0.0),
            theta.func(duration) - np.pi,
            omega.func(duration),
        ],
        cache=False,
    )
    guess = problem.initial_guess({theta: np.pi * times / duration, omega: np.pi / duration})
    return problem, problem.solve(guess), (theta, omega, T), times, g


@pytest.mark.parametrize("scheme", [Midpoint(), HermiteSimpson()], ids=lambda s: s.name)
def test_pendulum_swing_up_converges_to_upright(scheme):
    limit = 3.0  # well below m g l = 9.81: the pendulum has to be pumped up
    problem, solution, (theta, omega, T), _, _ = swing_up(scheme, limit)
    assert solution.success, solution.status
    assert solution.trajectories[theta][0] == pytest.approx(0.0, abs=1e-8)
    assert solution.trajectories[omega][0] == pytest.approx(0.0, abs=1e-8)
    assert solution.trajectories[theta][-1] == pytest.approx(np.pi, abs=1e-8)
    assert solution.trajectories[omega][-1] == pytest.approx(0.0, abs=1e-8)
    assert np.max(np.abs(problem.defects(solution.z))) < 1e-7
    torque = solution.trajectories[T]
    assert np.max(np.abs(torque)) <= limit * (1 + 1e-7)
    assert np.max(np.abs(torque)) > 0.999 * limit  # the bound is active
    # the swing passes through both sides before coming up
    assert solution.trajectories[theta].min() < -0.3


def test_swing_up_torque_drives_a_scipy_simulation_upright():
    """Hermite-Simpson's torque, replayed by an independent integrator, ends near upright."""
    problem, solution, (theta, omega, T), times, g = swing_up(HermiteSimpson(), 3.0)
    assert solution.success
    torque = solution.trajectories[T]
    replay = solve_ivp(
        lambda s, y: [y[1], np.interp(s, times, torque) - g * np.sin(y[0])],
        (times[0], times[-1]),
        [0.0, 0.0],
        t_eval=times,
        rtol=1e-10,
        atol=1e-10,
        max_step=times[1] - times[0],
    )
    assert abs(replay.y[0, -1] - np.pi) < 1e-2
    assert np.max(np.abs(replay.y[0] - solution.trajectories[theta])) < 1e-2


def test_looser_torque_bound_costs_less():
    costs = [swing_up(Midpoint(), limit)[1].stats["objective"] for limit in (3.0, 5.0)]
    assert costs[1] < costs[0]
