"""The gait smoother against the truth of a noise-free fixture trial.

References: the fixture's own recorded states and torques (a CVODES simulation of gait2d at
the model's contact, written exactly); backward differences computed here by NumPy; the
analytic gain of a Butterworth filter applied forward and backward.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from colloc.data.columns import JOINT_ANGLE_COLUMNS, TORQUE_COLUMNS, TRUNK_COLUMNS
from colloc.data.trial import read_trial
from colloc.identify.gait.smoother import GaitSmoother
from colloc.identify.gait.smoother_results import SmootherError, SmootherStage
from colloc.identify.gait.smoother_settings import SmootherSettings
from colloc.identify.gait.smoother_start import lowpass

FIXTURE = Path(__file__).parent / "data" / "gait_trial_p20"
POSITIONS = list(TRUNK_COLUMNS + JOINT_ANGLE_COLUMNS)
ANGLE_STD = np.radians(0.25)
STD = np.array([0.001, 0.001, ANGLE_STD] + [ANGLE_STD] * 6)


@pytest.fixture(scope="module")
def window():
    """2 s of the noise-free fixture (t = 2..4 s) with its truth."""
    trial = read_trial(FIXTURE)
    rows = np.flatnonzero((trial.time >= 2.0 - 1e-9) & (trial.time <= 4.0 + 1e-9))
    signals = trial.signals.iloc[rows].reset_index(drop=True)
    return (
        trial.time[rows],
        signals[POSITIONS].to_numpy(dtype=float),
        signals["belt_speed"].to_numpy(dtype=float),
        signals[list(TORQUE_COLUMNS)].to_numpy(dtype=float),
    )


@pytest.fixture(scope="module")
def dynamics():
    from colloc.gait.orbit import GaitDynamics

    return GaitDynamics.build()


def noisy(window, seed: int):
    t, q, v, T = window
    rng = np.random.default_rng(seed)
    return q + rng.standard_normal(q.shape) * STD, T + rng.standard_normal(T.shape)


def test_the_start_has_zero_defects_and_the_schemes_differences_as_rates(window, dynamics):
    from colloc.transcription import BackwardEuler

    t, _, v, _ = window
    q, T = noisy(window, 1)
    smoother = GaitSmoother(dynamics, t, q, v, STD, T)
    problem = smoother.problem(BackwardEuler(), 0.1)
    z = smoother.start(problem)
    assert np.max(np.abs(problem.defects(z))) < 1e-8
    X = problem.layout.node_matrix(z)
    filtered = lowpass(t, q, 6.0)
    np.testing.assert_allclose(X[:, :9], filtered, atol=1e-12)  # positions untouched
    # backward Euler's kinematic rows: u_{k+1} = (q_{k+1} - q_k) / h
    np.testing.assert_allclose(X[1:, 9:18], np.diff(filtered, axis=0) / np.diff(t)[:, None])


@pytest.fixture(scope="module")
def smoothed(window, dynamics):
    t, _, v, _ = window
    q, T = noisy(window, 2)
    reports: list[tuple[str, str]] = []
    result = GaitSmoother(dynamics, t, q, v, STD, T).run(lambda s, d: reports.append((s, d)))
    return result, q, T, reports


def test_every_stage_converges_and_the_contact_ends_at_the_models_own(smoothed, dynamics):
    result, _, _, reports = smoothed
    names = [s.name for s in result.stages]
    assert names[:3] == ["start", "backward-euler", "midpoint"]
    assert set(names[3:]) == {"continuation"}
    assert all(s.success for s in result.stages)
    friction = dynamics.gait.contact_symbols.friction_velocity
    assert result.stages[-1].friction_velocity == dynamics.constants[friction] == 0.01
    assert [s.friction_velocity for s in result.stages[3:]] == [0.05, 0.03, 0.02, 0.015, 0.01]
    assert result.problem.known_parameters[friction] == 0.01
    assert max(s.max_defect for s in result.stages) < 1e-6
    # each stage is announced and then described
    assert [s for s, _ in reports].count("continuation") == 10
    assert any("Solve_Succeeded" in d for s, d in reports if s == "midpoint")


def test_the_smoothed_motion_is_closer_to_the_truth_than_the_measurements(window, smoothed):
    _, q_true, _, T_true = window
    result, q, T, _ = smoothed
    angles = slice(2, 9)
    rms = lambda a, b: np.sqrt(np.mean((a - b) ** 2, axis=0))  # noqa: E731
    measured = rms(q[:, angles], q_true[:, angles])
    fitted = rms(result.states[:, angles], q_true[:, angles])
    assert np.all(fitted < 0.7 * measured), (np.degrees(fitted), np.degrees(measured))
    # torques: within the measurement noise (1 N m) of the truth, not the inverse dynamics
    # of filtered kinematics through the contact (hundreds of N m)
    assert np.all(rms(result.torques, T_true) < 1.3)
    assert np.all(np.sqrt(np.mean(result.residuals**2, axis=0)) < 10.0)
    mid_t, mid_x, mid_T = result.at_intervals()
    for a, b in zip(result.at_dynamics(), (mid_t, mid_x, mid_T), strict=True):
        np.testing.assert_array_equal(a, b)  # the midpoint rule holds them at the midpoints
    np.testing.assert_allclose(mid_t, 0.5 * (result.times[1:] + result.times[:-1]))
    np.testing.assert_allclose(mid_x[3], 0.5 * (result.states[3] + result.states[4]))
    assert mid_T.shape == (result.times.size - 1, 6)
    # the instruments' states: positions at the nodes, speeds the mean over the interval
    # ending at the node, which the midpoint rule's kinematic rows tie to the positions
    lagged = result.instrument_states()
    np.testing.assert_array_equal(lagged[:, :9], result.states[:, :9])
    h = np.diff(result.times)[:, None]
    np.testing.assert_allclose(lagged[1:, 9:], np.diff(result.states[:, :9], axis=0) / h, atol=1e-5)
    np.testing.assert_array_equal(lagged[0], result.states[0])


def test_radau_iia_converges_from_its_own_start_and_holds_the_dynamics_at_the_nodes(
    window, dynamics, smoothed
):
    """``backward_euler_first=False`` with the stiffly accurate Radau IIA: its zero-defect
    start fills the stage values too, one stage at the smoothed contact converges, and the
    result is as close to the truth as the midpoint rule's after backward Euler."""
    from colloc.transcription import RadauIIA

    t, q_true, v, T_true = window
    q, T = noisy(window, 2)  # the midpoint fixture's draw
    settings = SmootherSettings(scheme=RadauIIA(), backward_euler_first=False)
    smoother = GaitSmoother(dynamics, t, q, v, STD, T, settings=settings)
    problem = smoother.problem(RadauIIA(), 0.1)
    assert np.max(np.abs(problem.defects(smoother.start(problem)))) < 1e-8
    result = smoother.run()
    names = [s.name for s in result.stages]
    assert names[:2] == ["start", "radau-iia"] and set(names[2:]) == {"continuation"}
    assert all(s.success for s in result.stages) and result.stages[-1].friction_velocity == 0.01
    at_t, at_x, at_T = result.at_dynamics()
    np.testing.assert_array_equal(at_t, result.times)  # stiffly accurate: the nodes
    np.testing.assert_array_equal(result.instrument_states(), result.states)
    rms = lambda a, b: np.sqrt(np.mean((a - b) ** 2, axis=0))  # noqa: E731
    angles = slice(2, 9)
    assert np.all(
        rms(at_x[:, angles], q_true[:, angles]) < 0.7 * rms(q[:, angles], q_true[:, angles])
    )
    midpoint = smoothed[0]
    radau_error, midpoint_error = rms(at_T, T_true), rms(midpoint.torques, T_true)
    assert np.all(radau_error < 1.3) and np.all(radau_error < 1.2 * midpoint_error)


