"""Scheduled parameters in the collocation engine, on a gain-scheduled two-mass toy.

Two coupled masses (one with a nonlinear spring) driven by known forces ``F1``, ``F2`` and by
``T = T*(phi) - K(phi) s`` with ``s = [q1, q2, u1, u2]`` scheduled at ``P = 5`` points. The
phase is piecewise linear in time between irregular "heel strikes", so it is not
proportional to time, and some strikes fall inside grid intervals.

References: a dense NumPy evaluation of each scheme's defects (torques from NumPy's
periodic ``np.interp``), central finite differences of the assembled derivatives, the
bracketing points worked out from the phase, and recovery of a known schedule from data
simulated with SciPy's ``solve_ivp``.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
from nlp_derivatives import central_difference, dense_hessian, dense_jacobian
from scipy.integrate import solve_ivp
from sympy.physics.mechanics import dynamicsymbols

from colloc import (
    GainScheduled,
    Model,
    Problem,
    ProblemDefinitionError,
    Tracking,
    parameter_uncertainty,
)
from colloc.transcription import BackwardEuler, HermiteSimpson, Midpoint, Trapezoidal

t = dynamicsymbols._t
q1, q2, u1, u2, T1, T2, F1, F2 = dynamicsymbols("q1 q2 u1 u2 T1 T2 F1 F2")
m1, m2, c, k1, k2, kc = sm.symbols("m1 m2 c k1 k2 kc")
STATES = [q1, q2, u1, u2]
PLANT = {m1: 1.0, m2: 1.4, c: 0.4, k1: 5.0, k2: 3.0, kc: 1.5}
P = 5


def closed_toy(structure="full", points=P, outputs=None, disturbances=None):
    residual = [
        q1.diff(t) - u1,
        q2.diff(t) - u2,
        m1 * u1.diff(t) + c * u1 + k1 * sm.sin(q1) + kc * (q1 - q2) - T1 - F1,
        m2 * u2.diff(t) + c * u2 + k2 * q2 + kc * (q2 - q1) - T2 - F2,
    ]
    model = Model.from_equations(
        residual, STATES, controlled_inputs=[T1, T2], known_inputs=[F1, F2], outputs=outputs
    )
    if disturbances:
        model = model.with_disturbances(disturbances)
    gs = GainScheduled(points, STATES, [T1, T2], structure=structure)
    return model.close_loop(gs), gs


def phase_from_strikes(times, strikes):
    """Unwrapped phase: 0 at the first strike, rising linearly to 1, 2, ... at the next ones."""
    return np.interp(times, strikes, np.arange(strikes.size, dtype=float))


def reference_torque(phase, s, Tstar, K):
    """``T*(phi) - K(phi) s`` by NumPy's periodic linear interpolation."""
    xp = np.arange(Tstar.shape[0]) / Tstar.shape[0]
    out = np.empty((phase.size, Tstar.shape[1]))
    for j in range(Tstar.shape[1]):
        out[:, j] = np.interp(phase, xp, Tstar[:, j], period=1.0)
        for i in range(s.shape[1]):
            out[:, j] -= np.interp(phase, xp, K[:, j, i], period=1.0) * s[:, i]
    return out


def reference_residual(xd, x, T, F, cv):
    p = PLANT
    return np.column_stack(
        [
            xd[:, 0] - x[:, 2],
            xd[:, 1] - x[:, 3],
            p[m1] * xd[:, 2]
            + cv * x[:, 2]
            + p[k1] * np.sin(x[:, 0])
            + p[kc] * (x[:, 0] - x[:, 1])
            - T[:, 0]
            - F[:, 0],
            p[m2] * xd[:, 3]
            + cv * x[:, 3]
            + p[k2] * x[:, 1]
            + p[kc] * (x[:, 1] - x[:, 0])
            - T[:, 1]
            - F[:, 1],
        ]
    )


