"""The seed's study end to end: ``run_pendulum`` on the 1-link pendulum on a cart.

References: the seed's LQR gains, the truth used to simulate, the standard errors, the
noise level that was asked for, and the orders of the schemes (backward Euler's bias halves
with the step, midpoint's quarters).
"""

from __future__ import annotations

import numpy as np
import pytest

from colloc.identify import PendulumSettings, run_pendulum
from colloc.identify.pendulum.outputs import pendulum_run_id

#: The gains printed by the seed's 1-link study (LQR with Q = I, R = I).
SEED_GAINS = np.array([-4.71764346, 19.67083668, -3.69402157, 5.57114809])

NOISY = {"num_links": 1, "duration": 20.0, "sample_rate": 50.0, "sensor_noise": True}


@pytest.fixture(scope="module")
def runs():
    """One noisy run per initial guess (built without the on-disk cache)."""
    return {
        guess: run_pendulum(
            PendulumSettings(**NOISY, initial_guess=guess, check_true_gains=guess == "close"),
            cache=False,
        )
        for guess in ("close", "direct")
    }


def test_known_gains_are_the_seeds(runs):
    np.testing.assert_allclose(runs["close"].known_gains, SEED_GAINS, rtol=1e-6)
    assert runs["close"].gain_names == ["k_0_0", "k_0_1", "k_0_2", "k_0_3"]


@pytest.mark.parametrize("guess", ["close", "direct"])
def test_noisy_identification_recovers_the_gains(runs, guess):
    run = runs[guess]
    assert run.solution.success, run.solution.stats["message"]
    assert run.notes == []
    assert run.max_rel_gain_error < 0.01
    assert np.all(np.isfinite(run.standard_errors)) and np.all(run.standard_errors > 0)
    assert np.all(np.abs(run.identified_gains - SEED_GAINS) < 4 * run.standard_errors)
    # The identified motion is feasible: the defects vanish at the solution.
    assert np.max(np.abs(run.defects)) < 1e-6
    # The fit tracks the measurements to within the noise level.
    residual = run.identified_states[:, :2] - run.measurements
    np.testing.assert_allclose(np.std(residual, axis=0), np.deg2rad(0.25), rtol=0.15)


def test_both_guesses_reach_the_same_optimum(runs):
    np.testing.assert_allclose(
        runs["close"].identified_gains, runs["direct"].identified_gains, rtol=1e-6
    )


def test_initial_guesses_follow_their_definitions(runs):
    known = runs["close"].known_gains
    # close = K + 0.5 |K| N(0, 1): |N(0, 1)| = rel / 0.5 is a few per cent to a few units.
    normal = np.abs(runs["close"].initial_gains - known) / (0.5 * np.abs(known))
    assert np.max(normal) > 0.1 and np.all(normal < 4.0)
    # direct = least squares on smoothed data: within the smoother's few-per-cent bias.
    rel = np.abs(runs["direct"].initial_gains - known) / np.abs(known)
    assert np.max(rel) < 0.06


def test_sensor_noise_has_the_requested_spread(runs):
    run = runs["close"]
    noise = run.measurements - run.true_states[:, :2]
    expected = [run.settings.cart_noise_std, np.deg2rad(run.settings.noise_std_deg)]
    np.testing.assert_allclose(np.std(noise, axis=0), expected, rtol=0.1)
    assert np.abs(np.mean(noise, axis=0)).max() < 4 * max(expected) / np.sqrt(len(noise))


def test_true_gains_give_a_higher_objective_than_the_optimum(runs):
    run = runs["close"]
    assert run.objective_at_true_gains is not None
    assert run.objective_at_true_gains >= run.solution.stats["objective"]
    # ... but only by about what 4 extra fitted parameters buy: chi^2 with 4 dof.
    sigma2 = run.uncertainty.noise_variance
    assert run.objective_at_true_gains - run.solution.stats["objective"] < 20 * sigma2


def test_same_seed_gives_same_run_and_id(runs):
    first = runs["close"]
    again = run_pendulum(first.settings, cache=False)
    assert pendulum_run_id(again) == pendulum_run_id(first)
    np.testing.assert_array_equal(again.measurements, first.measurements)
    np.testing.assert_array_equal(again.identified_gains, first.identified_gains)
    other = run_pendulum(PendulumSettings(**NOISY, initial_guess="close", seed=1), cache=False)
    assert pendulum_run_id(other) != pendulum_run_id(first)
    assert not np.array_equal(other.measurements, first.measurements)