class _Scripted(GaitSmoother):
    """A smoother whose solves fail as scripted, to test the schedule alone: ``failures``
    maps a slip scale to how many times its solve fails (``inf``: always)."""

    failures: dict[float, float]
    visited: list[float]

    def problem(self, scheme, friction_velocity):
        class Stub:
            known_parameters = {self._friction: friction_velocity}

            def replace_data(inner, known_parameters=None, objective=None):
                if known_parameters is not None:
                    inner.known_parameters = dict(known_parameters)
                if objective is not None:
                    inner.objective = objective

            def initial_guess(inner, nodes):
                return nodes

        return Stub()

    def _backward_euler(self, say, stages):
        self.visited = []
        return np.zeros((self.times.size, 27))

    def _attempt(self, problem, z, name, v_s, max_iter=None, ceiling_factor=None):
        v = round(v_s, 6)
        self.visited.append(v)
        self.limits.append((name, max_iter))
        ok = self.failures.get(v, 0) <= 0
        self.failures[v] = self.failures.get(v, 0) - 1
        status = "Solve_Succeeded" if ok else "Maximum_Iterations_Exceeded"
        return SmootherStage(name, "Midpoint", v_s, status, ok, 1, 0.0, 0.0, 0.0), z

    def _result(self, problem, z, stages, started):
        return stages


