"""colloc gait identify on a short noise-free fixture trial with a known controller."""

import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from colloc.cli import main
from colloc.gait.closed_loop import simulate_walking
from colloc.identify.gait.read import read_gait_data
from colloc.identify.gait.settings import GaitIdentifySettings

FIXTURE = Path(__file__).parent / "data" / "gait_trial_p20"
ARGS = ["--phase", "controller", "--fit-fraction", "0.6", "--max-iter", "0", "--no-plots"]
ARGS += ["--method", "closed-loop"]  # the smoother is measured in tests/identify/test_gait_fit.py


@pytest.fixture(scope="module")
def identified(tmp_path_factory):
    """One CLI run: the direct-identification start, no solver iteration (the solve itself
    is measured in benchmarks/gait_identify.py), uncertainty, validation, store, JSON."""
    out = tmp_path_factory.mktemp("identify")
    db = f"sqlite:///{out / 'runs.db'}"
    plotted = [a for a in ARGS if a != "--no-plots"] + ["--out", str(out / "figures")]
    code = main(
        ["gait", "identify", str(FIXTURE), *plotted, "--db", db, "--json", str(out / "s.json")]
    )
    return code, json.loads((out / "s.json").read_text()), db, out / "figures"


def test_direct_start_recovers_the_known_controller_and_walks_the_held_out_part(identified):
    code, summary, _, _ = identified
    assert "subject: 75 kg, 1.8 m (the trial's metadata)" in summary["notes"]
    # exact data of a controller in the identified class: the direct least squares on the
    # measured rates is exact, and so is the (unsolved) collocation estimate it starts
    assert summary["direct_K_relative_error"] < 1e-6
    assert summary["K_relative_error"] < 1e-6 and summary["Tstar_relative_error"] < 1e-6
    assert summary["fraction_within_3se"] == 1.0
    vaf = summary["validation"]["torque_vaf"]
    # the trial records its controller: its VAF, the ceiling of a consistent estimate, is
    # reported beside the two fits (here the generator of noise-free torques: exact)
    assert set(vaf) == {"collocation", "direct", "truth"}
    assert min(vaf["collocation"].values()) > 0.9999 and min(vaf["truth"].values()) > 0.9999
    # the forward simulation under the true controller, started from the measured state at
    # the held-out part's start with the trial's own phase convention, retraces the record
    walk = summary["validation"]
    assert walk["walks"] is True
    assert max(walk["angle_rms"].values()) < 0.01  # degrees
    # retracing it, the simulation strikes the ground at the record's strikes
    assert walk["strides"] == walk["measured_strides"] > 0
    # the direct fit is exact here too, and walked the same way
    assert walk["direct_walk"]["walks"] is True
    assert max(walk["direct_walk"]["angle_rms_deg"].values()) < 0.01
    # the true controller walked the same belt from the same start: the identified walk
    # (its controller equal to the truth to 1e-6) is that walk, sample by sample and by phase
    assert walk["truth_walk"]["walks"] is True
    assert walk["truth_walk"]["strides"] == walk["strides"]
    against = walk["against_truth_walk"]
    assert against["seconds"] == pytest.approx(walk["simulated_seconds"], abs=0.02)
    assert max(against["angle_rms_deg"].values()) < 1e-3
    assert max(against["angle_rms_phase_deg"].values()) < 1e-3
    # retracing the record, the walk's mean stride is the record's
    assert set(walk["angle_rms_phase"]) == set(walk["angle_rms"])
    assert max(walk["angle_rms_phase"].values()) < 0.01
    assert summary["iterations"] == 0 and summary["status"] == "Maximum_Iterations_Exceeded"
    assert code == 1  # the solver did not converge (no iterations allowed): said by the code
    for key in ("times", "peak_rss_mb", "run_id", "problem"):
        assert key in summary


def test_the_figure_set_shows_the_schedules_with_bands_the_vaf_and_the_held_out_walk(identified):
    *_, figures = identified
    stems = {
        "tstar_schedule", "stiffness_schedule", "damping_schedule", "gain_schedule",
        "fitted_angles", "torque_vaf", "validation_walk", "validation_walk_phase",
    }  # fmt: skip
    for stem in stems:
        for suffix in (".png", ".svg"):
            assert (figures / f"{stem}{suffix}").stat().st_size > 10_000, stem + suffix


