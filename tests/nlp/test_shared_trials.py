"""Several trials sharing their unknown parameters (:class:`colloc.Trials`).

A mass-spring-damper (damping c and stiffness k unknown, shared) recorded in three trials,
each with its own grid, force, initial state and noise. Checked against references that do
not use the composite:

* trials on one grid give the estimate, objective and KKT errors of opty's way by hand: one
  model holding a copy of the states per trial;
* on their own grids, the estimate is the minimum of the profile objective (each trial
  solved alone with the parameters known, summed) and the KKT covariance is
  ``2 sigma^2`` times the inverse of that profile's Hessian, both by finite differences;
* the sandwich's blocks lie inside trials: each block's influence ``u_b`` equals the change
  of the estimate when that block's weights are scaled (finite differences of re-solves);
* the Cramer-Rao bound of the design adds the trials' informations;
* the discretisation error of the shared estimate, on noise-free data, is the estimate's
  actual error from the truth.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
from scipy.integrate import solve_ivp
from sympy.physics.mechanics import dynamicsymbols

from colloc import (
    Model,
    Problem,
    ProblemDefinitionError,
    Tracking,
    Trials,
    cramer_rao_bound,
    discretisation_error,
    parameter_uncertainty,
)

t = dynamicsymbols._t
x, v, F = dynamicsymbols("x v F")
m, c, k = sm.symbols("m c k")
MASS, DAMPING, STIFFNESS = 1.0, 0.6, 18.0
SIGMA = 0.002
#: (step, nodes, force, initial state) of each trial
DESIGN = [
    (0.02, 201, lambda s: 3.0 * np.sin(2.0 * s) + 2.0 * np.sin(5.3 * s), (0.1, 0.0)),
    (0.03, 151, lambda s: 4.0 * np.sin(1.3 * s) + np.sin(7.0 * s), (-0.05, 0.2)),
    (0.025, 101, lambda s: 2.0 * np.cos(3.1 * s), (0.0, 0.0)),
]
TRUTH = {c: DAMPING, k: STIFFNESS}
QUIET = {"stall_seconds": None, "print_level": 0, "tol": 1e-11}


def plant() -> Model:
    return Model.from_equations(
        [x.diff(t) - v, m * v.diff(t) + c * v + k * x - F], [x, v], outputs=[x], known_inputs=[F]
    )


def motion(times: np.ndarray, force, start) -> np.ndarray:
    """Positions and velocities of the continuous plant (tight tolerances)."""

    def rhs(s, y):
        return [y[1], (force(s) - DAMPING * y[1] - STIFFNESS * y[0]) / MASS]

    out = solve_ivp(rhs, times[[0, -1]], start, t_eval=times, rtol=1e-11, atol=1e-13)
    return out.y.T


def trial_data(seed: int, same_grid: bool = False, noise: float = SIGMA):
    """Per trial: times, force at the nodes, measured positions, true states."""
    rng = np.random.default_rng(seed)
    out = []
    for step, nodes, force, start in DESIGN:
        if same_grid:
            step, nodes = DESIGN[0][0], DESIGN[0][1]
        times = np.arange(nodes) * step
        states = motion(times, force, start)
        measured = states[:, 0] + rng.normal(0.0, noise, nodes)
        out.append((times, force(times), measured, states))
    return out


def one_problem(times, force, measured, known=None, objective=None) -> Problem:
    return Problem(
        plant(),
        times,
        known_trajectories={F: force},
        known_parameters={m: MASS, **(known or {})},
        objective=objective if objective is not None else Tracking({x: measured}),
        cache=False,
    )


def guess(problem: Problem, measured, times, params=None) -> np.ndarray:
    return problem.initial_guess(
        {x: measured, v: np.gradient(measured, times)},
        params
        if params is not None
        else ({c: 0.3, k: 15.0} if problem.partition.unknown_parameters else None),
    )


def solve_trials(data, objectives=None):
    problems = [
        one_problem(ts, f, d, objective=None if objectives is None else objectives[i])
        for i, (ts, f, d, _) in enumerate(data)
    ]
    trials = Trials(problems)
    z0 = trials.initial_guess(
        [guess(p, d, ts) for p, (ts, _, d, _) in zip(problems, data, strict=True)]
    )
    return trials, trials.solve(z0, **QUIET)


def test_trials_on_one_grid_match_one_model_with_a_copy_of_the_states_per_trial():
    data = trial_data(1, same_grid=True)
    trials, solution = solve_trials(data)
    assert solution.success
    # opty's way by hand: one model whose states are the three trials' copies
    xs, vs, Fs = (dynamicsymbols(f"{s}1:4") for s in "xvF")
    equations = []
    for xi, vi, Fi in zip(xs, vs, Fs, strict=True):
        equations += [xi.diff(t) - vi, m * vi.diff(t) + c * vi + k * xi - Fi]
    stacked = Model.from_equations(
        equations,
        [s for pair in zip(xs, vs, strict=True) for s in pair],
        outputs=list(xs),
        known_inputs=list(Fs),
    )
    times = data[0][0]
    by_hand = Problem(
        stacked,
        times,
        known_trajectories={Fi: f for Fi, (_, f, _, _) in zip(Fs, data, strict=True)},
        known_parameters={m: MASS},
        objective=Tracking({xi: d for xi, (_, _, d, _) in zip(xs, data, strict=True)}),
        cache=False,
    )
    start = {}
    for xi, vi, (ts, _, d, _) in zip(xs, vs, data, strict=True):
        start.update({xi: d, vi: np.gradient(d, ts)})
    reference = by_hand.solve(by_hand.initial_guess(start, {c: 0.3, k: 15.0}), **QUIET)
    assert reference.success
    for p in (c, k):
        assert solution.parameters[p] == pytest.approx(reference.parameters[p], rel=1e-7)
    assert solution.stats["objective"] == pytest.approx(reference.stats["objective"], rel=1e-8)
    ours = parameter_uncertainty(trials, solution, method="kkt", discretisation=False)
    theirs = parameter_uncertainty(by_hand, reference, method="kkt", discretisation=False)
    assert ours.degrees_of_freedom == theirs.degrees_of_freedom
    np.testing.assert_allclose(ours.covariance, theirs.covariance, rtol=1e-5)
    # each trial's own solution carries its trajectory and the shared estimate
    for i, (_, _, _, states) in enumerate(data):
        own = solution[i]
        assert own.parameters[k] == solution.parameters[k]
        assert np.sqrt(np.mean((own.trajectories[x] - states[:, 0]) ** 2)) < 2 * SIGMA
    assert solution["trial 2"] is solution.trials[2]


def profile(data, theta: dict) -> float:
    """Sum over trials of each trial's objective minimised over its states alone, with the
    parameters known."""
    total = 0.0
    for ts, f, d, _ in data:
        alone = one_problem(ts, f, d, known=theta)
        answer = alone.solve(guess(alone, d, ts), **QUIET)
        assert answer.success
        total += answer.stats["objective"]
    return total


def test_trials_on_their_own_grids_minimise_the_profile_objective_with_its_curvature():
    data = trial_data(2)
    trials, solution = solve_trials(data)
    assert solution.success
    est = np.array([solution.parameters[c], solution.parameters[k]])
    steps = np.array([2e-3, 2e-2])

    def V(values):
        return profile(data, {c: values[0], k: values[1]})

    grad = np.zeros(2)
    hess = np.zeros((2, 2))
    at = V(est)
    for i in range(2):
        e_i = np.eye(2)[i] * steps[i]
        plus, minus = V(est + e_i), V(est - e_i)
        grad[i] = (plus - minus) / (2 * steps[i])
        hess[i, i] = (plus - 2 * at + minus) / steps[i] ** 2
    e0, e1 = np.eye(2)[0] * steps[0], np.eye(2)[1] * steps[1]
    hess[0, 1] = hess[1, 0] = (
        V(est + e0 + e1) - V(est + e0 - e1) - V(est - e0 + e1) + V(est - e0 - e1)
    ) / (4 * steps[0] * steps[1])
    unc = parameter_uncertainty(trials, solution, method="kkt", discretisation=False)
    # the estimate is the profile's minimum: the Newton step to it is under 1 % of a
    # standard error (measured: 0.04 % and 0.2 %; the profile's solves stop at 1e-11)
    newton = np.linalg.solve(hess, grad)
    se = np.sqrt(np.diag(unc.covariance))
    assert np.all(np.abs(newton) < 1e-2 * se)
    expected = 2.0 * unc.noise_variance * np.linalg.inv(hess)
    np.testing.assert_allclose(unc.covariance, expected, rtol=2e-3)
    # 453 samples, two parameters and the six initial states free
    assert unc.degrees_of_freedom == sum(n for _, n, _, _ in DESIGN) - 2 - 6


def test_the_sandwich_blocks_lie_inside_trials_and_match_reweighted_resolves():
    data = trial_data(3)
    halves = [[0, ts.size // 2] for ts, _, _, _ in data]

    def objectives(scales):
        # one tracking term per block (NaN elsewhere), weighted by its scale
        out = []
        for (ts, _, d, _), starts, own in zip(data, halves, scales, strict=True):
            terms = []
            for b, first in enumerate(starts):
                last = starts[b + 1] if b + 1 < len(starts) else ts.size
                part = np.full(ts.size, np.nan)
                part[first:last] = d[first:last]
                terms.append(Tracking({x: part}, own[b]))
            out.append(terms)
        return out

    ones = [[1.0, 1.0] for _ in data]
    trials, solution = solve_trials(data, objectives(ones))
    unc = parameter_uncertainty(
        trials, solution, method="sandwich", blocks=halves, discretisation=False
    )
    assert unc.blocks == 6

    # the same design, one block's weights scaled by 1 +- eps, solved again from the estimate
    eps = 1e-4
    influences = []
    for i in range(len(data)):
        for b in range(2):
            moved = []
            for sign in (1.0, -1.0):
                scales = [list(s) for s in ones]
                scales[i][b] = 1.0 + sign * eps
                for p, terms in zip(trials.problems, objectives(scales), strict=True):
                    p.replace_data(objective=terms)
                again = trials.solve(solution.z, **QUIET)
                assert again.success
                moved.append(np.array([again.parameters[c], again.parameters[k]]))
            influences.append((moved[0] - moved[1]) / (2 * eps))
    U = np.array(influences).T
    nb = U.shape[1]
    np.testing.assert_allclose(unc.covariance, nb / (nb - 1) * U @ U.T, rtol=2e-3)


def test_the_bound_of_several_trials_adds_their_information():
    data = trial_data(4)
    problems = [one_problem(ts, f, d) for ts, f, d, _ in data]
    truth = [
        p.initial_guess({x: s[:, 0], v: s[:, 1]}, TRUTH)
        for p, (_, _, _, s) in zip(problems, data, strict=True)
    ]
    trials = Trials(problems)
    whole = cramer_rao_bound(trials, trials.initial_guess(truth), SIGMA**2)
    information = sum(
        np.linalg.inv(cramer_rao_bound(p, z, SIGMA**2).covariance)
        for p, z in zip(problems, truth, strict=True)
    )
    np.testing.assert_allclose(whole.covariance, np.linalg.inv(information), rtol=1e-9)


def test_the_discretisation_error_of_several_trials_is_the_estimate_s_own_error():
    data = trial_data(5, noise=0.0)
    trials, solution = solve_trials(data)
    estimate = discretisation_error(trials, solution, print_level=0)
    assert estimate.estimated, estimate.note
    for p in (c, k):
        actual = solution.parameters[p] - TRUTH[p]
        # midpoint's error here: -7.0e-4 in c, 1.9e-2 in k (4 of the noisy fit's SE); the
        # estimate caught it to 0.13 % and 0.003 %
        assert abs(actual) > 1e-4 * TRUTH[p]
        assert estimate.errors[p] == pytest.approx(actual, rel=0.02)
    assert "twice as fine" in estimate.note


def test_trials_and_their_errors_refuse_what_they_cannot_take():
    data = trial_data(6)
    (t0, f0, d0, _), (t1, f1, d1, _) = data[:2]
    a, b = one_problem(t0, f0, d0), one_problem(t1, f1, d1)
    with pytest.raises(TypeError, match="sequence of colloc.Problem"):
        Trials(a)
    with pytest.raises(ProblemDefinitionError, match=r"problems\[1\]: the same Problem"):
        Trials([a, a])
    with pytest.raises(ProblemDefinitionError, match="names: expected 2 names"):
        Trials([a, b], names=["only"])
    with pytest.raises(ProblemDefinitionError, match="expected a colloc.Problem"):
        Trials([a, "b"])
    bounded = Problem(
        plant(),
        t1,
        known_trajectories={F: f1},
        known_parameters={m: MASS},
        objective=Tracking({x: d1}),
        bounds={c: (0.0, 5.0)},
        cache=False,
    )
    with pytest.raises(ProblemDefinitionError, match="c is bounded"):
        Trials([a, bounded])
    known = one_problem(t1, f1, d1, known=TRUTH)
    with pytest.raises(ProblemDefinitionError, match="none has an unknown parameter"):
        Trials([known])
    trials = Trials([a, b])
    with pytest.raises(ValueError, match="expected 2 free vectors"):
        trials.initial_guess([guess(a, d0, t0)])
    with pytest.raises(ValueError, match=r"guesses\[1\]: expected shape"):
        trials.initial_guess([guess(a, d0, t0), guess(a, d0, t0)])
    with pytest.raises(ValueError, match="not a state, free input or unknown parameter of any"):
        trials.variable_scale({F: 2.0})
    z0 = trials.initial_guess([guess(a, d0, t0), guess(b, d1, t1)], {k: 17.0})
    assert z0[trials.parameter_offset + 1] == 17.0
    assert trials.describe_variable(trials.offsets[1]).startswith("trial 1: x at node 0")
    solution = trials.solve(z0, **QUIET)
    alone = a.solve(guess(a, d0, t0), **QUIET)
    with pytest.raises(ValueError, match="not a solve of this problem"):
        parameter_uncertainty(trials, alone)
    # a flat list reads like the one-trial form: the message says how the trials' differs
    with pytest.raises(
        ValueError,
        match=r"with 2 trials, expected .*a flat list of numbers is one trial's first nodes",
    ):
        parameter_uncertainty(trials, solution, method="sandwich", blocks=[0, 50])
    with pytest.raises(ValueError, match=r"blocks\[1\]: first node 400 is beyond"):
        parameter_uncertainty(trials, solution, method="sandwich", blocks=[[0], [0, 400]])


def test_a_trial_s_own_parameter_needs_two_sandwich_blocks_in_its_trial():
    b0, b1, y = sm.Symbol("b0"), sm.Symbol("b1"), dynamicsymbols("y")
    problems = []
    for b, (ts, f, d, _) in zip((b0, b1), trial_data(8)[:2], strict=True):
        model = Model.from_equations(
            [x.diff(t) - v, m * v.diff(t) + c * v + k * x - F],
            [x, v],
            outputs={y: x + b},
            known_inputs=[F],
            parameters=[m, c, k, b],
        )
        problems.append(
            Problem(
                model,
                ts,
                known_trajectories={F: f},
                known_parameters={m: MASS},
                objective=Tracking({y: d + 0.01}),
                cache=False,
            )
        )
    trials = Trials(problems)
    guesses = [
        p.initial_guess({x: d, v: np.gradient(d, ts)}, {b: 0.0})
        for p, b, (ts, _, d, _) in zip(problems, (b0, b1), trial_data(8)[:2], strict=True)
    ]
    solution = trials.solve(trials.initial_guess(guesses, {c: 0.3, k: 15.0}), **QUIET)
    assert set(trials.unknown_parameters) == {c, k, b0, b1}
    assert solution.parameters[b1] == pytest.approx(0.01, abs=5 * SIGMA)
    # one block in trial 1: b1's only block has a vanishing gradient at the optimum
    with pytest.raises(ValueError, match=r"b1 \(trial 1's own\) would be informed by one block"):
        parameter_uncertainty(trials, solution, method="sandwich", blocks=[[0, 60], [0]])
    two = parameter_uncertainty(
        trials, solution, method="sandwich", blocks=[[0, 60], [0, 70]], discretisation=False
    )
    assert two.blocks == 4
    assert all(se > 0 for se in two.standard_errors.values())