class _LastStageFails(_Scripted):
    """Every stage converges but the last, at the tracked signals' full weights."""

    def _attempt(self, problem, z, name, v_s, max_iter=None, ceiling_factor=None):
        stage, z = super()._attempt(problem, z, name, v_s, max_iter, ceiling_factor)
        self.weights_seen.append(dict(problem.objective.weights))
        if name == "full weights":
            stage = SmootherStage(name, "Midpoint", v_s, "Maximum_Iterations_Exceeded", False,
                                  300, 0.0, 0.0, 0.0)  # fmt: skip
            return stage, z + 1.0  # not kept
        return stage, z

    def _result(self, problem, z, stages, started):
        class Result:
            notes: list[str] = []

        out = Result()
        out.stages, out.z, out.notes = stages, z, []
        return out


def test_a_last_stage_at_full_weights_that_fails_keeps_the_stage_before_with_a_note(
    window, dynamics
):
    from sympy.physics.mechanics import dynamicsymbols

    t, q, v, T = window
    y = dynamicsymbols("plate_right_force_y")
    force = dynamics.gait.contact_forces["right_heel"][1]
    smoother = _LastStageFails(
        dynamics, t, q, v, STD, T, tracked={y: (force, np.zeros(t.size), 2.0)},
        early_weights={y: 0.01},
    )  # fmt: skip
    smoother.failures, smoother.visited, smoother.limits = {}, [], []
    smoother.weights_seen = []
    out = smoother.problem(None, 0.1)
    out.objective = smoother._tracking(final=False)
    smoother.problem = lambda scheme, v_s: out  # one stub whose objective the run swaps
    result = smoother.run()
    assert [s.name for s in result.stages][-2:] == ["continuation", "full weights"]
    assert not result.stages[-1].success
    np.testing.assert_array_equal(result.z, np.zeros((t.size, 27)))  # the stage before's
    assert (
        "did not converge" in result.notes[0] and "plate_right_force_y at 0.01" in result.notes[0]
    )
    # the early stages saw the plate at a hundredth of its weight, the last at its whole
    assert smoother.weights_seen[0][y] == pytest.approx(0.01 / 4.0)
    assert smoother.weights_seen[-1][y] == pytest.approx(1 / 4.0)
    # its budget is bounded (two continuation steps'), the fallback being at hand
    assert smoother.limits[-1] == ("full weights", 2 * SmootherSettings().step_max_iter)


def _scripted(window, dynamics, failures, **settings):
    t, q, v, T = window
    smoother = _Scripted(dynamics, t, q, v, STD, T, settings=SmootherSettings(**settings))
    smoother.failures = dict(failures)
    smoother.visited, smoother.limits = [], []
    return smoother


def test_a_failed_continuation_step_is_halved_and_then_reaches_its_goal(window, dynamics):
    smoother = _scripted(window, dynamics, {0.01: 1}, continuation=(0.05,))
    stages = smoother.run()
    # midpoint at 0.1, 0.05, the first try at 0.01 fails, halfway (0.03), then 0.01
    assert smoother.visited == [0.1, 0.05, 0.01, 0.03, 0.01]
    assert stages[-1].success and stages[-1].friction_velocity == 0.01
    # a continuation step is given its own, smaller iteration budget; the stages before, all
    limits = dict.fromkeys(name for name, _ in smoother.limits)
    assert {name: {m for n, m in smoother.limits if n == name} for name in limits} == {
        "midpoint": {None},
        "continuation": {SmootherSettings().step_max_iter},
    }


def test_a_goal_that_keeps_failing_stops_after_the_halvings_naming_the_stages(window, dynamics):
    smoother = _scripted(window, dynamics, {0.03: np.inf}, continuation=(0.05, 0.03))
    with pytest.raises(
        SmootherError,
        match=r"stage continuation \(Midpoint, v_s = 0.03 m/s\): Maximum_Iterations_Exceeded",
    ) as info:
        smoother.run()
    assert "did not converge (after midpoint (Midpoint, v_s = 0.1 m/s)" in str(info.value)
    # three halvings (the default) move closer each time, then the fourth failure ends it
    assert smoother.visited == [0.1, 0.05, 0.03, 0.04, 0.03, 0.035, 0.03, 0.0325, 0.03]
    assert len(info.value.stages) == len(smoother.visited)