def test_the_fitted_angles_figure_says_whose_motion_it_shows(monkeypatch):
    """The smoother's fit has free torques: its figure must not read as the controller's."""
    import colloc.identify.gait.outputs as outputs
    from colloc.identify.gait.settings import METHODS

    assert set(outputs.FITTED_ANGLES) == set(METHODS)
    assert "not the controller's" in outputs.FITTED_ANGLES["smoother"][0]
    assert "identified controller" in outputs.FITTED_ANGLES["closed-loop"][0]


def test_each_joints_own_gains_are_picked_with_their_errors():
    from types import SimpleNamespace

    from colloc.identify.gait.outputs import _own_gains
    from colloc.identify.gait.workflow import JOINT_NAMES

    feedback = [f"{j}_{s}" for s in ("rate", "angle") for j in reversed(JOINT_NAMES)]
    K = np.arange(3 * 6 * 12, dtype=float).reshape(3, 6, 12)
    est = SimpleNamespace(K=K, K_se=K / 10)
    run = SimpleNamespace(feedback=feedback, collocation=est, direct=SimpleNamespace(K=-K))
    run.truth = SimpleNamespace(K=2 * K)
    own = _own_gains(run, "angle")  # type: ignore[arg-type]
    for j, joint in enumerate(JOINT_NAMES):
        i = feedback.index(f"{joint}_angle")
        np.testing.assert_array_equal(own["collocation"][0][:, j], K[:, j, i])
        np.testing.assert_array_equal(own["collocation"][1][:, j], K[:, j, i] / 10)
        np.testing.assert_array_equal(own["direct"][0][:, j], -K[:, j, i])
        np.testing.assert_array_equal(own["truth"][0][:, j], 2 * K[:, j, i])
    run.feedback = feedback[:6]  # rates only: no angle gains to draw
    assert _own_gains(run, "angle") == {}  # type: ignore[arg-type]


def test_the_run_is_stored_with_its_own_kind_and_a_deterministic_id(identified, tmp_path):
    _, summary, db, _ = identified
    from colloc.store import RunStore

    store = RunStore(db)
    record = store.get(summary["run_id"])
    assert record.kind == "gait-identify"
    frame = record.parameters_frame()
    assert len(frame) == summary["problem"]["parameters"]
    np.testing.assert_allclose(frame["identified"], frame["known"], atol=1e-6)
    from colloc.identify.gait.outputs import gait_run_id

    class Run:  # the id depends on the settings and the data digest only
        settings = GaitIdentifySettings(
            trial=tmp_path, phase="controller", fit_fraction=0.6, max_iter=0, method="closed-loop"
        )
        data_digest = ""

    assert gait_run_id(Run) == gait_run_id(Run)  # type: ignore[arg-type]
    Run.data_digest = "x"
    assert gait_run_id(Run) != summary["run_id"]  # type: ignore[arg-type]


def copy_fixture(tmp_path: Path) -> Path:
    trial = tmp_path / "trial"
    shutil.copytree(FIXTURE, trial)
    return trial


def read_error(trial: Path, **settings) -> str:
    with pytest.raises(ValueError) as info:
        read_gait_data(GaitIdentifySettings(trial=trial, **settings))
    return str(info.value)


def test_missing_columns_are_named_before_any_work(tmp_path):
    trial = copy_fixture(tmp_path)
    frame = pd.read_csv(trial / "trial.csv")
    frame.drop(columns=["controller_phase"]).to_csv(trial / "trial.csv", index=False)
    assert "controller_phase" in read_error(trial, phase="controller")
    frame.drop(columns=["left_knee_rate"]).to_csv(trial / "trial.csv", index=False)
    assert "left_knee_rate" in read_error(trial)  # the trial reader's own check


def test_too_few_strides_for_the_schedule_and_no_strides_in_the_window(tmp_path):
    message = read_error(FIXTURE, points=400, fit_fraction=0.6)
    assert "P = 400" in message and "--points" in message
    message = read_error(FIXTURE, fit_fraction=0.6, duration=1.0)
    assert "complete strides" in message