# ---------------------------------------------------------------------- small engine problems
# Cubic forces: the engine's midpoint values (cubic interpolation) are then exact.
def cubic_forces(tt):
    tt = np.asarray(tt, float)
    return np.column_stack(
        [0.3 + 0.5 * tt - 0.2 * tt**2 + 0.05 * tt**3, -0.1 + 0.2 * tt + 0.1 * tt**2 - 0.03 * tt**3]
    )


SMALL_TIMES = np.cumsum(np.r_[0.0, np.random.default_rng(0).uniform(0.15, 0.33, 10)])
SMALL_STRIKES = np.array([-0.5, 0.47, 1.21, 2.05, 3.0])
OTHER_STRIKES = np.array([-0.2, 0.71, 1.33, 2.4, 3.2])


def schedule_values(seed):
    rng = np.random.default_rng(seed)
    return rng.normal(size=(P, 2)), rng.normal(size=(P, 2, 4))


def small_problem(scheme, *, known_schedule, strikes=SMALL_STRIKES, seed=1):
    closed, gs = closed_toy()
    times = SMALL_TIMES
    F = cubic_forces(times)
    Tstar, K = schedule_values(seed)
    known = {p: v for p, v in PLANT.items() if p is not c}
    kwargs = {}
    if known_schedule:
        known.update({c: PLANT[c], **gs.parameter_values(Tstar, K)})
    else:
        # c stays unknown: a plain unknown parameter next to the schedule
        kwargs["objective"] = Tracking({q1: np.sin(times), q2: np.cos(2 * times)})
    problem = Problem(
        closed,
        times,
        scheme=scheme,
        known_trajectories={gs.phase: phase_from_strikes(times, strikes), F1: F[:, 0], F2: F[:, 1]},
        known_parameters=known,
        cache=False,
        **kwargs,
    )
    return problem, gs, Tstar, K


def random_point(problem, gs, Tstar, K, seed):
    rng = np.random.default_rng(seed)
    lay = problem.layout
    z = rng.uniform(-1.0, 1.0, lay.num_variables)
    for p, v in gs.parameter_values(Tstar, K).items():
        if str(p) in lay.parameter_names:
            z[lay.variable_index(str(p))] = v
    return z


def unpack(problem, z):
    """States X, derivative variables V (or None), interval variables M, value of c."""
    lay = problem.layout
    Xn = lay.node_matrix(z)
    X = Xn[:, [lay.node_names.index(str(s.func)) for s in STATES]]
    V = None
    if "q1'" in lay.node_names:
        V = Xn[:, [lay.node_names.index(f"{s.func}'") for s in STATES]]
    M = lay.interval_matrix(z) if lay.num_interval_variables else None
    cv = z[lay.variable_index("c")] if "c" in lay.parameter_names else PLANT[c]
    return X, V, M, cv


def ref_backward_euler(X, V, M, cv, times, phase, sched):
    h = np.diff(times)[:, None]
    T = reference_torque(phase[1:], X[1:], *sched)
    return reference_residual(np.diff(X, axis=0) / h, X[1:], T, cubic_forces(times[1:]), cv).ravel()


def ref_midpoint(X, V, M, cv, times, phase, sched):
    h = np.diff(times)[:, None]
    xm = 0.5 * (X[:-1] + X[1:])
    tm = 0.5 * (times[:-1] + times[1:])
    # the engine knows the phase at the nodes only and takes it linear in time in between
    T = reference_torque(np.interp(tm, times, phase), xm, *sched)
    return reference_residual(np.diff(X, axis=0) / h, xm, T, cubic_forces(tm), cv).ravel()


def node_residuals(X, V, cv, times, phase, sched):
    T = reference_torque(phase, X, *sched)
    return reference_residual(V, X, T, cubic_forces(times), cv).ravel()


def ref_trapezoidal(X, V, M, cv, times, phase, sched):
    h = np.diff(times)[:, None]
    interval = np.diff(X, axis=0) - 0.5 * h * (V[:-1] + V[1:])
    return np.r_[interval.ravel(), node_residuals(X, V, cv, times, phase, sched)]


