"""colloc gait plan: the bound of the schedule's design against the record's length."""

import json
import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import yaml
from sympy.physics.mechanics import dynamicsymbols

from colloc.cli import main
from colloc.control.gain_scheduled import GainScheduled
from colloc.data.columns import TORQUE_COLUMNS
from colloc.data.trial import read_trial
from colloc.identify.gait.controller_fit import fit_schedule_with_errors, relative_spread
from colloc.identify.gait.phase_law import gait_phase
from colloc.identify.gait.plan import design_bounds, plan_record
from colloc.identify.gait.read import measured_states, state_names

FIXTURE = Path(__file__).parent / "data" / "gait_trial_p20"


def _design():
    trial = read_trial(FIXTURE)
    controller_meta = trial.metadata["controller"]
    names = list(controller_meta["feedback"])
    Tstar, K = np.asarray(controller_meta["Tstar"]), np.asarray(controller_meta["K"])
    gs = GainScheduled(Tstar.shape[0], dynamicsymbols(names), dynamicsymbols("T0:6"))
    phase = gait_phase("causal", trial, trial.time, trial.signals)
    index = {n: i for i, n in enumerate(state_names())}
    states = measured_states(trial.time, trial.signals, 0.05)[:, [index[n] for n in names]]
    known = np.isfinite(phase)
    torques = trial.signals[list(TORQUE_COLUMNS)].to_numpy()[known]
    return gs, phase[known], states[known], torques, Tstar, K


def test_the_design_bound_is_the_fits_bound_and_falls_as_one_over_root_length():
    gs, phase, states, torques, Tstar, K = _design()
    k_bound, t_bound = design_bounds(gs, phase, states, 2.0, Tstar, K)
    # the bound identify reports for the same design and noise (its own code path)
    fit = fit_schedule_with_errors(
        gs, phase, states, torques, np.floor(phase).astype(int), np.full(6, 2.0)
    )
    assert k_bound == pytest.approx(relative_spread(fit.K_bound, K), rel=1e-6)
    assert t_bound == pytest.approx(relative_spread(fit.Tstar_bound, Tstar), rel=1e-6)
    # the same walk twice is twice the information: the bound / sqrt(2), exactly
    twice = design_bounds(gs, np.r_[phase, phase], np.vstack([states, states]), 2.0, Tstar, K)
    assert twice[0] == pytest.approx(k_bound / np.sqrt(2.0), rel=1e-6)
    # and it is proportional to the noise
    assert design_bounds(gs, phase, states, 4.0, Tstar, K)[0] == pytest.approx(2 * k_bound)


def _measured_states():
    trial = read_trial(FIXTURE)
    return measured_states(trial.time, trial.signals, 0.05)


def test_the_plan_reads_the_law_off_the_whole_pilot():
    plan = plan_record(
        FIXTURE, target_k=0.2, record_seconds=300.0, fit_fraction=0.75, states=_measured_states()
    )
    gs, phase, states, _, Tstar, K = _design()
    whole = design_bounds(gs, phase, states, plan.noise_std, Tstar, K)[0]
    assert plan.K_bound[-1] == pytest.approx(whole, rel=1e-6)
    assert plan.K_coefficient == pytest.approx(whole * np.sqrt(plan.fitted_seconds[-1]))
    # beyond the 14 s pilot: the law
    assert plan.K_coefficient / np.sqrt(plan.needed_fit_seconds) == pytest.approx(0.2)
    assert plan.needed_record_seconds == pytest.approx(plan.needed_fit_seconds / 0.75)
    assert plan.K_bound_at_length == pytest.approx(plan.K_coefficient / np.sqrt(225.0))
    assert any("beyond the pilot's 14 s: from the 1/sqrt(length) law" in n for n in plan.notes)
    # a 14 s pilot is far from the law over its shorter parts: said once, with the direction
    (said,) = [n for n in plan.notes if "times the 1/sqrt(length) law's" in n]
    assert "fell faster than the law" in said and "errs long" in said