def test_trial_without_heel_strikes(tmp_path):
    trial = copy_fixture(tmp_path)
    events = pd.read_csv(trial / "events.csv")
    events[events["side"] != "right"].to_csv(trial / "events.csv", index=False)
    assert "heel strikes on one side only (0 right" in read_error(trial)


def test_metadata_that_disagrees_with_the_columns(tmp_path):
    trial = copy_fixture(tmp_path)
    meta = yaml.safe_load((trial / "metadata.yaml").read_text())
    meta["controller"]["feedback"] = meta["controller"]["feedback"][:-1]
    (trial / "metadata.yaml").write_text(yaml.safe_dump(meta))
    assert "disagree" in read_error(trial)


def test_a_ragged_gain_array_in_the_metadata_is_named(tmp_path):
    trial = copy_fixture(tmp_path)
    meta = yaml.safe_load((trial / "metadata.yaml").read_text())
    meta["controller"]["K"][0][0] = meta["controller"]["K"][0][0][:-1]  # one row short
    (trial / "metadata.yaml").write_text(yaml.safe_dump(meta))
    message = read_error(trial)
    assert "controller K: expected a rectangular array of numbers" in message
    assert "inhomogeneous" in message  # NumPy's reason, after colloc's


def test_simulation_without_a_cycle_needs_the_reference_given():
    with pytest.raises(ValueError, match="stride_duration"):
        simulate_walking(None, np.zeros((2, 6)), np.zeros((2, 6, 12)), 1.0, None)


# About 20 minutes on a 2-core machine (the priors' effective degrees of freedom solve the
# KKT system for every disturbance sample): run with -m slow, timed by
# benchmarks/gait_identify.py --trial tests/identify/data/gait_trial_p20 --process-noise 1,2
@pytest.mark.slow
def test_process_noise_fit_estimates_disturbances_and_reports_sandwich_errors(tmp_path):
    """``--process-noise``: motor noise on the six torques and residual forces on the trunk
    become free trajectories of the fit (the solver's numbers are checked against IPOPT in
    tests/nlp/test_gauss_newton.py); the standard errors come from the sandwich over the
    window's strides, and the settings are recorded."""
    out = tmp_path / "s.json"
    args = ["--phase", "controller", "--fit-fraction", "0.6", "--max-iter", "1"]
    args += ["--method", "closed-loop"]
    code = main(
        ["gait", "identify", str(FIXTURE), *args, "--no-plots", "--no-store", "--no-simulate"]
        + ["--process-noise", "1,2", "--json", str(out)]
    )
    summary = json.loads(out.read_text())
    assert summary["settings"]["process_noise"] == [1.0, 2.0]
    assert summary["iterations"] == 1 and code == 1
    # 9 disturbances at every node beside the 18 states
    N = summary["problem"]["nodes"]
    assert summary["problem"]["variables"] == N * (18 + 9) + summary["problem"]["parameters"]
    data = read_gait_data(GaitIdentifySettings(trial=FIXTURE, phase="controller", fit_fraction=0.6))
    t = data.fit.time[data.rows]
    strikes = data.trial.right_heel_strikes
    blocks = 1 + np.count_nonzero((strikes > t[0] + 1e-9) & (strikes < t[-1]))
    assert f"standard errors: sandwich over {blocks} strides" in summary["notes"]
    assert summary["fraction_within_3se"] is not None


@pytest.mark.parametrize("value", ["0", "1,-2", "a", "1,2,3"])
def test_bad_process_noise_is_refused_by_name(value, capsys):
    code = None
    with pytest.raises(SystemExit) as stop:
        code = main(["gait", "identify", str(FIXTURE), "--process-noise", value])
    assert code is None and stop.value.code == 2
    assert "--process-noise" in capsys.readouterr().err


def test_the_default_causal_phase_says_where_its_stride_and_reset_come_from(tmp_path):
    """The fixture records its designed cycle but not its controller's reset phase: one
    cycle per the cycle's duration, reset to 0, and the run's notes say so."""
    out = tmp_path / "s.json"
    args = ["--fit-fraction", "0.6", "--max-iter", "1", "--method", "closed-loop"]
    args += ["--points", "4"]  # the phase's note does not depend on P; 4 points fit faster
    main(
        ["gait", "identify", str(FIXTURE), *args, "--no-plots", "--no-store", "--no-simulate"]
        + ["--json", str(out)]
    )
    summary = json.loads(out.read_text())
    assert summary["settings"]["phase"] == "causal"
    duration = yaml.safe_load((FIXTURE / "metadata.yaml").read_text())["cycle"]["duration"]
    expected = (
        f"phase: causal, reset to 0 at each right heel strike, one cycle per {duration:.4g} s "
        "(the trial's designed cycle)"
    )
    assert expected in summary["notes"]


