"""The schedule's least squares with stride-sandwich errors and its bound, and the smoother
fit of ``colloc gait identify``.

References: a gain schedule drawn here and applied to random signals (exact recovery); a Monte
Carlo over noise realisations for the spread that the standard errors and the bound must
match; the noise-free fixture trial's recorded controller.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from sympy.physics.mechanics import dynamicsymbols

from colloc.cli import main
from colloc.control.gain_scheduled import GainScheduled
from colloc.data.trial import read_trial
from colloc.identify.gait.controller_fit import fit_schedule_with_errors, relative_spread

FIXTURE = Path(__file__).parent / "data" / "gait_trial_p20"


@pytest.fixture(scope="module")
def design():
    """P = 4 points, 2 torques on 2 signals, 40 'strides' of 50 samples."""
    s = dynamicsymbols("s0 s1")
    T = dynamicsymbols("T0 T1")
    gs = GainScheduled(4, s, T, structure="full")
    rng = np.random.default_rng(3)
    N = 2000
    phase = np.arange(N) / 50.0 + 0.013
    feedback = np.column_stack([np.sin(2 * np.pi * phase), np.cos(6 * phase)])
    feedback += 0.5 * rng.standard_normal((N, 2))
    Tstar = rng.normal(size=(4, 2))
    K = rng.normal(size=(4, 2, 2))
    law = gs.torque(phase, feedback, Tstar, K)
    return gs, phase, feedback, Tstar, K, law, np.floor(phase).astype(int)


def test_exact_data_give_the_schedule_back(design):
    gs, phase, feedback, Tstar, K, law, blocks = design
    est = fit_schedule_with_errors(gs, phase, feedback, law, blocks)
    np.testing.assert_allclose(est.Tstar, Tstar, atol=1e-10)
    np.testing.assert_allclose(est.K, K, atol=1e-10)
    assert est.blocks == 40 and np.all(est.residual_std < 1e-10)


def test_errors_and_bound_match_the_monte_carlo_spread(design):
    gs, phase, feedback, Tstar, K, law, blocks = design
    rng = np.random.default_rng(4)
    sigma = 0.3
    estimates, ses, bounds = [], [], []
    for _ in range(200):
        noisy = law + sigma * rng.standard_normal(law.shape)
        est = fit_schedule_with_errors(gs, phase, feedback, noisy, blocks, np.full(2, sigma))
        estimates.append(est.K.ravel())
        ses.append(est.K_se.ravel())
        bounds.append(est.K_bound.ravel())
    spread = np.std(estimates, axis=0)
    # white noise: the bound sigma^2 (D^T D)^-1 is the exact covariance; the sandwich over 40
    # blocks estimates it, a little low on average ((nb - 1) / nb and its own noise)
    np.testing.assert_allclose(np.mean(bounds, axis=0), spread, rtol=0.15)
    np.testing.assert_allclose(np.mean(ses, axis=0), spread, rtol=0.2)
    within = np.abs(np.array(estimates) - K.ravel()) <= 3 * np.array(ses)
    assert within.mean() > 0.97
    assert relative_spread(bounds[0], K) == pytest.approx(
        np.sqrt(np.sum(bounds[0] ** 2)) / np.linalg.norm(K)
    )


def test_the_sandwich_follows_residuals_correlated_within_strides(design):
    gs, phase, feedback, Tstar, K, law, blocks = design
    rng = np.random.default_rng(5)
    estimates, ses, bounds = [], [], []
    for _ in range(200):
        # half the variance an offset per stride, half white: correlated within a stride
        offsets = rng.standard_normal((blocks.max() + 1, 2))[blocks] + rng.standard_normal(
            law.shape
        )
        est = fit_schedule_with_errors(
            gs, phase, feedback, law + offsets / np.sqrt(2), blocks, np.ones(2)
        )
        estimates.append(est.Tstar.ravel())
        ses.append(est.Tstar_se.ravel())
        bounds.append(est.Tstar_bound.ravel())
    spread = np.std(estimates, axis=0)
    np.testing.assert_allclose(np.mean(ses, axis=0), spread, rtol=0.25)
    # the white-noise bound does not know the correlation: it is the smaller
    assert np.median(spread / np.mean(bounds, axis=0)) > 1.5


def _closed_loop_sample(gs, Tstar, K, rng, coupling=0.6):
    """Fed-back signals that feel each sample's torque noise within the sample, as a closed
    loop's do: ``s_k = 0.9 s_(k-1) + u_k + coupling * n_k`` with ``T_k = law(s_k) + n_k``."""
    N = 2000
    phase = np.arange(N) / 50.0 + 0.013
    noise = rng.standard_normal((N, 2))
    drive = np.column_stack([np.sin(2 * np.pi * phase), np.cos(6 * phase)])
    feedback = np.zeros((N, 2))
    for k in range(N):
        before = feedback[k - 1] if k else 0.0
        feedback[k] = 0.9 * before + 0.3 * drive[k] + 0.5 * rng.standard_normal(2)
        feedback[k] += coupling * noise[k, ::-1]  # each signal feels the other torque's noise
    torques = gs.torque(phase, feedback, Tstar, K) + noise
    return phase, feedback, torques, np.floor(phase).astype(int)