def test_a_target_for_tstar_too_needs_the_longer_of_the_two_records():
    states = _measured_states()
    k_only = plan_record(FIXTURE, target_k=0.2, states=states)
    t_only = plan_record(FIXTURE, target_tstar=0.1, states=states)
    both = plan_record(FIXTURE, target_k=0.2, target_tstar=0.1, states=states)
    # beyond the 14 s pilot, each from its own law
    assert t_only.needed_fit_seconds == pytest.approx((t_only.Tstar_coefficient / 0.1) ** 2)
    assert both.needed_fit_seconds == pytest.approx(
        max(k_only.needed_fit_seconds, t_only.needed_fit_seconds)
    )
    assert both.target_K == 0.2 and both.target_Tstar == 0.1
    with pytest.raises(ValueError, match="target_tstar: expected a positive number"):
        plan_record(FIXTURE, target_tstar=-1.0, states=states)


def test_within_the_pilot_the_plan_computes_the_bound_on_its_first_seconds():
    gs, phase, states, _, Tstar, K = _design()
    trial = read_trial(FIXTURE)
    t = trial.time[np.isfinite(gait_phase("causal", trial, trial.time, trial.signals))]
    plan = plan_record(FIXTURE, target_k=1.0, record_seconds=16.0, states=_measured_states())
    needed = plan.needed_fit_seconds
    assert plan.fitted_seconds[-2] < needed < plan.fitted_seconds[-1]
    assert any("within the pilot: computed on its own first seconds" in n for n in plan.notes)

    def bound(fitted):  # the design of the first `fitted` seconds, built here on its own
        rows = t <= t[0] + fitted + 1e-9
        return design_bounds(gs, phase[rows], states[rows], plan.noise_std, Tstar, K)[0]

    # the shortest such length: the target met there, not a twentieth of a second before
    assert bound(needed) <= 1.0 < bound(needed - 0.05)
    # a length within the pilot: its own bound, not the law's
    assert plan.K_bound_at_length == pytest.approx(bound(12.0), rel=1e-9)
    t_bound = design_bounds(gs, phase[t <= t[0] + 12.0 + 1e-9], states[t <= t[0] + 12.0 + 1e-9],
                            plan.noise_std, Tstar, K)[1]  # fmt: skip
    assert plan.Tstar_bound_at_length == pytest.approx(t_bound, rel=1e-9)


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    """One command-line plan from the fixture, its states smoothed as identify smooths."""
    out = tmp_path_factory.mktemp("plan")
    code = main(
        ["gait", "plan", str(FIXTURE), "--target-k", "0.2", "--out", str(out)]
        + ["--json", str(out / "plan.json")]
    )
    return code, out


@pytest.mark.slow  # 98 s: the plan smooths the whole fixture; benchmarks/slow_tests.py runs it
def test_a_pilots_design_is_its_smoothed_states(planned):
    """On the noise-free fixture the smoother's states are the record's: the bound the plan
    computes from them is the one from the recorded states, to the smoother's small error
    (and its nodes in place of the samples)."""
    code, out = planned
    assert code == 0
    summary = json.loads((out / "plan.json").read_text())
    assert any("as the fit's smoother gives them" in n for n in summary["notes"])
    given = plan_record(FIXTURE, target_k=0.2, states=_measured_states())
    assert summary["K_bound"][-1] == pytest.approx(given.K_bound[-1], rel=0.05)
    assert summary["K_coefficient"] == pytest.approx(given.K_coefficient, rel=0.05)
    with pytest.raises(ValueError, match=r"states: expected shape \(\d+, 18\)"):
        plan_record(FIXTURE, target_k=0.2, states=np.zeros((3, 18)))


@pytest.mark.slow  # shares the 98 s plan above; benchmarks/slow_tests.py runs it
def test_the_command_writes_the_plan_and_refuses_what_it_cannot_plan(planned, tmp_path, capsys):
    code, out = planned
    assert code == 0
    summary = json.loads((out / "plan.json").read_text())
    assert summary["target_K"] == 0.2 and summary["needed_record_seconds"] > 0
    assert (out / "bound_against_length.png").stat().st_size > 10_000
    assert main(["gait", "plan", str(FIXTURE)]) == 2
    assert "expected at least one, found none" in capsys.readouterr().err
    pilot = tmp_path / "pilot"
    shutil.copytree(FIXTURE, pilot)
    meta = yaml.safe_load((pilot / "metadata.yaml").read_text())
    del meta["controller"]
    (pilot / "metadata.yaml").write_text(yaml.safe_dump(meta))
    assert main(["gait", "plan", str(pilot), "--length", "60"]) == 2
    assert "pilot: expected a trial whose metadata records its controller" in (
        capsys.readouterr().err
    )