def ref_hermite_simpson(X, V, M, cv, times, phase, sched):
    h = np.diff(times)[:, None]
    xm, vm = M[:, :4], M[:, 4:]
    tm = 0.5 * (times[:-1] + times[1:])
    T = reference_torque(np.interp(tm, times, phase), xm, *sched)
    interval = np.hstack(
        [
            xm - 0.5 * (X[:-1] + X[1:]) - h / 8 * (V[:-1] - V[1:]),
            np.diff(X, axis=0) - h / 6 * (V[:-1] + 4 * vm + V[1:]),
            reference_residual(vm, xm, T, cubic_forces(tm), cv),
        ]
    )
    return np.r_[interval.ravel(), node_residuals(X, V, cv, times, phase, sched)]


CASES = [
    (BackwardEuler(), ref_backward_euler),
    (Midpoint(), ref_midpoint),
    (Trapezoidal(), ref_trapezoidal),
    (HermiteSimpson(), ref_hermite_simpson),
]
IDS = [s.name for s, _ in CASES]


@pytest.fixture(scope="module", params=CASES, ids=IDS)
def case(request):
    scheme, reference = request.param
    return scheme, reference, small_problem(scheme, known_schedule=False)


@pytest.mark.parametrize(("scheme", "reference"), CASES, ids=IDS)
def test_defects_with_known_schedule_match_dense_numpy(scheme, reference):
    problem, gs, Tstar, K = small_problem(scheme, known_schedule=True)
    assert problem.layout.parameter_names == []
    phase = phase_from_strikes(SMALL_TIMES, SMALL_STRIKES)
    for seed in (3, 4):
        z = random_point(problem, gs, Tstar, K, seed)
        expected = reference(*unpack(problem, z), SMALL_TIMES, phase, (Tstar, K))
        np.testing.assert_allclose(problem.defects(z), expected, rtol=1e-12, atol=1e-12)


def test_defects_with_unknown_schedule_match_dense_numpy(case):
    scheme, reference, (problem, gs, Tstar, K) = case
    assert len(problem.layout.parameter_names) == len(gs.parameters) + 1
    phase = phase_from_strikes(SMALL_TIMES, SMALL_STRIKES)
    for seed in (5, 6):
        z = random_point(problem, gs, Tstar, K, seed)
        expected = reference(*unpack(problem, z), SMALL_TIMES, phase, (Tstar, K))
        np.testing.assert_allclose(problem.defects(z), expected, rtol=1e-12, atol=1e-12)
    # a different schedule in z changes the defects accordingly
    other = schedule_values(seed=9)
    z = random_point(problem, gs, *other, seed=7)
    expected = reference(*unpack(problem, z), SMALL_TIMES, phase, other)
    np.testing.assert_allclose(problem.defects(z), expected, rtol=1e-12, atol=1e-12)


def two_schedule_problem(scheme):
    """Right controller on T1 (P = 3, known values), left on T2 (P = 4, unknown), each with
    its own phase: slots of known and unknown schedules must not be mixed up."""
    residual = [
        q1.diff(t) - u1,
        q2.diff(t) - u2,
        m1 * u1.diff(t) + c * u1 + k1 * sm.sin(q1) + kc * (q1 - q2) - T1 - F1,
        m2 * u2.diff(t) + c * u2 + k2 * q2 + kc * (q2 - q1) - T2 - F2,
    ]
    model = Model.from_equations(
        residual, STATES, controlled_inputs=[T1, T2], known_inputs=[F1, F2]
    )
    right = GainScheduled(3, [q1, u1], [T1], name="R")
    left = GainScheduled(4, [q2, u2], [T2], name="L")
    closed = model.close_loop(right).close_loop(left)
    rng = np.random.default_rng(31)
    sched_r = (rng.normal(size=(3, 1)), rng.normal(size=(3, 1, 2)))
    sched_l = (rng.normal(size=(4, 1)), rng.normal(size=(4, 1, 2)))
    times = SMALL_TIMES
    F = cubic_forces(times)
    phases = (
        phase_from_strikes(times, SMALL_STRIKES),
        phase_from_strikes(times, OTHER_STRIKES),
    )
    problem = Problem(
        closed,
        times,
        scheme=scheme,
        known_trajectories={
            right.phase: phases[0],
            left.phase: phases[1],
            F1: F[:, 0],
            F2: F[:, 1],
        },
        known_parameters={**PLANT, **right.parameter_values(*sched_r)},
        cache=False,
    )
    z = rng.uniform(-1.0, 1.0, problem.layout.num_variables)
    for p, v in left.parameter_values(*sched_l).items():
        z[problem.layout.variable_index(str(p))] = v
    return problem, z, phases, sched_r, sched_l