def test_a_record_too_short_says_how_long_a_record_is_needed(tmp_path):
    """A 2.5 s walk (OpenSim's example is one) is told the length identification needs, from
    its own strides and rate: two strides to fit and one held out, and the schedule's
    unknowns per torque times P samples in a fit of 0.6 of the record."""
    trial = copy_fixture(tmp_path)
    frame = pd.read_csv(trial / "trial.csv")
    frame[frame["time"] <= 2.5].to_csv(trial / "trial.csv", index=False)
    events = pd.read_csv(trial / "events.csv")
    events = events[events["time"] <= 2.5]
    events.to_csv(trial / "events.csv", index=False)
    message = read_error(trial, fit_fraction=0.6)
    assert "trial: 2.5 s with 3 right heel strikes; identification needs at least 4" in message
    stride = np.median(np.diff(events.loc[events["side"] == "right", "time"]))
    width = int(message.split(" samples in the fit")[0].split()[-1]) // 20
    needed = max(max(2 * stride, width * 20 / 100.0) / 0.6, 3 * stride)
    assert f"at least {needed:.0f} s of walking at {stride:.2f} s a stride and 100 Hz" in message


def test_a_missed_heel_strike_is_named(tmp_path):
    trial = copy_fixture(tmp_path)
    events = pd.read_csv(trial / "events.csv")
    right = events[events["side"] == "right"]
    dropped = right.index[4]
    events.drop(index=dropped).to_csv(trial / "events.csv", index=False)
    message = read_error(trial, fit_fraction=0.6)
    before, after = right["time"].iloc[3], right["time"].iloc[5]
    assert "events: 1 stride(s) between right heel strikes last more than 1.6 times" in message
    assert f"{before:.2f}-{after:.2f} s" in message and "a strike was missed" in message


def test_the_subject_and_where_it_came_from_are_said():
    """A trial with an empty metadata.yaml was accepted and nothing said which body mass and
    height scaled the model."""
    from colloc.identify.gait.read import subject_note

    assert subject_note({"body_mass": 62.0, "height": 1.65}) == (
        "subject: 62 kg, 1.65 m (the trial's metadata)"
    )
    said = subject_note({})
    assert said.startswith("subject: 75 kg, 1.8 m; metadata.yaml gives no body_mass or height")
    assert "colloc's defaults are used" in said
    assert "gives no height" in subject_note({"body_mass": 80.0})


def stripped_copy(tmp_path: Path) -> Path:
    """The fixture as a lab export's trial would be: the same walk, no controller recorded."""
    trial = copy_fixture(tmp_path)
    meta = yaml.safe_load((trial / "metadata.yaml").read_text())
    del meta["controller"]
    (trial / "metadata.yaml").write_text(yaml.safe_dump(meta))
    return trial


def test_truth_from_another_trial_scores_the_walk_like_the_walk_itself(tmp_path):
    """--truth: a trial without a controller, given the simulated trial's, is read as the
    simulated trial is (same P, feedback and controller)."""
    trial = stripped_copy(tmp_path)
    alone = read_gait_data(GaitIdentifySettings(trial=trial, fit_fraction=0.6))
    own = read_gait_data(GaitIdentifySettings(trial=FIXTURE, fit_fraction=0.6))
    given = read_gait_data(GaitIdentifySettings(trial=trial, fit_fraction=0.6, truth=FIXTURE))
    assert given.points == own.points and given.feedback == own.feedback
    assert given.trial.metadata["controller"] == own.trial.metadata["controller"]
    assert given.trial.metadata["truth_source"] == str(FIXTURE)
    assert "controller" not in alone.trial.metadata
    # the motor noise the walk was simulated with comes along for the lab design's bound,
    # beside (not over) the trial's own entry, which its torques' bound reads
    walked = copy_fixture(tmp_path / "walked")
    meta = yaml.safe_load((walked / "metadata.yaml").read_text())
    meta["motor_noise"] = {"std": 3.0, "seed": 7}
    (walked / "metadata.yaml").write_text(yaml.safe_dump(meta))
    lab = read_gait_data(GaitIdentifySettings(trial=trial, fit_fraction=0.6, truth=walked))
    assert lab.trial.metadata["truth_motor_noise"] == 3.0
    assert lab.trial.metadata.get("motor_noise") == own.trial.metadata.get("motor_noise")