def _bias_in_monte_carlo_se(estimates: np.ndarray, truth: np.ndarray) -> float:
    """The median over entries of ``|mean - truth|`` in Monte Carlo standard errors of the
    mean (``std / sqrt(realisations)``)."""
    spread = estimates.std(axis=0) / np.sqrt(estimates.shape[0])
    return float(np.median(np.abs(estimates.mean(axis=0) - truth) / spread))


def test_instruments_remove_the_bias_of_noise_that_reaches_the_fed_back_signals(design):
    """Ordinary least squares fits the noise through the signals it reached; two-stage least
    squares on the signals one and two samples earlier does not, and its sandwich errors
    cover its scatter."""
    gs, _, _, Tstar, K, _, _ = design
    rng = np.random.default_rng(8)
    ols, iv, iv_se = [], [], []
    for _ in range(60):
        phase, feedback, torques, blocks = _closed_loop_sample(gs, Tstar, K, rng)
        ols.append(fit_schedule_with_errors(gs, phase, feedback, torques, blocks).K.ravel())
        est = fit_schedule_with_errors(gs, phase, feedback, torques, blocks, instrument_lags=(1, 2))
        iv.append(est.K.ravel())
        iv_se.append(est.K_se.ravel())
    ols, iv, iv_se = np.array(ols), np.array(iv), np.array(iv_se)
    truth = K.ravel()
    # the least squares' bias is many of its own standard errors of the mean; the IV's is not
    assert _bias_in_monte_carlo_se(ols, truth) > 10
    assert _bias_in_monte_carlo_se(iv, truth) < 3
    assert np.median(np.abs(iv.mean(axis=0) - truth)) < 0.2 * np.median(
        np.abs(ols.mean(axis=0) - truth)
    )
    np.testing.assert_allclose(np.median(iv_se, axis=0), iv.std(axis=0), rtol=0.35)
    assert (np.abs(iv - truth) <= 3 * iv_se).mean() > 0.95
    few = fit_schedule_with_errors(
        gs, phase[:60], feedback[:60], torques[:60], blocks[:60], instrument_lags=(1, 2)
    )
    assert few.method == "least squares" and "samples per parameter" in few.reason
    assert est.method == "two-stage least squares"
    with pytest.raises(ValueError, match="instrument_lags: expected whole numbers >= 1"):
        fit_schedule_with_errors(gs, phase, feedback, torques, blocks, instrument_lags=(0,))