@pytest.mark.parametrize(("scheme", "reference"), CASES, ids=IDS)
def test_two_schedules_one_known_one_unknown(scheme, reference):
    problem, z, phases, sched_r, sched_l = two_schedule_problem(scheme)
    assert len(problem.layout.parameter_names) == 4 * 3
    X, V, M, cv = unpack(problem, z)
    # Each reference evaluation yields [T1, T2] from one schedule; combine the right one's T1
    # with the left one's T2 by evaluating twice with gains that zero the other input.
    full_r = _embed(sched_r, row=0, cols=[0, 2])
    full_l = _embed(sched_l, row=1, cols=[1, 3])
    with_r = reference(X, V, M, cv, SMALL_TIMES, phases[0], full_r)
    with_l = reference(X, V, M, cv, SMALL_TIMES, phases[1], full_l)
    none = reference(X, V, M, cv, SMALL_TIMES, phases[0], _embed(None, 0, []))
    expected = with_r + with_l - none  # the residual is affine in T
    np.testing.assert_allclose(problem.defects(z), expected, rtol=1e-12, atol=1e-12)


def _embed(sched, row, cols):
    """A two-input schedule whose only nonzero row is ``row`` (gains on states ``cols``)."""
    num = 2 if sched is None else sched[0].shape[0]
    Tstar, K = np.zeros((num, 2)), np.zeros((num, 2, 4))
    if sched is not None:
        Tstar[:, row] = sched[0][:, 0]
        K[:, row, cols] = sched[1][:, 0, :]
    return Tstar, K


# ---------------------------------------------------------------------- derivatives


def test_gradient_matches_finite_differences(case):
    _, _, (problem, gs, Tstar, K) = case
    nlp = problem.nlp
    z = random_point(problem, gs, Tstar, K, seed=11)
    fd = central_difference(lambda v: np.atleast_1d(nlp.objective(v)), z)[0]
    np.testing.assert_allclose(nlp.gradient(z), fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())


def test_jacobian_matches_finite_differences(case):
    _, _, (problem, gs, Tstar, K) = case
    nlp = problem.nlp
    z = random_point(problem, gs, Tstar, K, seed=12)
    fd = central_difference(nlp.constraints, z)
    J = dense_jacobian(nlp, z)
    np.testing.assert_allclose(J, fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())
    # the schedule columns carry real derivatives, not only structure
    assert np.abs(J[:, problem.layout.parameter_offset :]).max() > 0.1


def test_hessian_matches_finite_differences_of_lagrangian_gradient(case):
    _, _, (problem, gs, Tstar, K) = case
    nlp = problem.nlp
    rng = np.random.default_rng(13)
    z = random_point(problem, gs, Tstar, K, seed=14)
    lam = rng.normal(size=nlp.m)

    def lagrangian_gradient(v):
        return 0.8 * nlp.gradient(v) + dense_jacobian(nlp, v).T @ lam

    fd = central_difference(lagrangian_gradient, z)
    fd = 0.5 * (fd + fd.T)
    H = dense_hessian(nlp, z, lam, 0.8)
    np.testing.assert_allclose(H, fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())
    p0 = problem.layout.parameter_offset
    # K multiplies the states: state x gain entries of the Hessian are present
    assert np.abs(H[:p0, p0:]).max() > 0.1


# ---------------------------------------------------------------------- sparsity
# Where in an interval (fraction of h) each scheme evaluates the residual, from its formulas.
EVALUATION = {BackwardEuler: 1.0, Midpoint: 0.5, Trapezoidal: None, HermiteSimpson: 0.5}