def test_backward_euler_is_biased_where_midpoint_is_not():
    # Same settings and seed, so the same data; only the scheme differs.
    def run(scheme: str):
        settings = PendulumSettings(**NOISY, initial_guess="known", scheme=scheme)
        return run_pendulum(settings, cache=False)

    midpoint, euler = run("midpoint"), run("backward-euler")
    # the same data up to the integrator's round-off (which can differ in the last bits
    # with the state of the BLAS threads between two runs in one process)
    np.testing.assert_allclose(midpoint.measurements, euler.measurements, rtol=0, atol=1e-8)
    assert euler.max_rel_gain_error > 10 * midpoint.max_rel_gain_error
    assert euler.max_rel_gain_error > 0.02  # biased by several per cent (the seed's point)
    assert euler.max_gain_error_in_se > 4  # ... which the standard errors do not explain


def test_discretisation_bias_follows_the_order_of_each_scheme():
    # Noise-free data, so the only error left is the scheme's: halving h halves backward
    # Euler's (first order) and quarters midpoint's (second order).
    def error(scheme: str, rate: float) -> float:
        settings = PendulumSettings(
            duration=10.0, sample_rate=rate, initial_guess="known", scheme=scheme
        )
        return run_pendulum(settings, cache=False).max_rel_gain_error

    euler = error("backward-euler", 50.0) / error("backward-euler", 100.0)
    midpoint = error("midpoint", 50.0) / error("midpoint", 100.0)
    assert 1.6 < euler < 2.6
    assert 3.0 < midpoint < 6.0


@pytest.mark.parametrize("scheme", ["midpoint", "trapezoidal", "hermite-simpson"])
def test_every_second_order_scheme_recovers_the_gains(scheme):
    run = run_pendulum(PendulumSettings(**NOISY, scheme=scheme), cache=False)
    assert run.solution.success
    assert run.max_rel_gain_error < 0.01
    assert np.all(np.abs(run.identified_gains - SEED_GAINS) < 4 * run.standard_errors)


def test_limited_memory_hessian_reaches_the_exact_hessians_optimum(runs):
    # A second optimiser path (L-BFGS) to the same minimiser of the same NLP.
    settings = PendulumSettings(**NOISY, hessian="limited-memory")
    run = run_pendulum(settings, cache=False)
    assert run.solution.success
    exact = runs["close"]
    np.testing.assert_allclose(run.identified_gains, exact.identified_gains, rtol=1e-6)
    assert run.solution.stats["iterations"] > exact.solution.stats["iterations"]


# ----------------------------------------------------------------------------- settings


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"num_links": 0}, r"num_links \(-n\): expected an integer >= 1, found 0"),
        ({"num_links": 1.5}, r"num_links \(-n\): expected an integer >= 1, found 1.5"),
        ({"duration": -1.0}, r"duration \(-d\): expected a positive number .*found -1.0"),
        ({"sample_rate": 0.0}, r"sample_rate \(-s\): expected a positive rate .*found 0.0"),
        (
            {"duration": 1.0, "sample_rate": 0.01},
            r"gives 1 node\(s\); expected at least 3",
        ),
        ({"initial_guess": "bogus"}, r"initial_guess \(-i\): expected one of .*'bogus'"),
        ({"scheme": "bogus"}, r"scheme: expected one of .*'midpoint'.*found 'bogus'"),
        ({"hessian": "bogus"}, r"hessian: expected 'exact' or 'limited-memory'"),
        ({"noise_std_deg": -0.1}, r"noise_std_deg: expected a finite number >= 0"),
        # Infinite duration or rate: a settings error, not an OverflowError from num_nodes.
        ({"duration": float("inf")}, r"duration \(-d\): expected a positive"),
        ({"sample_rate": float("inf")}, r"sample_rate \(-s\): expected a positive"),
        ({"duration": float("nan")}, r"duration \(-d\): expected a positive"),
        # A negative seed must be named as the culprit (numpy's own message does not).
        ({"seed": -1}, r"seed: expected an integer >= 0, found -1"),
        ({"process_noise": -1.0}, r"process_noise: expected a finite number >= 0, found -1.0"),
        ({"input_noise": float("nan")}, r"input_noise: expected a finite number >= 0, found nan"),
        (
            {"uncertainty": "bootstrap"},
            r"uncertainty: expected one of \['sandwich', 'autoregressive', 'kkt'\]",
        ),
        ({"noise_model": "yes"}, r"noise_model: expected True or False, found 'yes'"),
    ],
)
def test_bad_settings_are_rejected_before_any_work(changes, message):
    settings = PendulumSettings(**changes)
    with pytest.raises(ValueError, match=message):
        run_pendulum(settings, progress=_fail_if_called)


def test_every_bad_setting_is_reported_at_once():
    settings = PendulumSettings(num_links=0, duration=-1.0, initial_guess="x", scheme="y")
    problems = settings.problems()
    assert len(problems) == 4
    with pytest.raises(ValueError, match="invalid pendulum settings") as info:
        settings.validate()
    for name in ("num_links", "duration", "initial_guess", "scheme"):
        assert name in str(info.value)