def test_instruments_free_of_an_odd_even_error_keep_the_fit_consistent(design):
    """A regressor error that alternates in sign from sample to sample with a slowly varying
    size (the midpoint rule's mode in the smoothed node rates) is shared by the same signal one
    and two samples earlier, so those instruments leave a bias; the means over neighbouring
    samples cancel it, and the fit with them is consistent and its errors cover it."""
    gs, _, _, Tstar, K, _, _ = design
    rng = np.random.default_rng(11)
    node, paired, paired_se = [], [], []
    for _ in range(60):
        phase, feedback, torques, blocks = _closed_loop_sample(gs, Tstar, K, rng, coupling=0.0)
        drift = np.zeros_like(feedback)
        for k in range(1, feedback.shape[0]):
            drift[k] = 0.95 * drift[k - 1] + 0.31 * rng.standard_normal(2)  # sd 1
        sign = (-1.0) ** np.arange(feedback.shape[0])
        measured = feedback + sign[:, None] * drift
        means = measured.copy()
        means[1:] = 0.5 * (measured[1:] + measured[:-1])
        node.append(
            fit_schedule_with_errors(
                gs, phase, measured, torques, blocks, instrument_lags=(1, 2)
            ).K.ravel()
        )
        est = fit_schedule_with_errors(
            gs,
            phase,
            measured,
            torques,
            blocks,
            instrument_lags=(1, 2),
            instrument_feedback=means,
        )
        paired.append(est.K.ravel())
        paired_se.append(est.K_se.ravel())
    node, paired, paired_se = np.array(node), np.array(paired), np.array(paired_se)
    truth = K.ravel()
    # the node instruments' bias: many Monte Carlo standard errors and a quarter of K (the
    # error's size is the signal's); the means': none to speak of
    assert _bias_in_monte_carlo_se(node, truth) > 5
    assert np.linalg.norm(node.mean(axis=0) - truth) > 0.15 * np.linalg.norm(truth)
    assert _bias_in_monte_carlo_se(paired, truth) < 3
    assert np.linalg.norm(paired.mean(axis=0) - truth) < 0.05 * np.linalg.norm(truth)
    assert (np.abs(paired - truth) <= 3 * paired_se).mean() > 0.93
    with pytest.raises(ValueError, match=r"instrument_feedback: expected shape \(2000, 2\)"):
        fit_schedule_with_errors(
            gs, phase, measured, torques, blocks, (1, 2), instrument_feedback=means[:, :1]
        )


def test_bad_arrays_are_named(design):
    gs, phase, feedback, Tstar, K, law, blocks = design
    with pytest.raises(ValueError, match=r"feedback: expected shape \(2000, 2\)"):
        fit_schedule_with_errors(gs, phase, feedback[:, :1], law, blocks)
    with pytest.raises(ValueError, match="blocks: expected at least two blocks"):
        fit_schedule_with_errors(gs, phase, feedback, law, np.zeros(2000, dtype=int))
    with pytest.raises(ValueError, match=r"noise_std: expected shape \(2,\)"):
        fit_schedule_with_errors(gs, phase, feedback, law, blocks, np.ones(3))


def _identify_with_full_bound(trial, out):
    """``gait identify`` with the smoother on 60 % of ``trial``, the whole design's bound
    asked for; the exit code and the summary."""
    code = main(
        ["gait", "identify", str(trial), "--phase", "controller", "--fit-fraction", "0.6"]
        + ["--no-plots", "--no-store", "--no-simulate", "--json", str(out)]
        + ["--design-bound", "full"]
    )
    return code, json.loads(out.read_text())


def test_the_smoother_fit_runs_end_to_end_with_its_bounds_and_errors(tmp_path):
    """``colloc gait identify`` with its default method on the noise-free fixture. Its 7 s fit
    window (696 midpoints for 360 parameters per torque) cannot pin the 2160 parameters from
    the smoother's signals, which differ from the recorded ones by the midpoint rule's own
    error: recovery is measured on long trials by benchmarks/gait_smoother.py. Here: every
    stage converges, the fitted angles follow the record, the schedule predicts the held-out
    torques, and the bound, the errors and their notes are reported."""
    code, summary = _identify_with_full_bound(FIXTURE, tmp_path / "s.json")
    assert code == 0 and summary["settings"]["method"] == "smoother"
    # the whole design's bound needs the motor noise, which this walk had none of: said
    assert summary["K_relative_bound_full_design"] is None
    assert any("records no motor noise" in n and "design bound" in n for n in summary["notes"])
    assert summary["K_relative_bound_states_known"] == summary["K_relative_bound"]
    assert summary["status"] == "Solve_Succeeded"
    # noise-free record, weighted as if it had the lab noise (0.25 deg, 1 N m): the smoother
    # trades 0.04-0.12 deg of angle for the measured torques under the midpoint rule's error
    assert max(summary["fit_angle_rms"].values()) < 0.25
    assert summary["direct_K_relative_error"] < 1e-6  # exact rate columns: exact
    assert summary["K_relative_bound"] > 0 and summary["Tstar_relative_bound"] > 0
    assert 0 <= summary["fraction_within_3se"] <= 1
    # 7 s: too few samples per parameter for the instruments, said in the note
    assert any(
        n.startswith("schedule: least squares (")
        and "samples per parameter" in n
        and "sandwich over" in n
        for n in summary["notes"]
    )
    # the fixture walked without motor noise: its bars are too narrow, and that is said
    from colloc.identify.gait.smoother_fit import ZERO_MOTOR_NOISE_NOTE

    assert ZERO_MOTOR_NOISE_NOTE in summary["notes"]
    # the schedule is not pinned here, so its held-out VAF moves with round-off: a start
    # differing by 2e-13 (filtfilt's against sosfiltfilt's sections) moved the six joints'
    # by up to 0.056, the left knee's from 0.70 to 0.69 (measured)
    vaf = summary["validation"]["torque_vaf"]["collocation"]
    assert min(vaf.values()) > 0.6