def evaluation_phases(problem, phase):
    """Phase where each constraint row evaluates the residual (NaN: it does not)."""
    times = problem.grid.times
    fraction = EVALUATION[type(problem.scheme)]
    assert problem.scheme.interval_evaluation == fraction
    out = []
    for block in problem.layout.blocks:
        if block.item == "interval":
            where = (
                np.full(block.count, np.nan)
                if fraction is None
                else np.interp(times[:-1] + fraction * np.diff(times), times, phase)
            )
        else:
            where = phase
        out.append(np.repeat(where, block.rows))
    return np.concatenate(out)


def test_each_row_touches_the_two_bracketing_schedule_points(case):
    _, _, (problem, gs, _, _) = case
    lay = problem.layout
    point_of = {str(s): p for p, point in enumerate(gs.schedule.points) for s in point}
    c_col = lay.variable_index("c")
    phase = phase_from_strikes(SMALL_TIMES, SMALL_STRIKES)
    where = evaluation_phases(problem, phase)
    scaled = where[~np.isnan(where)] * P
    assert np.min(np.abs(scaled - np.round(scaled))) > 1e-3  # no row sits on a point
    rows, cols = problem.nlp.jacobianstructure()
    seen_lower = set()
    rows_with_schedule = 0
    for j in range(problem.nlp.m):
        pcols = set(cols[(rows == j) & (cols >= lay.parameter_offset)].tolist())
        points = {point_of[lay.parameter_names[i - lay.parameter_offset]] for i in pcols - {c_col}}
        assert len(points) <= 2
        if points:
            rows_with_schedule += 1
            a = int(np.floor(where[j] * P)) % P
            assert points == {a, (a + 1) % P}, lay.describe_constraint(j)
            seen_lower.add(a)
            # the controller's T* and every gain of both points are reached
            assert len(pcols - {c_col}) in (10, 20)
    # the two dynamic equations at every interval or node that evaluates the residual
    evaluations = sum(
        b.count
        for b in lay.blocks
        if b.item == "node" or EVALUATION[type(problem.scheme)] is not None
    )
    assert rows_with_schedule == 2 * evaluations
    assert P - 1 in seen_lower  # the periodic wrap from point 4 to point 0 occurs


def test_hessian_couples_schedule_points_only_through_shared_rows(case):
    """A variable meets a schedule point in the Hessian only if some constraint row holds
    both; distinct schedule points never meet (the residual is linear in them)."""
    _, _, (problem, gs, _, _) = case
    lay = problem.layout
    p0 = lay.parameter_offset
    point_of = {str(s): p for p, point in enumerate(gs.schedule.points) for s in point}
    col_point = np.full(lay.num_variables, -1)
    for i, name in enumerate(lay.parameter_names):
        col_point[p0 + i] = point_of.get(name, -1)
    jr, jc = problem.nlp.jacobianstructure()
    row_points = {}
    for j, col in zip(jr, jc, strict=True):
        if col_point[col] >= 0:
            row_points.setdefault(int(j), set()).add(int(col_point[col]))
    allowed = {}
    for j, col in zip(jr, jc, strict=True):
        allowed.setdefault(int(col), set()).update(row_points.get(int(j), set()))
    hr, hc = problem.nlp.hessianstructure()
    coupled = 0
    for a, b in zip(hr, hc, strict=True):
        pa, pb = col_point[a], col_point[b]
        assert pa < 0 or pb < 0, "two schedule parameters meet in the Hessian"
        if pa >= 0 or pb >= 0:
            var, point = (b, pa) if pa >= 0 else (a, pb)
            assert point in allowed[int(var)], lay.describe_variable(int(var))
            coupled += 1
    assert coupled > 0


# ---------------------------------------------------------------------- errors
def problem_kwargs(times, phase):
    F = cubic_forces(times)
    closed, gs = closed_toy()
    return closed, gs, {gs.phase: phase, F1: F[:, 0], F2: F[:, 1]}