class _FakeSimulation:
    """simulate_trial standing in for the minutes of a real pilot: it writes the fixture (a
    simulated walk) where the settings say and records what it was asked for."""

    def __init__(self, fell=False):
        self.fell_flag, self.asked = fell, []

    def __call__(self, settings, progress=None):
        from types import SimpleNamespace

        self.asked.append(settings)
        shutil.copytree(FIXTURE, settings.out / "trial")
        message = "fell at 3.1 s" if self.fell_flag else "walked"
        trial = read_trial(FIXTURE)
        # the simulation's own states: the fixture's noise-free record at half its rate
        record = SimpleNamespace(times=trial.time[::2], states=_measured_states()[::2])
        return SimpleNamespace(
            out=settings.out,
            fell=self.fell_flag,
            summary={"message": message},
            record=record,
            trial=trial,
        )


def test_a_plan_without_a_pilot_simulates_one_for_the_subject_and_keeps_it(
    tmp_path, capsys, monkeypatch
):
    import colloc.gait.workflow as workflow

    fake = _FakeSimulation()
    monkeypatch.setattr(workflow, "simulate_trial", fake)
    out = tmp_path / "plan"
    args = ["gait", "plan", "--target-k", "0.2", "--speed", "1.1", "--mass", "68"]
    args += ["--height", "1.72", "--points", "20", "--motor-noise", "3", "--seed", "4"]
    code = main(args + ["--out", str(out), "--json", str(out / "plan.json")])
    assert code == 0, capsys.readouterr().err
    (asked,) = fake.asked
    assert (asked.speed, asked.body_mass, asked.height) == (1.1, 68.0, 1.72)
    assert (asked.num_points, asked.motor_noise, asked.seed) == (20, 3.0, 4)
    assert asked.duration == 60.0 and asked.out == out / "pilot"
    summary = json.loads((out / "plan.json").read_text())
    # the plan is the pilot's own: the trial it wrote, with the simulation's states at the
    # trial's samples as the design (interpolated from the record's)
    trial = read_trial(FIXTURE)
    record = _FakeSimulation()(SimpleNamespace(out=tmp_path / "again"), None).record
    exact = np.column_stack([np.interp(trial.time, record.times, c) for c in record.states.T])
    direct = plan_record(out / "pilot" / "trial", target_k=0.2, states=exact)
    assert summary["needed_record_seconds"] == pytest.approx(direct.needed_record_seconds)
    assert summary["pilot"]["simulated"]["speed"] == 1.1
    assert summary["pilot"]["simulated"]["seed"] == 4
    assert summary["notes"][0].startswith("pilot simulated: 60 s at 1.1 m/s, 68 kg")
    assert summary["notes"][0].endswith("its states without sensor noise are the design")
    # without --out the pilot goes to a folder that is removed, and that is said
    assert main(["gait", "plan", "--length", "120", "--speed", "1.1"]) == 0
    assert "now removed (--out keeps it)" in capsys.readouterr().out
    assert not fake.asked[-1].out.exists()
    # real walking's motor noise unless told: without it the fit's bars are too narrow
    assert fake.asked[-1].motor_noise == 3.0


def test_a_plan_refuses_a_pilot_that_fell_and_pilot_options_beside_a_pilot(
    tmp_path, capsys, monkeypatch
):
    import colloc.gait.workflow as workflow

    monkeypatch.setattr(workflow, "simulate_trial", _FakeSimulation(fell=True))
    assert main(["gait", "plan", "--length", "60", "--out", str(tmp_path / "p")]) == 2
    assert "pilot: the simulated walk fell (fell at 3.1 s)" in capsys.readouterr().err
    # options of a pilot to simulate beside a pilot given: which one is meant is not known
    assert main(["gait", "plan", str(FIXTURE), "--length", "60", "--speed", "1.2"]) == 2
    assert "--speed: these describe a pilot to simulate" in capsys.readouterr().err
    # a bad pilot option is named by its flag, before any simulation
    fake = _FakeSimulation()
    monkeypatch.setattr(workflow, "simulate_trial", fake)
    assert main(["gait", "plan", "--length", "60", "--speed", "9", "--mass", "-1"]) == 2
    err = capsys.readouterr().err
    assert "--speed: expected a walking speed" in err and "--mass: expected a positive" in err
    assert main(["gait", "plan", "--target-k", "-0.2", "--speed", "1.2"]) == 2
    assert "target_k: expected a positive number" in capsys.readouterr().err
    assert fake.asked == []