def test_a_diverging_solve_is_stopped_at_its_objective_ceiling(window, dynamics, monkeypatch):
    """A stage whose objective climbs past DIVERGED_OBJECTIVE_FACTOR times its start's is
    stopped at that iteration (not left to its iteration budget): with the factor at 1e-12
    every stage is, so the first backward-Euler solve ends at once, by the user's stop."""
    import colloc.identify.gait.smoother_solve as module

    t, q, v, T = window
    monkeypatch.setattr(module, "DIVERGED_OBJECTIVE_FACTOR", 1e-12)
    smoother = GaitSmoother(dynamics, t[:201], q[:201], v[:201], STD, T[:201])
    with pytest.raises(SmootherError, match="backward-euler .*User_Requested_Stop") as info:
        smoother.run()
    assert info.value.stages[-1].iterations <= 1


def test_settings_and_arrays_are_checked_with_every_problem_named(window, dynamics):
    bad = SmootherSettings(
        cutoff_hz=-1.0, continuation=(0.02, 0.05), max_iter=0, overlap_seconds=6.0,
        backward_euler_first="yes",
    )  # fmt: skip
    problems = bad.problems()
    assert "backward_euler_first: expected True or False, found 'yes'" in problems
    assert any(p.startswith("cutoff_hz: expected a positive number") for p in problems)
    assert any("continuation: expected decreasing" in p for p in problems)
    assert any(p.startswith("max_iter: expected an integer >= 1") for p in problems)
    assert any(p.startswith("overlap_seconds: expected less than half") for p in problems)
    t, q, v, T = window
    with pytest.raises(ValueError, match=r"positions: expected shape \(201, 9\), found \(201, 8\)"):
        GaitSmoother(dynamics, t, q[:, :8], v, STD, T)
    with pytest.raises(ValueError, match="cutoff_hz: expected a positive number"):
        GaitSmoother(dynamics, t, q, v, STD, T, settings=bad)


def test_windows_overlap_and_their_kept_parts_tile_the_record(dynamics):
    t = np.arange(0.0, 25.0 + 1e-9, 0.01)
    N = t.size
    smoother = GaitSmoother(
        dynamics, t, np.zeros((N, 9)), np.ones(N), STD, settings=SmootherSettings()
    )
    windows = smoother.windows()
    assert len(windows) == 3
    kept = np.concatenate([np.arange(a, b) for _, _, a, b in windows])
    np.testing.assert_array_equal(kept, np.arange(N))  # every node once, in order
    for first, stop, keep, keep_stop in windows:
        assert stop - first == 1001 and first <= keep < keep_stop <= stop
    for (_, stop, _, cut), (first, _, cut2, _) in zip(windows, windows[1:], strict=False):
        assert stop - first >= 100 and cut == cut2 and first < cut < stop


def test_lowpass_is_zero_lag_with_the_butterworth_gain_squared():
    t = np.arange(0.0, 20.0, 0.01)
    slow, fast = np.sin(2 * np.pi * 1.0 * t), np.sin(2 * np.pi * 15.0 * t)
    out = lowpass(t, np.column_stack([slow, fast]), 6.0)
    middle = slice(500, 1500)
    # |H(f)|^2 of a 2nd-order Butterworth is 1 / (1 + (f / fc)^4) in analog form; the
    # bilinear transform warps it slightly, so compare with its digital response
    from scipy.signal import butter, freqz

    b, a = butter(2, 6.0 / 50.0)
    gain = np.abs(freqz(b, a, worN=[1.0, 15.0], fs=100.0)[1]) ** 2
    np.testing.assert_allclose(out[middle, 0], gain[0] * slow[middle], atol=1e-6)
    np.testing.assert_allclose(out[middle, 1], gain[1] * fast[middle], atol=1e-6)
    with pytest.raises(
        ValueError, match="cutoff_hz: expected a positive frequency below the Nyquist"
    ):
        lowpass(t, slow, 60.0)