# a second identification of the fixture (23 s): run by benchmarks/slow_tests.py
@pytest.mark.slow
def test_truth_from_another_trial_gives_the_simulated_trials_own_errors(identified, tmp_path):
    """The whole command: the same errors against the truth as the simulated trial's own
    run."""
    trial = stripped_copy(tmp_path)
    out = tmp_path / "s.json"
    code = main(
        [
            "gait",
            "identify",
            str(trial),
            *ARGS,
            "--truth",
            str(FIXTURE),
            "--no-store",
            "--no-simulate",
        ]
        + ["--json", str(out)]
    )
    assert code == identified[0]  # 1 for both: --max-iter 0 stops IPOPT before success
    summary, reference = json.loads(out.read_text()), identified[1]
    for key in ("K_relative_error", "Tstar_relative_error", "fraction_within_3se"):
        assert summary[key] is not None
        assert summary[key] == pytest.approx(reference[key], rel=1e-6), key
    assert any(n.startswith(f"true controller: {FIXTURE}'s") for n in summary["notes"])


def test_a_truth_that_records_no_controller_is_refused_by_name(tmp_path, capsys):
    trial = stripped_copy(tmp_path)
    message = read_error(trial, fit_fraction=0.6, truth=trial)
    assert "truth: expected a trial whose metadata records the controller" in message
    assert str(trial) in message
    (tmp_path / "broken").mkdir()
    (tmp_path / "broken" / "metadata.yaml").write_text("controller: [unclosed\n")
    assert "truth: " in read_error(trial, fit_fraction=0.6, truth=tmp_path / "broken")
    code = main(["gait", "identify", str(trial), "--truth", str(tmp_path / "nowhere")])
    assert code == 2
    err = capsys.readouterr().err
    assert "truth: expected the directory of the simulated trial" in err


def test_mean_signals_by_phase_is_the_hat_weighted_mean_cycle():
    """A signal linear in the phase, sampled evenly over many strides: the schedule's mean at
    an inner point is the signal at that point (the hats are symmetric); a constant is kept
    exactly; T0 is the controller's own torque at the mean cycle (GainScheduled.torque)."""
    from sympy.physics.mechanics import dynamicsymbols

    from colloc.control.gain_scheduled import GainScheduled
    from colloc.identify.gait.estimate import (
        ControllerEstimate,
        mean_cycle_torque,
        mean_signals_by_phase,
    )

    P = 8
    gs = GainScheduled(P, dynamicsymbols("s0:2"), dynamicsymbols("T0:6"))
    phase = np.arange(0, 30 * 4000) / 4000 + 0.125 / 4000  # 30 strides, even samples
    cycle = np.mod(phase, 1.0)
    signals = np.column_stack([3.0 + 2.0 * cycle, np.full_like(phase, -1.5)])
    mean = mean_signals_by_phase(gs, phase, signals)
    inner = np.arange(1, P)  # point 0's hats straddle the wrap of the linear signal
    np.testing.assert_allclose(mean[inner, 0], 3.0 + 2.0 * inner / P, atol=1e-9)
    np.testing.assert_allclose(mean[:, 1], -1.5, atol=1e-12)
    rng = np.random.default_rng(0)
    est = ControllerEstimate(rng.normal(size=(P, 6)), rng.normal(size=(P, 6, 2)))
    at_points = np.array([gs.torque(p / P, mean[p], est.Tstar, est.K)[0] for p in range(P)])
    np.testing.assert_allclose(mean_cycle_torque(est, mean), at_points, atol=1e-12)