def test_node_count_follows_duration_and_rate():
    assert PendulumSettings(duration=20.0, sample_rate=50.0).num_nodes == 1001
    assert PendulumSettings(duration=0.1, sample_rate=30.0).num_nodes == 4
    assert PendulumSettings(duration=0.05, sample_rate=30.0).problems() != []


def _fail_if_called(step: str, detail: str) -> None:
    raise AssertionError(f"work started ({step}: {detail}) before the settings were checked")


# ----------------------------------------------------------------------------- noise model

NOISE = {**NOISY, "initial_guess": "direct", "process_noise": 1.0, "input_noise": 2.5}


@pytest.fixture(scope="module")
def noisy_runs():
    """Motor noise and a noisy force: identified with and without the noise model."""
    return {
        modelled: run_pendulum(
            PendulumSettings(
                **NOISE, noise_model=modelled, uncertainty="sandwich" if modelled else "kkt"
            ),
            cache=False,
        )
        for modelled in (True, False)
    }


def test_motor_and_force_noise_are_simulated_as_asked(noisy_runs, runs):
    run = noisy_runs[True]
    # the same seed without the noise options: same force, different motion
    clean = runs["direct"]
    np.testing.assert_array_equal(run.force, clean.force)
    assert np.abs(run.true_states - clean.true_states).max() > 1e-3
    spread = np.std(run.force_measured - run.force)
    assert spread == pytest.approx(2.5, rel=0.1)
    # both fits saw the same data
    np.testing.assert_array_equal(run.measurements, noisy_runs[False].measurements)


def test_noise_model_gives_estimates_within_their_error_bars(noisy_runs):
    modelled, today = noisy_runs[True], noisy_runs[False]
    assert modelled.uncertainty.method == "sandwich" and today.uncertainty.method == "kkt"
    assert modelled.solution.success
    assert modelled.max_gain_error_in_se < 3.5
    # exact dynamics with KKT errors: overconfident, and its residuals say so
    assert today.max_gain_error_in_se > 2 * modelled.max_gain_error_in_se
    assert any("not white" in note for note in today.notes)
    assert not any("not white" in note for note in modelled.notes)
    # the estimated cart force and the disturbance torque are trajectories of the solution
    names = set(modelled.solution.trajectories)
    assert {"F", "w1"} <= {str(getattr(k, "func", k)) for k in names}
    # the modelled fit reports the marginal likelihood's gains, the joint ones kept in the
    # solution; the exact-dynamics fit has nothing to integrate out
    marginal = modelled.marginal
    assert marginal is not None and today.marginal is None
    corrected = [marginal.parameters[k] for k in modelled.gain_symbols]
    joint = [modelled.solution.parameters[k] for k in modelled.gain_symbols]
    np.testing.assert_array_equal(modelled.identified_gains, corrected)
    np.testing.assert_allclose(
        np.subtract(corrected, joint), [marginal.shift[k] for k in modelled.gain_symbols]
    )
    assert any("marginal likelihood's (Laplace) correction" in note for note in modelled.notes)


def test_a_run_is_sized_before_any_work():
    """The estimate grows with nodes and links as the KKT factor does, and refuses what
    cannot fit; the measured 1-link, 60 s run is the one-second reference."""
    base = PendulumSettings(num_links=1, duration=60.0).estimated_needs()
    assert base["nodes"] == 6001 and base["variables"] == 6001 * 4 + 4
    assert base["seconds"] == pytest.approx(1.0, rel=0.02)
    longer = PendulumSettings(num_links=1, duration=120.0).estimated_needs()
    assert longer["memory_bytes"] == pytest.approx(2 * base["memory_bytes"], rel=1e-3)
    # 4 links: 10 states and 40 gains per node block instead of 4 and 4
    four = PendulumSettings(num_links=4, duration=60.0).estimated_needs()
    assert four["memory_bytes"] / base["memory_bytes"] == pytest.approx(10 * 60 / (4 * 12))
    assert PendulumSettings(num_links=4).too_big(2**30) == []  # 86 MB fits in 1 GiB
    (problem,) = PendulumSettings(num_links=4).too_big(2**20)
    assert "more than the 0.000977 GiB available" in problem
    assert PendulumSettings(num_links=0).too_big(1.0) == []  # invalid: problems() says why


def test_a_failed_solve_reports_no_standard_errors(monkeypatch):
    from colloc.nlp.problem import Problem

    solve = Problem.solve

    def one_iteration(self, *args, **kwargs):
        return solve(self, *args, **{**kwargs, "max_iter": 1})

    monkeypatch.setattr(Problem, "solve", one_iteration)
    run = run_pendulum(PendulumSettings(duration=5.0, sample_rate=20.0, sensor_noise=True))
    assert not run.solution.success
    assert np.all(np.isnan(run.standard_errors)) and run.uncertainty is None
    assert any("no standard errors: the solve did not succeed" in n for n in run.notes)