def test_the_whole_designs_bound_sits_beside_the_states_known_one(tmp_path):
    """The fixture declared as walked with 3 N m of motor noise (its samples do not enter the
    Gauss-Newton information, only where it is taken): ``--design-bound full`` reports the
    whole design's bound beside the schedule's own. With the lab's 0.25 deg and 1 N m the
    states cost little: on 20 s of a 3 N m walk the two were 1.6 % apart."""
    trial = read_trial(FIXTURE)
    trial.metadata["motor_noise"] = {"std": 3.0, "seed": 1}
    folder = trial.write(tmp_path / "trial")
    code, summary = _identify_with_full_bound(folder, tmp_path / "s.json")
    assert code == 0
    full, known = summary["K_relative_bound_full_design"], summary["K_relative_bound"]
    assert known > 0 and 0.9 * known < full < 1.5 * known
    Tfull, Tknown = summary["Tstar_relative_bound_full_design"], summary["Tstar_relative_bound"]
    assert 0.9 * Tknown < Tfull < 1.5 * Tknown
    assert any(n.startswith("design bound: the whole design's, states unknown") for n in
               summary["notes"])  # fmt: skip


def test_records_sharing_the_controller_keep_their_lags_inside_and_add_up(design):
    """Several records (windows, episodes) fitted together: the result does not depend on
    their order, because no lag reaches into another record; without the labels it does."""
    gs, _, _, Tstar, K, _, _ = design
    rng = np.random.default_rng(12)
    parts = [_closed_loop_sample(gs, Tstar, K, rng) for _ in range(2)]

    def fit(order, labelled=True):
        phase, feedback, torques, blocks = (
            np.concatenate([parts[i][k] + (100 * j if k == 3 else 0) for j, i in enumerate(order)])
            for k in range(4)
        )
        segments = np.repeat(np.arange(2), [parts[i][0].size for i in order])
        return fit_schedule_with_errors(
            gs,
            phase,
            feedback,
            torques,
            blocks,
            instrument_lags=(1, 2),
            segments=segments if labelled else None,
        )

    forward, backward = fit((0, 1)), fit((1, 0))
    np.testing.assert_allclose(forward.K, backward.K, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(forward.K_se, backward.K_se, rtol=1e-8, atol=1e-12)
    assert not np.allclose(fit((0, 1), False).K, fit((1, 0), False).K, rtol=1e-8, atol=1e-10)
    one = fit_schedule_with_errors(gs, *parts[0], instrument_lags=(1, 2))
    assert forward.blocks == 2 * one.blocks
    assert np.median(forward.K_se / one.K_se) < 0.8  # twice the data: about 1/sqrt(2)
    phase, feedback, torques, blocks = parts[0]
    with pytest.raises(ValueError, match="segments: expected each record to be one run"):
        fit_schedule_with_errors(
            gs, phase, feedback, torques, blocks, segments=np.arange(phase.size) % 2
        )


@pytest.mark.slow  # 156 s: three identifications of the fixture, one on two Dask workers; benchmarks/slow_tests.py runs it
def test_windows_of_whole_strides_smooth_alone_and_share_the_controller(tmp_path, capsys):
    """``--window-strides 2`` on the fixture: each window of two strides (from a right heel
    strike) is smoothed alone with its own start; together they hold every node of the fit
    window, follow the record as the one-window smoother does, and the schedule's fit keeps
    its lags inside each window (fewer samples than one window's fit)."""
    runs = {}
    for name, extra in (
        ("one", []),
        ("windows", ["--window-strides", "2"]),
        ("workers", ["--window-strides", "2", "--workers", "2"]),
    ):
        out = tmp_path / f"{name}.json"
        quick = ["--no-simulate"] if name == "one" else []
        code = main(
            ["gait", "identify", str(FIXTURE), "--phase", "controller", "--fit-fraction", "0.6"]
            + ["--no-plots", "--no-store", "--json", str(out), *quick, *extra]
        )
        said = capsys.readouterr()
        runs[name] = (json.loads(out.read_text()), said.out + said.err)
        # two strides per window cannot pin the schedule (K 195 % here): its walk falls,
        # which the exit code says; the solve itself succeeds
        walked = runs[name][0]["validation"]["walks"] is not False
        assert runs[name][0]["success"] and code == (0 if walked else 1)
    one, windows = runs["one"][0], runs["windows"][0]
    size = windows["problem"]
    assert one["problem"]["windows"] == 1 and size["windows"] >= 2
    assert size["nodes"] == one["problem"]["nodes"]  # disjoint windows, every node
    assert windows["status"] == "Solve_Succeeded"
    last = f"stride window {size['windows']}/{size['windows']}, "
    assert last in runs["windows"][1] and "stride window" not in runs["one"][1]
    # each window starts free at its first stride: its fit follows the record as closely
    for joint, rms in windows["fit_angle_rms"].items():
        assert rms < 0.25 and abs(rms - one["fit_angle_rms"][joint]) < 0.05, joint
    vaf = windows["validation"]["torque_vaf"]["collocation"]
    assert min(vaf.values()) > 0.7
    # the same windows smoothed on two Dask worker processes: the same numbers
    workers = runs["workers"][0]
    assert workers["problem"] == size and "local workers" in runs["workers"][1]
    for key in ("K_relative_error", "Tstar_relative_error", "fraction_within_3se"):
        assert workers[key] == pytest.approx(windows[key], rel=1e-9, abs=1e-12), key
    assert workers["fit_angle_rms"] == pytest.approx(windows["fit_angle_rms"], rel=1e-9)
    # each window's cost and the process that smoothed it: in order, one after another, all
    # here in one process, and over the workers' processes (not this one) with --workers
    facts = windows["windows"]
    assert len(facts) == size["windows"] and sum(f["nodes"] for f in facts) == size["nodes"]
    assert all(a["stop"] < b["start"] for a, b in zip(facts, facts[1:], strict=False))
    assert all(f["seconds"] > 0 and f["iterations"] > 0 for f in facts)
    assert (
        len({f["process"] for f in facts}) == 1 and len({f["process"] for f in one["windows"]}) == 1
    )
    spread = {f["process"] for f in workers["windows"]}
    assert 1 <= len(spread) <= 2 and facts[0]["process"] not in spread
    # each worker's peak memory (its forked solvers' included) beside this process's
    assert len(workers["worker_peak_rss_mb"]) == 2 and windows["worker_peak_rss_mb"] == []
    assert all(peak > 100 for peak in workers["worker_peak_rss_mb"])
    assert "peak memory: " in runs["workers"][1] and " MB here, workers " in runs["workers"][1]
    # the held-out part walked under both controllers on the workers as here
    here, there = windows["validation"], workers["validation"]
    assert here["walks"] is not None and there["walks"] == here["walks"]
    assert there["angle_rms"] == pytest.approx(here["angle_rms"], rel=1e-9)
    assert there["strides"] == here["strides"] and there["measured_strides"] > 0
    direct = there["direct_walk"]  # exact rate columns: the direct fit is exact and walks
    assert direct["walks"] is True and direct["strides"] == direct["measured_strides"] > 0
    assert direct["angle_rms_deg"] == pytest.approx(here["direct_walk"]["angle_rms_deg"], rel=1e-9)


def test_workers_need_stride_windows(capsys):
    code = main(["gait", "identify", str(FIXTURE), "--workers", "2", "--no-store", "--no-plots"])
    assert code == 2
    assert "--workers/--scheduler: expected --window-strides N" in capsys.readouterr().err


def test_workers_that_lose_a_window_end_the_command_with_its_cause(monkeypatch, tmp_path, capsys):
    """A worker that dies mid-window: the command names the loss (exit 2), writes nothing."""
    import colloc.identify.gait.workflow as workflow
    from colloc.batch.cluster import WorkersLostError

    def lost(*args, **kwargs):
        raise WorkersLostError("workers: the Dask workers lost a task of smooth_window ...")

    monkeypatch.setattr(workflow, "identify_gait", lost)
    out = tmp_path / "out"
    argv = ["gait", "identify", str(FIXTURE), "--window-strides", "2", "--workers", "1"]
    code = main([*argv, "--no-store", "--no-plots", "--out", str(out)])
    assert code == 2
    assert "--workers: the Dask workers lost a task of smooth_window" in capsys.readouterr().err
    assert not out.exists()