def test_t0_of_the_truth_is_the_measured_torque_on_the_mean_cycle(identified):
    """On the noise-free fixture the true controller's T0 agrees with the measured joint
    torques averaged per schedule point (an independent mean of what the trial records), and
    the summary defines what it reports."""
    from sympy.physics.mechanics import dynamicsymbols

    from colloc.control.gain_scheduled import GainScheduled
    from colloc.data.columns import TORQUE_COLUMNS
    from colloc.identify.gait.estimate import mean_signals_by_phase

    _, summary, _, figures = identified
    t0 = {name: np.asarray(v) for name, v in summary["T0"].items()}
    assert set(t0) == {"collocation", "direct", "truth"}
    P = summary["points"]
    frame = pd.read_csv(FIXTURE / "trial.csv")
    start, stop = summary["window"]
    rows = (frame["time"] >= start - 1e-9) & (frame["time"] <= stop + 1e-9)
    gs = GainScheduled(P, dynamicsymbols("s0:1"), dynamicsymbols("T0:6"))
    torques = frame.loc[rows, list(TORQUE_COLUMNS)].to_numpy()
    measured = mean_signals_by_phase(gs, frame.loc[rows, "controller_phase"].to_numpy(), torques)
    # (not equal: T* and K vary across each point's samples, and the window has few strides:
    # measured 0.06-0.21 of the range RMS; a plausibility check: the exact identity is the
    # unit test above, and T* alone or a wrong sign of K s misses by hundreds of N m)
    rms = np.sqrt(np.mean((t0["truth"] - measured) ** 2, axis=0))
    assert np.all(rms <= 0.25 * np.ptp(measured, axis=0)), (t0["truth"], measured)
    # a joint-moment profile, not the intercept T* (hundreds to thousands of N m)
    assert (
        np.abs(t0["truth"]).max()
        < 0.2
        * np.abs(
            yaml.safe_load((FIXTURE / "metadata.yaml").read_text())["controller"]["Tstar"]
        ).max()
    )
    for key in ("K_relative_error", "K_relative_bound", "fraction_within_3se", "T0"):
        assert key in summary["definitions"]
    assert (figures / "mean_cycle_torque.png").stat().st_size > 10_000


def test_the_summary_says_which_subject_and_model_constants_the_fit_used(identified):
    from dataclasses import asdict

    from colloc.models.gait2d_params import load_parameters

    summary = identified[1]
    meta = yaml.safe_load((FIXTURE / "metadata.yaml").read_text())
    mass, height = meta["body_mass"], meta["height"]
    assert summary["model"]["subject"] == f"{mass:g} kg, {height:g} m (the trial's metadata)"
    expected = asdict(load_parameters(mass, height))
    constants = summary["model"]["constants"]
    assert constants["body_mass"] == mass and constants["gravity"] == expected["gravity"]
    for segment in ("trunk", "thigh", "shank", "foot"):
        for key, value in expected[segment].items():
            assert constants[segment][key] == pytest.approx(value), (segment, key)
    assert constants["contact"] == pytest.approx(expected["contact"])


def test_the_mean_stride_figure_draws_each_walk_that_has_a_whole_stride():
    from colloc.identify.gait.outputs import _mean_strides_figure

    t = np.arange(0.0, 6.0, 0.01)
    strikes = np.array([0.2, 1.3, 2.4, 3.5, 4.6, 5.7])
    phi = np.interp(t, strikes, np.arange(strikes.size), left=np.nan, right=np.nan) % 1
    angles = np.column_stack([np.sin(2 * np.pi * np.nan_to_num(phi)) * (j + 1) for j in range(6)])
    walked = {"times": t, "simulated_angles": angles, "simulated_strikes": strikes}
    fell = {"times": t[:30], "simulated_angles": angles[:30], "simulated_strikes": strikes[:1]}
    validation = {
        "held_out": {"times": t, "angles": angles, "strikes": strikes},
        "walk_signals": {"collocation": walked, "direct": fell, "truth": walked},
    }
    fig = _mean_strides_figure(validation)
    first = fig.axes[0]
    labels = [line.get_label() for line in first.get_lines()]
    assert labels == ["record", "identified controller's walk", "true controller's walk"]
    # each drawn walk is the record's mean stride here (the same signal)
    record_mean, walk_mean = (first.get_lines()[k].get_ydata() for k in (0, 1))
    np.testing.assert_allclose(walk_mean, record_mean)
    assert "not drawn: direct fit's walk" in fig._suptitle.get_text()