def test_decreasing_phase_is_rejected():
    phase = phase_from_strikes(SMALL_TIMES, SMALL_STRIKES)
    phase[6] = phase[5] - 0.01
    closed, gs, known = problem_kwargs(SMALL_TIMES, phase)
    with pytest.raises(ProblemDefinitionError, match=r"phi\].*non-decreasing.*after node 5"):
        Problem(closed, SMALL_TIMES, known_trajectories=known, known_parameters=PLANT, cache=False)


def test_partly_known_schedule_is_rejected():
    closed, gs, known = problem_kwargs(SMALL_TIMES, phase_from_strikes(SMALL_TIMES, SMALL_STRIKES))
    values = gs.parameter_values(*schedule_values(seed=1))
    first_point = {p: values[p] for p in gs.schedule.points[0]}
    with pytest.raises(ProblemDefinitionError, match=r"every point.*found 10 of 50"):
        Problem(
            closed,
            SMALL_TIMES,
            known_trajectories=known,
            known_parameters={**PLANT, **first_point},
            cache=False,
        )


def test_missing_phase_trajectory_is_named():
    closed, gs, known = problem_kwargs(SMALL_TIMES, phase_from_strikes(SMALL_TIMES, SMALL_STRIKES))
    del known[gs.phase]
    with pytest.raises(ProblemDefinitionError, match=r"known inputs \['phi'\] have no trajectory"):
        Problem(closed, SMALL_TIMES, known_trajectories=known, known_parameters=PLANT, cache=False)


def test_replace_data_rejects_a_decreasing_phase():
    problem, gs, _, _ = small_problem(Midpoint(), known_schedule=False)
    phase = phase_from_strikes(SMALL_TIMES, SMALL_STRIKES)
    phase[6] = phase[5] - 0.01
    _, _, known = problem_kwargs(SMALL_TIMES, phase)
    with pytest.raises(ProblemDefinitionError, match=r"non-decreasing"):
        problem.replace_data(known_trajectories=known)


