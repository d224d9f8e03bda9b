"""The constrained Gauss-Newton solver with condensing, on the gain-scheduled two-mass toy.

References: IPOPT's optimum and multipliers on the same problem (a second method), a
direct sparse solve of the full Gauss-Newton KKT system for the first step, and the known
schedule the data were simulated with. Each is checked with the positions tracked and with
the controller's torques tracked too (objective terms in a node's states and the
parameters).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from sympy.physics.mechanics import dynamicsymbols
from test_schedule_engine import (
    F1,
    F2,
    ID_STRIKES,
    PLANT,
    T1,
    T2,
    closed_toy,
    excitation,
    identification_problem,
    identification_times,
    phase_from_strikes,
    q1,
    q2,
    reference_torque,
    simulate,
    true_schedule,
    u1,
    u2,
)

from colloc import GaussNewtonOptions, Problem, ProblemDefinitionError, Tracking
from colloc.model.symbols import name_of
from colloc.solve import ChainStructure, solve_gauss_newton
from colloc.transcription import BackwardEuler, HermiteSimpson, Midpoint

w1, w2 = dynamicsymbols("w1 w2")
SIGMA_Q, SIGMA_T, SIGMA_F, SIGMA_W = 0.01, 0.05, 0.05, 0.3


def noise_model_problem(scheme, torques=False):
    """The toy with motor noise on both torques (free at every node, penalised by
    ``1/sigma^2``) and ``F1`` measured with noise (a free trajectory tracked to its
    measurement), fitted to noisy positions (and torques); starts at the measured states."""
    closed, gs = closed_toy(
        "full", outputs=[q1, q2, T1, T2] if torques else None, disturbances={T1: w1, T2: w2}
    )
    Tstar, K = true_schedule("full")
    times = identification_times()
    X, F = simulate(Tstar, K, times), excitation(times)
    rng = np.random.default_rng(11)
    noisy = X + rng.normal(0.0, SIGMA_Q, X.shape)
    measured = {q1: noisy[:, 0], q2: noisy[:, 1]}
    weights = {q1: SIGMA_Q**-2, q2: SIGMA_Q**-2}
    phase = phase_from_strikes(times, ID_STRIKES)
    if torques:
        tau = reference_torque(phase, X, Tstar, K) + rng.normal(0.0, SIGMA_T, (times.size, 2))
        measured.update({T1: tau[:, 0], T2: tau[:, 1]})
        weights.update({T1: SIGMA_T**-2, T2: SIGMA_T**-2})
    problem = Problem(
        closed,
        times,
        scheme=scheme,
        known_trajectories={gs.phase: phase, F2: F[:, 1]},
        measured_inputs={F1: (F[:, 0] + rng.normal(0.0, SIGMA_F, times.size), SIGMA_F)},
        process_noise={w1: SIGMA_W, w2: SIGMA_W},
        known_parameters=PLANT,
        objective=Tracking(measured, weights),
        cache=False,
    )
    rates = np.gradient(noisy[:, :2], times, axis=0)
    guess = problem.initial_guess(
        {q1: noisy[:, 0], q2: noisy[:, 1], u1: rates[:, 0], u2: rates[:, 1]},
        gs.parameter_values(1.1 * Tstar, 0.9 * K),
    )
    return problem, guess


def toy_problem(scheme, bounds=None, torques=False):
    problem, gs, Tstar, K, _, guess = identification_problem("full", scheme, bounds, torques)
    return problem, gs, Tstar, K, guess


@pytest.fixture(
    scope="module",
    params=[
        (BackwardEuler(), False),
        (Midpoint(), False),
        (BackwardEuler(), True),
        (Midpoint(), True),
    ],
    ids=["be", "midpoint", "be-torques", "midpoint-torques"],
)
def solved(request):
    scheme, torques = request.param
    problem, gs, Tstar, K, guess = toy_problem(scheme, torques=torques)
    reference = problem.solve(guess, print_level=0, tol=1e-12)
    assert reference.status.success
    return problem, gs, Tstar, K, guess, reference, torques


@pytest.mark.parametrize("segment", [7, 50, 1000])
def test_optimum_and_multipliers_match_ipopt(solved, segment):
    problem, _, _, _, guess, reference, torques = solved
    # with torques tracked, Gauss-Newton converges linearly (backward Euler's bias leaves
    # residuals at the optimum, whose curvature it leaves out), so rounding ends it sooner
    tol = 1e-13 if torques else 1e-16
    options = GaussNewtonOptions(segment_nodes=segment, tol=tol, constraint_tol=1e-11)
    solution = problem.solve_gauss_newton(guess, options)
    assert solution.status.success
    scale = np.abs(reference.z).max()
    np.testing.assert_allclose(solution.z, reference.z, atol=(1e-5 if torques else 1e-6) * scale)
    lam = np.abs(reference.multipliers).max()
    np.testing.assert_allclose(
        solution.multipliers, reference.multipliers, atol=(1e-3 if torques else 1e-5) * lam
    )
    assert solution.stats["constraint_violation"] <= 1e-11


def test_midpoint_recovers_the_simulated_schedule():
    problem, gs, Tstar, K, guess = toy_problem(Midpoint())
    solution = problem.solve_gauss_newton(guess, GaussNewtonOptions(tol=1e-16))
    Tstar_hat, K_hat = gs.arrays(solution.parameters)
    # midpoint's O(h^2) error at h = 0.01 s: a few parts in a thousand of the peak values
    np.testing.assert_allclose(Tstar_hat, Tstar, atol=3e-3 * np.abs(Tstar).max())
    np.testing.assert_allclose(K_hat, K, atol=3e-3 * np.abs(K).max())


def first_steps(problem, guess):
    """The first Gauss-Newton step by a SuperLU solve of the whole KKT system
    ``[H J^T; J 0]`` (H the objective's Gauss-Newton Hessian), and one iteration of the
    solver (13-node segments, no damping)."""
    nlp = problem.nlp
    jr, jc = nlp.jacobianstructure()
    J = sp.csr_matrix((nlp.jacobian(guess), (jr, jc)), shape=(nlp.m, nlp.n))
    hr, hc = nlp.hessianstructure()
    Hl = sp.csr_matrix((nlp.gauss_newton_hessian(guess), (hr, hc)), (nlp.n, nlp.n))
    H = Hl + sp.triu(Hl.T, 1)
    kkt = sp.bmat([[H, J.T], [J, None]], format="csc")
    rhs = np.r_[-nlp.gradient(guess), -nlp.constraints(guess)]
    direct = spla.spsolve(kkt, rhs)[: nlp.n]
    options = GaussNewtonOptions(segment_nodes=13, max_iter=1, damping=1e-14)
    return direct, solve_gauss_newton(nlp, guess, problem.chain_structure(), options)


def test_first_step_equals_a_direct_solve_of_the_kkt_system(solved):
    """Condensing over segments is exact linear algebra: the first (undamped, full) step is
    the solution of [H J^T; J 0] with H the objective's Hessian, solved by SuperLU."""
    problem, gs, Tstar, K, guess, _, torques = solved
    if torques:
        # near the true schedule, so that the line search takes most of the first step
        states = {x: guess[problem.layout.node_indices(name_of(x))] for x in problem.model.states}
        guess = problem.initial_guess(states, gs.parameter_values(1.1 * Tstar, 0.9 * K))
    direct, result = first_steps(problem, guess)
    alpha = result.history[0]["alpha"]
    assert alpha == 1.0 or torques  # the line search may shorten the step, not turn it
    np.testing.assert_allclose((result.x - guess) / alpha, direct, atol=1e-7 * np.abs(direct).max())


def test_wall_time_and_interrupt_keep_the_last_accepted_iterate(solved):
    problem, _, _, _, guess, _, _ = solved
    stopped = problem.solve_gauss_newton(guess, GaussNewtonOptions(max_wall_time=1e-9))
    assert stopped.status.name == "Maximum_WallTime_Exceeded"
    np.testing.assert_array_equal(stopped.z, guess)

    seen = []

    def interrupt(row):
        seen.append(row["objective"])
        if len(seen) == 2:
            raise KeyboardInterrupt

    solution = problem.solve_gauss_newton(guess, progress=interrupt)
    assert solution.status.name == "User_Requested_Stop"
    assert solution.stats["iterations"] == 2
    assert solution.stats["objective"] == pytest.approx(seen[-1])
    assert "Ctrl-C" in solution.stats["ipopt_log"]


def test_progress_returning_false_stops_after_that_iteration(solved):
    problem, _, _, _, guess, _, _ = solved
    solution = problem.solve_gauss_newton(guess, progress=lambda row: False)
    assert solution.status.name == "User_Requested_Stop"
    assert solution.stats["iterations"] == 1


def test_problems_that_are_not_a_chain_are_refused():
    problem, *_, guess = toy_problem(HermiteSimpson())
    with pytest.raises(ProblemDefinitionError, match="scheme: .*one-step scheme"):
        problem.solve_gauss_newton(guess)
    problem, *_, guess = toy_problem(BackwardEuler(), bounds={q1: (-2.0, 2.0)})
    with pytest.raises(ProblemDefinitionError, match="bounds"):
        problem.solve_gauss_newton(guess)


def test_structure_and_options_are_validated():
    with pytest.raises(ValueError, match=r"interval_rows: expected shape \(2, 3\)"):
        ChainStructure(np.zeros((3, 3), int), np.zeros(0, int), np.zeros((3, 3), int))
    with pytest.raises(ValueError, match="segment_nodes: .*found 1.*tol: .*found -1"):
        GaussNewtonOptions(segment_nodes=1, tol=-1)


def test_ipopt_with_the_gauss_newton_hessian_reaches_the_same_optimum(solved):
    """IPOPT's hessian='gauss-newton' leaves out the constraints' curvature: a different
    path (its own linear algebra and line search) to the same optimum."""
    problem, _, _, _, guess, reference, _ = solved
    solution = problem.solve(guess, hessian="gauss-newton", print_level=0, tol=1e-12)
    assert solution.status.success
    scale = np.abs(reference.z).max()
    np.testing.assert_allclose(solution.z, reference.z, atol=1e-6 * scale)


@pytest.fixture(
    scope="module",
    params=[
        (BackwardEuler(), False),
        (Midpoint(), False),
        (Midpoint(), True),
    ],
    ids=["be", "midpoint", "midpoint-torques"],
)
def noise_model(request):
    scheme, torques = request.param
    problem, guess = noise_model_problem(scheme, torques)
    reference = problem.solve(guess, print_level=0, tol=1e-12)
    assert reference.status.success
    return problem, guess, reference


# one segment of every node eliminates all the free inputs at once: 13-15 s a scheme, run
# by benchmarks/slow_tests.py (the one-segment chain without them is tested above, in CI)
@pytest.mark.parametrize("segment", [7, pytest.param(1000, marks=pytest.mark.slow)])
def test_free_inputs_reach_ipopts_optimum(noise_model, segment):
    """Disturbances and a measured input at every node (eliminated inside each segment):
    the same optimum, disturbances included, as IPOPT on the full NLP."""
    problem, guess, reference = noise_model
    assert problem.chain_structure().input_index.shape == (problem.layout.num_nodes, 3)
    options = GaussNewtonOptions(segment_nodes=segment, tol=1e-14, constraint_tol=1e-11)
    solution = problem.solve_gauss_newton(guess, options)
    assert solution.status.success
    for symbol in (w1, w2, F1, q1, u2):
        expected = reference.trajectories[symbol]
        np.testing.assert_allclose(
            solution.trajectories[symbol], expected, atol=1e-6 * np.abs(expected).max()
        )
    estimated = np.array(list(solution.parameters.values()))
    expected = np.array([reference.parameters[p] for p in solution.parameters])
    np.testing.assert_allclose(estimated, expected, atol=1e-6 * np.abs(expected).max())


def test_first_step_with_free_inputs_equals_a_direct_kkt_solve(noise_model):
    problem, guess, _ = noise_model
    direct, result = first_steps(problem, guess)
    alpha = result.history[0]["alpha"]
    np.testing.assert_allclose((result.x - guess) / alpha, direct, atol=1e-7 * np.abs(direct).max())