# two smoothers of 2 s (31 s): run by benchmarks/slow_tests.py; in CI the plates are tracked
# through the contact model by the marker smoother's tests (tests/lab/test_marker_smoother.py)
@pytest.mark.slow
def test_ground_reactions_are_tracked_through_the_contact_model(window, dynamics):
    """Each foot's measured force (heel plus toe of the contact model, computed here from the
    fixture's exact states, plus 5 N of noise) is an output of the smoother's model; with the
    trapezoidal rule (dynamics at the nodes, where the forces are tracked) the smoothed
    motion's vertical forces come out within that noise of the truth, and the horizontal
    ones (a friction law that turns a millimetre per second of slip into tens of newtons)
    less than half as far from it as without them."""
    from colloc.transcription import Trapezoidal

    t, q_true, v, T_true = window
    states_true = read_trial(FIXTURE).signals
    rows = np.flatnonzero(
        (read_trial(FIXTURE).time >= 2.0 - 1e-9) & (read_trial(FIXTURE).time <= 4.0 + 1e-9)
    )
    from colloc.gait.metadata import STATE_SIGNAL_NAMES

    X = states_true.iloc[rows][list(STATE_SIGNAL_NAMES)].to_numpy(dtype=float)

    def feet(states):
        f = np.asarray(dynamics.contact_forces.map(len(t))(states.T, v)).T
        return np.column_stack(
            [f[:, 0] + f[:, 2], f[:, 1] + f[:, 3], f[:, 4] + f[:, 6], f[:, 5] + f[:, 7]]
        )

    truth = feet(X)
    rng = np.random.default_rng(4)
    q, T = noisy(window, 4)
    measured = truth + 5.0 * rng.standard_normal(truth.shape)
    settings = SmootherSettings(scheme=Trapezoidal())
    smoother = GaitSmoother(dynamics, t, q, v, STD, T, settings=settings, ground_reactions=measured)
    assert {"right_grf_x", "right_grf_y", "left_grf_x", "left_grf_y"} <= {
        str(y.func) for y in smoother.model.outputs
    }
    result = smoother.run()
    assert [s.name for s in result.stages][:3] == ["start", "backward-euler", "trapezoidal"]
    np.testing.assert_array_equal(result.at_dynamics()[1], result.states)  # at the nodes
    without = GaitSmoother(dynamics, t, q, v, STD, T, settings=settings).run()

    def rms(states):
        return np.sqrt(np.mean((feet(states) - truth) ** 2, axis=0))

    tracked, untracked = rms(result.states), rms(without.states)
    assert np.all(tracked[[1, 3]] < 5.0), tracked  # vertical: within the plates' noise
    assert np.all(tracked[[0, 2]] < 0.5 * untracked[[0, 2]]), (tracked, untracked)


def test_measured_rates_are_tracked_with_their_own_noise_levels(window, dynamics):
    t, q, v, T = window
    rates = np.zeros((t.size, 9))
    std = np.full(9, 0.2)
    smoother = GaitSmoother(dynamics, t, q, v, STD, T, rates=rates, rate_std=std)
    speeds = dynamics.model.states[9:]
    assert set(speeds) <= set(smoother.model.outputs)
    assert all(smoother._weights[u] == pytest.approx(25.0) for u in speeds)
    with pytest.raises(ValueError, match=r"rate_std: expected shape \(9,\), found \(\)"):
        GaitSmoother(dynamics, t, q, v, STD, T, rates=rates)
    with pytest.raises(ValueError, match="rate_std: expected positive standard deviations"):
        GaitSmoother(dynamics, t, q, v, STD, T, rates=rates, rate_std=np.zeros(9))


def test_node_means_remove_the_odd_even_mode_and_keep_a_line():
    from colloc.identify.gait.smoother_results import node_means

    k = np.arange(11.0)
    line = np.column_stack([2.0 + 0.5 * k, -k])
    alternating = line + np.column_stack([3.0 * (-1.0) ** k, np.zeros(11)])
    np.testing.assert_allclose(node_means(alternating)[1:-1], line[1:-1], atol=1e-12)
    # at the ends, the one interval's mean
    np.testing.assert_allclose(node_means(line)[[0, -1]], 0.5 * (line[[0, -2]] + line[[1, -1]]))
    # a sampled sine keeps cos(pi f h)^2 of its amplitude (inside)
    h, f = 0.01, 10.0
    t = np.arange(200) * h
    wave = np.sin(2 * np.pi * f * t)[:, None]
    np.testing.assert_allclose(
        node_means(wave)[1:-1, 0], np.cos(np.pi * f * h) ** 2 * wave[1:-1, 0], atol=1e-12
    )
    with pytest.raises(ValueError, match=r"shape \(N, k\) with N >= 2"):
        node_means(np.zeros(5))