# ---------------------------------------------------------------------- replace_data
@pytest.mark.parametrize("scheme", [Midpoint(), HermiteSimpson()], ids=lambda s: s.name)
def test_replace_data_with_new_phase_equals_new_problem(scheme):
    swapped, gs, Tstar, K = small_problem(scheme, known_schedule=False)
    fresh, _, _, _ = small_problem(scheme, known_schedule=False, strikes=OTHER_STRIKES)
    z = random_point(swapped, gs, Tstar, K, seed=21)
    before = swapped.defects(z)
    _, _, known = problem_kwargs(SMALL_TIMES, phase_from_strikes(SMALL_TIMES, OTHER_STRIKES))
    swapped.replace_data(known_trajectories=known)
    assert np.abs(swapped.defects(z) - before).max() > 1e-3  # the phase mattered
    lam = np.random.default_rng(22).normal(size=fresh.nlp.m)
    np.testing.assert_allclose(swapped.defects(z), fresh.defects(z), rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(swapped.nlp.gradient(z), fresh.nlp.gradient(z), atol=1e-14)
    np.testing.assert_allclose(
        dense_jacobian(swapped.nlp, z), dense_jacobian(fresh.nlp, z), rtol=1e-14, atol=1e-14
    )
    np.testing.assert_allclose(
        dense_hessian(swapped.nlp, z, lam, 1.0),
        dense_hessian(fresh.nlp, z, lam, 1.0),
        rtol=1e-13,
        atol=1e-13,
    )


# ---------------------------------------------------------------------- identification
ID_STRIKES = np.cumsum(np.r_[-0.4, np.random.default_rng(2).uniform(0.8, 1.25, 10)])
ID_DURATION = 8.0
ID_NODES = 801


def true_schedule(structure):
    rng = np.random.default_rng(3)
    Tstar = rng.normal(0.0, 1.0, (P, 2))
    K = np.zeros((P, 2, 4))
    K[:, 0, 0], K[:, 1, 1] = 4 + rng.uniform(-1, 1, P), 3 + rng.uniform(-1, 1, P)
    K[:, 0, 2], K[:, 1, 3] = 1 + rng.uniform(-0.3, 0.3, P), 0.8 + rng.uniform(-0.3, 0.3, P)
    if structure == "full":
        K[:, 0, [1, 3]] = rng.normal(0.0, 0.5, (P, 2))
        K[:, 1, [0, 2]] = rng.normal(0.0, 0.5, (P, 2))
    return Tstar, K


def excitation(tt):
    tt = np.asarray(tt, float)
    return np.stack(
        [
            1.5 * np.sin(2.3 * tt) + np.sin(5.1 * tt + 1.0),
            1.2 * np.sin(3.7 * tt + 0.5) + 0.8 * np.sin(7.3 * tt),
        ],
        axis=-1,
    )


def kink_times():
    """Where the torque is not smooth in time: strikes and crossings of schedule points."""
    cycles = phase_from_strikes(ID_DURATION, ID_STRIKES)
    crossings = np.interp(
        np.arange(int(cycles * P) + 1) / P, np.arange(ID_STRIKES.size), ID_STRIKES
    )
    inside = crossings[(crossings > 0) & (crossings < ID_DURATION)]
    return np.unique(np.r_[0.0, inside, ID_DURATION])


def identification_times():
    """A uniform grid with every kink added as a node (the torque is smooth on each interval,
    so Hermite-Simpson keeps its order); uniform nodes too close to a kink are dropped."""
    kinks = kink_times()
    uniform = np.linspace(0.0, ID_DURATION, ID_NODES)
    h = ID_DURATION / (ID_NODES - 1)
    far = np.min(np.abs(uniform[:, None] - kinks[None, :]), axis=1) > 0.25 * h
    return np.sort(np.r_[uniform[far], kinks])


def simulate(Tstar, K, times):
    """solve_ivp over each smooth piece between kinks, tight tolerances."""
    p = PLANT

    def rhs(tt, x):
        T = reference_torque(np.atleast_1d(phase_from_strikes(tt, ID_STRIKES)), x[None], Tstar, K)[
            0
        ]
        F = excitation(tt)
        return [
            x[2],
            x[3],
            (T[0] + F[0] - p[c] * x[2] - p[k1] * np.sin(x[0]) - p[kc] * (x[0] - x[1])) / p[m1],
            (T[1] + F[1] - p[c] * x[3] - p[k2] * x[1] - p[kc] * (x[1] - x[0])) / p[m2],
        ]

    x = np.array([0.2, -0.1, 0.0, 0.3])
    pieces = []
    kinks = kink_times()
    for a, b in zip(kinks[:-1], kinks[1:], strict=True):
        sol = solve_ivp(rhs, (a, b), x, method="DOP853", rtol=1e-12, atol=1e-12, dense_output=True)
        assert sol.success
        pieces.append(sol.sol(times[(times >= a) & (times < b)]).T)
        x = sol.y[:, -1]
    return np.vstack([*pieces, x[None]])


def identification_problem(structure, scheme, bounds=None, torques=False):
    """The toy closed by a schedule of ``structure``, tracking simulated positions (and with
    ``torques`` the two controller outputs) on the kink-aligned grid, and a start from the
    simulated states; returns the problem, the schedule, the true ``T*`` and ``K``, the
    simulated states and the start."""
    closed, gs = closed_toy(structure, outputs=[q1, q2, T1, T2] if torques else None)
    Tstar, K = true_schedule(structure)
    times = identification_times()
    X = simulate(Tstar, K, times)
    F = excitation(times)
    measured = {q1: X[:, 0], q2: X[:, 1]}
    if torques:
        phase = phase_from_strikes(times, ID_STRIKES)
        tau = reference_torque(phase, X, Tstar, K)
        measured.update({T1: tau[:, 0], T2: tau[:, 1]})
    problem = Problem(
        closed,
        times,
        scheme=scheme,
        known_trajectories={
            gs.phase: phase_from_strikes(times, ID_STRIKES),
            F1: F[:, 0],
            F2: F[:, 1],
        },
        known_parameters=PLANT,
        objective=Tracking(measured),
        bounds=bounds,
        cache=False,
    )
    guess = problem.initial_guess(
        {q1: X[:, 0], q2: X[:, 1], u1: np.gradient(X[:, 0], times), u2: np.gradient(X[:, 1], times)}
    )
    return problem, gs, Tstar, K, X, guess


@pytest.fixture(scope="module", params=["full", "joint-isolated"])
def identification(request):
    return identification_problem(request.param, HermiteSimpson())


def test_recovers_schedule_from_noise_free_data(identification):
    problem, gs, Tstar, K, _, guess = identification
    assert len(problem.layout.parameter_names) == P * (2 + gs.mask.sum())
    solution = problem.solve(guess, print_level=0)
    assert solution.status.success
    Tstar_hat, K_hat = gs.arrays(solution.parameters)
    np.testing.assert_allclose(Tstar_hat, Tstar, atol=1e-5)
    np.testing.assert_allclose(K_hat, K, atol=1e-5)


def test_noisy_estimates_within_standard_errors(identification):
    problem, gs, Tstar, K, X, guess = identification
    rng = np.random.default_rng(4)
    noisy = X[:, :2] + rng.normal(0.0, 0.01, (X.shape[0], 2))
    problem.replace_data(objective=Tracking({q1: noisy[:, 0], q2: noisy[:, 1]}))
    solution = problem.solve(guess, print_level=0)
    assert solution.status.success
    # white noise with the right weights: the KKT form's own case
    unc = parameter_uncertainty(problem, solution, noisy.size, method="kkt")
    truth = gs.parameter_values(Tstar, K)
    z = np.array(
        [(solution.parameters[p] - truth[p]) / unc.standard_errors[p] for p in gs.parameters]
    )
    assert np.abs(z).max() < 4.0
    assert 0.5 < np.sqrt(np.mean(z**2)) < 2.0
    # the noise level is estimated: sigma^2 per unit weight
    assert unc.noise_variance == pytest.approx(0.01**2, rel=0.15)


# ---------------------------------------------------------------------- size
def test_twenty_thousand_schedule_parameters_build_and_evaluate_exactly():
    """A gait-sized schedule (P = 2000 points x 10 parameters) builds and is exact.

    Before the build was made linear in the number of parameters (set membership instead of
    tuple scans, a name -> index map in the layout) this size took minutes; now it is a
    routine case. The defects at the true schedule are checked against the dense reference.
    """
    points = 2000
    closed, gs = closed_toy(points=points)
    assert len(gs.parameters) == 20_000
    times = np.linspace(0.0, 40.0, 4001)
    phase = times / 2.0  # 20 cycles: every schedule point is bracketed by some interval
    rng = np.random.default_rng(3)
    Tstar, K = rng.normal(size=(points, 2)), rng.normal(size=(points, 2, 4))
    F = cubic_forces(times / 40.0)
    problem = Problem(
        closed,
        times,
        known_trajectories={gs.phase: phase, F1: F[:, 0], F2: F[:, 1]},
        known_parameters=PLANT,
        objective=Tracking({q1: np.sin(times)}),
        cache=False,
    )
    assert problem.layout.num_variables == 4 * times.size + 20_000
    assert "20000 (" in repr(problem)
    x = np.column_stack([np.sin(times), np.cos(times), np.cos(times), -np.sin(times)])
    values = gs.parameter_values(Tstar, K)
    z = problem.initial_guess(dict(zip(STATES, x.T, strict=True)), values)
    last = gs.parameters[-1]
    assert z[problem.layout.variable_index(str(last))] == values[last]
    # Midpoint defects against the dense NumPy residual at the interval midpoints.
    h = np.diff(times)[:, None]
    xm, xd = 0.5 * (x[1:] + x[:-1]), (x[1:] - x[:-1]) / h
    tm = 0.5 * (times[1:] + times[:-1])
    Fm = cubic_forces(tm / 40.0)  # the engine interpolates known inputs cubically
    T = reference_torque(np.interp(tm, times, phase) % 1.0, xm, Tstar, K)
    expected = reference_residual(xd, xm, T, Fm, PLANT[c])
    np.testing.assert_allclose(problem.defects(z).reshape(-1, 4), expected, rtol=1e-9, atol=1e-9)
