"""Walking record -> gait-lab trial: column mapping, seeded noise, metadata round trip."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

from colloc.data.columns import (
    GRF_COLUMNS,
    JOINT_ANGLE_COLUMNS,
    JOINT_RATE_COLUMNS,
    SIGNAL_COLUMNS,
    TORQUE_COLUMNS,
)
from colloc.data.trial import read_trial
from colloc.gait.metadata import controller_from_metadata, controller_metadata, synthetic_metadata
from colloc.gait.trials import (
    COLUMN_NOISE_GROUP,
    DEFAULT_NOISE_STD,
    NOISE_GROUPS,
    STATE_COLUMNS,
    record_to_trial,
    resolve_noise_std,
    true_signals,
)

PERIOD = 1.1


@dataclass
class FakeRecord:
    times: np.ndarray
    states: np.ndarray
    torques: np.ndarray
    belt_speed: np.ndarray
    belt_position: np.ndarray
    right_heel_strikes: np.ndarray
    left_heel_strikes: np.ndarray
    ground_reactions: np.ndarray | None = None


def make_record(duration: float = 6.0, step: float = 0.005) -> FakeRecord:
    times = np.arange(round(duration / step) + 1) * step
    w = 2 * np.pi / PERIOD
    # Column i of q is a distinct sinusoid, u its exact derivative.
    amplitude = 0.1 * (1 + np.arange(9))
    offset = np.array([0.2, 0.95, 0.05, 0.1, -0.3, 0.0, -0.1, -0.2, 0.05])
    q = offset + amplitude * np.sin(w * times[:, None] + np.arange(9))
    u = amplitude * w * np.cos(w * times[:, None] + np.arange(9))
    torques = 10.0 * np.cos(w * times[:, None] + 0.5 * np.arange(6))
    belt_speed = 1.2 + 0.1 * np.sin(3.0 * times)
    belt_position = 1.2 * times + 0.1 * (1 - np.cos(3.0 * times)) / 3.0
    right = np.arange(0.3, duration + 1.0, PERIOD)  # the last one lies beyond the record
    left = right[:-1] + PERIOD / 2
    return FakeRecord(times, np.hstack([q, u]), torques, belt_speed, belt_position, right, left)


def make_controller(num_points: int = 4) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(7)
    mask = np.zeros((6, 12), dtype=bool)
    mask[np.arange(6), np.arange(6)] = True
    mask[np.arange(6), 6 + np.arange(6)] = True
    K = np.where(mask, rng.normal(size=(num_points, 6, 12)), 0.0)
    return rng.normal(size=(num_points, 6)) * 30.0, K, mask


def test_true_signals_map_states_to_canonical_columns():
    record = make_record()
    time, frame = true_signals(record)
    q, u = record.states[:, :9], record.states[:, 9:]
    # a record without ground reactions gives every column but theirs
    assert list(frame.columns) == [c for c in SIGNAL_COLUMNS if c not in GRF_COLUMNS]
    np.testing.assert_array_equal(time, record.times)
    # Right hip/knee/ankle = qb, qc, qd; left = qe, qf, qg (gait2d order).
    for i, name in enumerate(JOINT_ANGLE_COLUMNS):
        np.testing.assert_array_equal(frame[name], q[:, 3 + i])
    for i, name in enumerate(JOINT_RATE_COLUMNS):
        np.testing.assert_array_equal(frame[name], u[:, 3 + i])
    np.testing.assert_array_equal(frame["trunk_x"], q[:, 0])
    np.testing.assert_array_equal(frame["trunk_y"], q[:, 1])
    np.testing.assert_array_equal(frame["trunk_angle"], q[:, 2])
    # The trunk's velocity: uax, uay, ua (what a lab differentiates from the pelvis markers).
    np.testing.assert_array_equal(frame["trunk_x_rate"], u[:, 0])
    np.testing.assert_array_equal(frame["trunk_y_rate"], u[:, 1])
    np.testing.assert_array_equal(frame["trunk_angle_rate"], u[:, 2])
    np.testing.assert_array_equal(frame["belt_speed"], record.belt_speed)
    np.testing.assert_array_equal(frame["belt_position"], record.belt_position)
    for i, name in enumerate(TORQUE_COLUMNS):
        np.testing.assert_array_equal(frame[name], record.torques[:, i])
    # STATE_COLUMNS reads the state back in gait2d's order, each column in one noise group
    np.testing.assert_array_equal(frame[list(STATE_COLUMNS)].to_numpy(), record.states)
    assert [COLUMN_NOISE_GROUP[c] for c in STATE_COLUMNS[:9]] == (
        ["trunk_position"] * 2 + ["trunk_angle"] + ["joint_angle"] * 6
    )
    assert sorted(COLUMN_NOISE_GROUP) == sorted(c for g in NOISE_GROUPS.values() for c in g)


def test_noise_free_trial_resamples_at_the_sample_rate():
    record = make_record()
    trial = record_to_trial(record, noise_std=0.0, seed=0, sample_rate=100.0)
    np.testing.assert_allclose(trial.time, np.arange(601) * 0.01, atol=1e-12)
    q = record.states[:, :9]
    # Record step 5 ms, so every 100 Hz sample is a record sample: interpolation is exact.
    np.testing.assert_allclose(trial.signals["right_knee_angle"], q[::2, 4], atol=1e-12)
    # Strikes after the last sample (6 s) are dropped: right 6.9 s, left 6.35 s.
    np.testing.assert_allclose(trial.right_heel_strikes, 0.3 + 1.1 * np.arange(6))
    np.testing.assert_allclose(trial.left_heel_strikes, 0.85 + 1.1 * np.arange(5))
    assert trial.metadata["sample_rate"] == 100.0


def test_noise_has_the_requested_std_and_is_seeded():
    record = make_record(duration=60.0, step=0.01)
    std = {"joint_angle": 0.01, "belt_speed": 0.002, "joint_torque": 0.0}
    trial = record_to_trial(record, noise_std=std, seed=3, sample_rate=None)
    _, truth = true_signals(record)
    error = trial.signals - truth
    # 6 columns x 6001 samples: the sample sd is within ~1 % of the true sd.
    assert np.std(error[list(JOINT_ANGLE_COLUMNS)].to_numpy()) == pytest.approx(0.01, rel=0.03)
    assert np.std(error["belt_speed"].to_numpy()) == pytest.approx(0.002, rel=0.06)
    expected_rate = DEFAULT_NOISE_STD["joint_rate"]
    assert np.std(error[list(JOINT_RATE_COLUMNS)].to_numpy()) == pytest.approx(
        expected_rate, rel=0.03
    )
    np.testing.assert_array_equal(error[list(TORQUE_COLUMNS)].to_numpy(), 0.0)
    # Independent columns: correlation between two angle noises is ~0 (|r| < 4 / sqrt(M)).
    r = np.corrcoef(error["right_hip_angle"], error["left_hip_angle"])[0, 1]
    assert abs(r) < 4 / math.sqrt(error.shape[0])
    again = record_to_trial(record, noise_std=std, seed=3, sample_rate=None)
    np.testing.assert_array_equal(again.signals.to_numpy(), trial.signals.to_numpy())
    other = record_to_trial(record, noise_std=std, seed=4, sample_rate=None)
    assert not np.allclose(other.signals["right_hip_angle"], trial.signals["right_hip_angle"])
    assert trial.metadata["noise"]["seed"] == 3
    assert trial.metadata["noise"]["std"]["joint_angle"] == 0.01


def test_resolve_noise_std_scales_and_overrides():
    assert resolve_noise_std(None) == DEFAULT_NOISE_STD
    doubled = resolve_noise_std(2.0)
    assert doubled["joint_angle"] == pytest.approx(2 * math.radians(0.25))
    assert doubled["trunk_position"] == pytest.approx(0.002)
    custom = resolve_noise_std({"trunk_position": 0.003})
    assert custom["trunk_position"] == 0.003
    assert custom["joint_angle"] == DEFAULT_NOISE_STD["joint_angle"]
    assert set(custom) == set(NOISE_GROUPS)


def test_resolve_noise_std_errors():
    with pytest.raises(ValueError, match=r"unknown group 'knee'.*noise_std\['joint_rate'\]"):
        resolve_noise_std({"knee": 0.1, "joint_rate": -1.0})
    with pytest.raises(ValueError, match="non-negative finite multiple, found -1"):
        resolve_noise_std(-1.0)
    with pytest.raises(TypeError, match="noise_std: expected a number.*found str"):
        resolve_noise_std("high")  # type: ignore[arg-type]


def test_record_to_trial_errors():
    record = make_record()
    with pytest.raises(ValueError, match=r"seed: expected a non-negative int.*sample_rate"):
        record_to_trial(record, seed=-1, sample_rate=0.0)
    record.states = record.states[:, :9]
    record.belt_speed = record.belt_speed.copy()
    record.belt_speed[5] = np.nan
    with pytest.raises(
        ValueError, match=r"record.states: expected shape \(1201, 18\).*record.belt_speed: has 1"
    ):
        record_to_trial(record, seed=0)


def test_written_trial_round_trips_with_the_true_controller(tmp_path):
    record = make_record()
    Tstar, K, mask = make_controller()
    metadata = synthetic_metadata(
        controller=controller_metadata(Tstar, K, mask, structure="joint-isolated"),
        cycle_speed=1.2,
        cycle_duration=PERIOD,
        body_mass=75.0,
        height=1.8,
        belt={"source": "RandomSlowSpeed1.txt", "mean_speed": 1.2, "deviation_scale": 1.0},
        fell=False,
        message="ok",
    )
    trial = record_to_trial(record, seed=11, metadata=metadata)
    directory = trial.write(tmp_path / "trial")
    back = read_trial(directory)
    np.testing.assert_array_equal(back.time, trial.time)
    written = [c for c in SIGNAL_COLUMNS if c in trial.signals.columns]
    np.testing.assert_array_equal(back.signals[written], trial.signals)
    np.testing.assert_array_equal(back.right_heel_strikes, trial.right_heel_strikes)
    np.testing.assert_array_equal(back.left_heel_strikes, trial.left_heel_strikes)
    Tstar_back, K_back, mask_back = controller_from_metadata(back.metadata)
    np.testing.assert_array_equal(Tstar_back, Tstar)
    np.testing.assert_array_equal(K_back, K)
    np.testing.assert_array_equal(mask_back, mask)
    assert back.metadata["controller"]["num_points"] == 4
    assert back.metadata["controller"]["feedback"][:2] == ["right_hip_angle", "right_knee_angle"]
    assert back.metadata["body_mass"] == 75.0 and back.metadata["height"] == 1.8
    assert back.metadata["cycle"] == {"speed": 1.2, "duration": PERIOD}
    assert back.metadata["belt"]["source"] == "RandomSlowSpeed1.txt"
    assert back.metadata["noise"]["std"] == pytest.approx(DEFAULT_NOISE_STD)
    assert back.metadata["package_versions"]["numpy"] == np.__version__
    # The noise-free truth is not in the file.
    _, truth = true_signals(record)
    assert not np.allclose(back.signals["right_hip_angle"], truth["right_hip_angle"][::2])


def test_controller_metadata_errors():
    Tstar, K, mask = make_controller()
    with pytest.raises(ValueError, match=r"K: expected shape \(4, 6, 12\).*mask: expected a bool"):
        controller_metadata(Tstar, K[:, :, :6], mask.astype(int))
    K_bad = K.copy()
    K_bad[0, 0, 5] = 1.0
    with pytest.raises(ValueError, match="nonzero gains outside mask"):
        controller_metadata(Tstar, K_bad, mask)
    with pytest.raises(KeyError, match=r"'controller' mapping with \['Tstar', 'K', 'mask'\]"):
        controller_from_metadata({"body_mass": 75.0})
    # read back: shapes that disagree are named, not used (issue 13)
    good = controller_metadata(Tstar, K, mask)
    assert [a.shape for a in controller_from_metadata({"controller": good})] == [
        Tstar.shape,
        K.shape,
        mask.shape,
    ]
    cases = [
        ({"K": K[:2].tolist()}, r"'K': expected shape \(P, 6, n_s\) with P = 4"),
        ({"mask": mask[:, :5].tolist()}, r"'mask': expected shape \(6, 12\), found \(6, 5\)"),
        ({"Tstar": [["a"] * 6]}, r"'Tstar': not a numeric array"),
        ({"feedback": ["x"]}, r"'feedback': names 1 signals, K has 12 columns"),
        # written by hand, not by controller_metadata: a gain the structure forbids (issue 32)
        ({"K": K_bad.tolist()}, r"'K': 1 non-zero gains where 'mask' allows none"),
    ]
    for change, message in cases:
        with pytest.raises(ValueError, match=message):
            controller_from_metadata({"controller": {**good, **change}})


# --------------------------------------------------------------------------- workflow


@dataclass
class FakeDesignInfo:
    spectral_radius: float


def fake_pipeline(monkeypatch, calls, spectral_radius=0.5, settle_error=None, failing=None):
    """Replace the expensive steps by synthetic stand-ins that log their arguments.

    ``settle_error`` is raised by every second settle (each P-point controller's walk after a
    full-state one), or by the settles numbered in ``failing`` (from 1) when given."""
    from colloc.control.gain_scheduled import joint_isolated_mask
    from colloc.gait.closed_loop import ClosedLoopRecord
    from colloc.gait.walking_cycle import WalkingCycle

    Tstar, K, mask = make_controller()

    def find_walking_cycle(speed, **kwargs):
        calls.append(("cycle", speed, kwargs))
        times = np.linspace(0.0, PERIOD, 21)
        return WalkingCycle(
            times, np.zeros((21, 18)), np.zeros((21, 6)), np.zeros((21, 8)), speed, PERIOD
        )

    def design_controller(cycle, num_points, **kwargs):
        calls.append(("design", num_points, {**kwargs, "cycle": cycle}))

        class Controller:
            pass

        controller = Controller()
        controller.mask = joint_isolated_mask(6)
        extra = len(kwargs["feedback"]) - K.shape[2]  # other feedback sets: zero gains
        if extra:
            controller.mask = np.pad(controller.mask, ((0, 0), (0, extra)))
            return_K = np.pad(K, ((0, 0), (0, 0), (0, extra)))
        else:
            return_K = K
        radii = spectral_radius if isinstance(spectral_radius, list) else [spectral_radius] * 3
        designs = sum(c[0] == "design" for c in calls)
        return controller, Tstar, return_K, FakeDesignInfo(radii[(designs - 1) % len(radii)])

    def simulate_walking(cycle, Tstar_, K_, duration, belt_speed, **kwargs):
        calls.append(("simulate", duration, belt_speed, kwargs))
        fake = make_record(duration=duration, step=0.01)
        forces = np.column_stack([np.sin(fake.times + k) for k in range(8)])
        return ClosedLoopRecord(
            fake.times,
            fake.states,
            fake.torques,
            forces,
            fake.belt_speed,
            fake.belt_position,
            fake.right_heel_strikes[fake.right_heel_strikes <= duration],
            fake.left_heel_strikes[fake.left_heel_strikes <= duration],
            fake.times / PERIOD,
            False,
            "walked the whole duration",
        )

    class Dynamics:
        @staticmethod
        def build(params):
            calls.append(("dynamics", params.body_mass))
            return "dynamics"

    import colloc.gait.workflow as workflow

    def settle_cycle(cycle, Tstar_, K_, feedback, **kwargs):
        calls.append(("settle", feedback.tolist(), kwargs))
        # every second settle walks the trial's P-point controller (the first the full state)
        number = sum(c[0] == "settle" for c in calls)
        fails = number % 2 == 0 if failing is None else number in failing
        if settle_error is not None and fails:
            raise settle_error
        settled = WalkingCycle(
            cycle.times, cycle.states, cycle.torques, cycle.contact_forces,
            cycle.belt_speed, cycle.duration,
        )  # fmt: skip
        settled.stats = {**cycle.stats, "settled": sum(c[0] == "settle" for c in calls)}
        return settled

    real_animation = workflow.write_animation

    def write_animation(record, geometry, path, seconds):
        # at most half a second of the fake walk: the command line's 5 s are 300 frames and
        # 23 s of drawing a test does not look at (the animation is tested in tests/plot)
        calls.append(("animation", seconds))
        return real_animation(record, geometry, path, min(seconds, 0.5))

    monkeypatch.setattr(workflow, "write_animation", write_animation)
    monkeypatch.setattr(workflow, "settle_cycle", settle_cycle)
    monkeypatch.setattr(workflow, "find_walking_cycle", find_walking_cycle)
    monkeypatch.setattr(workflow, "design_controller", design_controller)
    monkeypatch.setattr(workflow, "simulate_walking", simulate_walking)
    monkeypatch.setattr(workflow, "GaitDynamics", Dynamics)
    return Tstar, K


def test_settings_report_every_bad_field_before_any_work(monkeypatch, tmp_path):
    from colloc.gait.workflow import GaitSimulationSettings, simulate_trial

    calls: list = []
    fake_pipeline(monkeypatch, calls)
    a_file = tmp_path / "file.txt"
    a_file.write_text("x")
    settings = GaitSimulationSettings(
        duration=-1.0, speed=float("nan"), seed=-2, out=a_file, num_points=1,
        noise={"knee": 1.0}, sample_rate=0, cache=3, body_mass=0, height=-1.8,
        perturbed=True, belt_record=tmp_path / "missing.txt", motor_noise=-1.0,
        structure="diagonal", animation_seconds=0, feedback="eyes", num_nodes=5,
    )  # fmt: skip
    expected = [
        "duration", "speed", "sample_rate", "body_mass", "height", "animation_seconds",
        "motor_noise", "seed", "num_points", "num_nodes: expected None (automatic) or an integer from 20 to 400",
        "noise: noise_std: unknown group 'knee'", "cache",
        "structure", "feedback: expected one of ['joints', 'joints+trunk', 'all']",
        "out: expected a directory, found an existing file", "belt_record",
    ]  # fmt: skip
    problems = settings.problems()
    assert len(problems) == len(expected)
    for name, problem in zip(expected, problems, strict=True):
        assert problem.startswith(name), (name, problem)
    with pytest.raises(ValueError, match=r"(?s)invalid gait simulation settings.*duration.*belt"):
        simulate_trial(settings)
    assert calls == []
    assert GaitSimulationSettings(perturbed=False).problems() == []


def test_a_users_folder_named_trial_in_out_is_refused_before_any_work(monkeypatch, tmp_path):
    """The trial goes to <out>/trial/, which replaces only a trial: a folder of that name
    holding the user's own files stops the run before any work and stays as it was."""
    from colloc.gait.workflow import GaitSimulationSettings, simulate_trial

    calls: list = []
    fake_pipeline(monkeypatch, calls)
    (tmp_path / "trial").mkdir()
    (tmp_path / "trial" / "raw.c3d").write_bytes(b"lab data")
    settings = GaitSimulationSettings(duration=3.0, out=tmp_path, perturbed=False)
    (problem,) = settings.problems()
    assert problem.startswith("out: the trial goes to trial/ inside it, but")
    assert "holds 'raw.c3d', which is not part of a trial" in problem
    with pytest.raises(ValueError, match="raw.c3d"):
        simulate_trial(settings)
    assert calls == [] and (tmp_path / "trial" / "raw.c3d").read_bytes() == b"lab data"


def test_publish_moves_nothing_when_a_folder_may_not_be_replaced(tmp_path):
    from colloc.gait.outputs import publish

    staging, out = tmp_path / "staging", tmp_path / "out"
    (staging / "trial").mkdir(parents=True)
    (staging / "summary.json").write_text("{}")
    (out / "trial").mkdir(parents=True)
    (out / "trial" / "mine.txt").write_text("keep")
    with pytest.raises(FileExistsError, match="holds 'mine.txt'"):
        publish(staging, out, ["trial", "summary.json"])
    assert sorted(p.name for p in out.rglob("*")) == ["mine.txt", "trial"]
    assert (staging / "summary.json").exists()


@pytest.mark.parametrize("radius", [1.0, 314.0, float("nan")])
def test_an_unstable_design_is_refused_before_simulating(monkeypatch, tmp_path, radius):
    from colloc.gait.workflow import (
        GaitSimulationSettings,
        UnstableControllerError,
        simulate_trial,
    )

    calls: list = []
    fake_pipeline(monkeypatch, calls, spectral_radius=radius)
    out = tmp_path / "out"
    settings = GaitSimulationSettings(duration=3.0, out=out, perturbed=False, num_points=7)
    with pytest.raises(
        UnstableControllerError,
        match=r"expected a stabilising design \(Floquet spectral radius < 1\), found "
        r"(1|314|nan) .*P = 200 schedule points.*nothing was simulated",
    ):
        simulate_trial(settings)
    # each cycle of AUTO_NUM_NODES was tried, none simulated
    assert [c[0] for c in calls] == ["dynamics", *["cycle", "design"] * 3]
    assert [c[2]["num_nodes"] for c in calls if c[0] == "cycle"] == [60, 100, 160]
    assert not out.exists()
    # A ValueError, so the CLI reports it as an error message, not a traceback.
    assert issubclass(UnstableControllerError, ValueError)


def test_an_unstable_trial_controller_is_refused_after_settling(monkeypatch, tmp_path):
    from colloc.gait.workflow import GaitSimulationSettings, UnstableControllerError, simulate_trial

    calls: list = []
    fake_pipeline(monkeypatch, calls, spectral_radius=[0.2, 3.5, 3.5])
    out = tmp_path / "out"
    settings = GaitSimulationSettings(duration=3.0, out=out, perturbed=False, feedback="joints")
    with pytest.raises(UnstableControllerError, match=r"found 3.5 .*feedback 'joints'"):
        simulate_trial(settings)
    # the P-point controller's own stride is not walked with an unstable design; the finer
    # cycles are tried (their settling designs unstable too: radii 3.5, 3.5, then 0.2 ...),
    # and the design on the first full-state stride is refused
    steps = [c[0] for c in calls]
    assert steps[:6] == ["dynamics", "cycle", "design", "settle", "design", "cycle"]
    assert steps.count("cycle") == 3 and steps[-1] == "design"
    assert "simulate" not in steps
    assert not out.exists()


def test_a_schedule_stride_that_does_not_settle_leaves_the_full_state_stride(monkeypatch, tmp_path):
    from colloc.gait.settle import CycleNotSettledError
    from colloc.gait.workflow import GaitSimulationSettings, simulate_trial

    calls: list = []
    error = CycleNotSettledError("settle_cycle: the last two strides still differ")
    fake_pipeline(monkeypatch, calls, settle_error=error)
    settings = GaitSimulationSettings(
        duration=6.0, out=tmp_path / "out", perturbed=False, animation_seconds=0.5
    )
    result = simulate_trial(settings)
    designs = [c for c in calls if c[0] == "design"]
    # every cycle tried (60, 100, 160 nodes: a settling and a P-point design each), none of
    # their P-point walkers settled: the trial's controller is designed on the first
    # full-state settled stride, and the user told why
    assert [c[2]["num_nodes"] for c in calls if c[0] == "cycle"] == [60, 100, 160]
    assert len(designs) == 7 and designs[-1][2]["cycle"].stats["settled"] == 1
    assert result.trial.metadata["cycle_nodes"] == 60
    assert any(
        "P = 20 controller's own stride was not used" in n and "still differ" in n
        for n in result.notes
    ), result.notes
    assert any(n.startswith("no finer cycle did better: 100 nodes: ") for n in result.notes)
    assert any("still differ" in n for n in result.summary["notes"])


def test_a_schedule_stride_that_does_not_settle_refines_the_cycle(monkeypatch, tmp_path):
    """At 1.35 m/s the 60-node cycle's P = 20 walker did not settle and the controller
    designed on the full-state stride fell 5-8 s into the perturbed belt; the 100-node
    cycle's walker settled and walked. A walker that does not settle is now one node count
    that failed, and the finer cycle is tried before the full-state stride is used."""
    import colloc.gait.workflow as workflow
    from colloc.gait.settle import CycleNotSettledError

    calls: list = []
    error = CycleNotSettledError("settle_cycle: the last two strides still differ")
    # settles: 60 nodes full-state, 60 nodes P-point (fails), 100 nodes full-state, P-point
    fake_pipeline(monkeypatch, calls, settle_error=error, failing={2})
    monkeypatch.setattr(workflow, "find_walking_cycle", _cycles_by_nodes(calls))
    result = _refined_to_100_nodes(workflow, calls, tmp_path / "out")
    designs = [c for c in calls if c[0] == "design"]
    # the trial's controller is designed on the 100-node P-point walker's stride (settle 4)
    stats = designs[-1][2]["cycle"].stats
    assert (stats["nodes"], stats["settled"], stats["cycle_nodes"]) == (100, 4, 100)
    assert "under the P = 20 controller" in stats["source"]
    assert result.trial.metadata["cycle_nodes"] == 100
    assert not any("own stride was not used" in n for n in result.notes)
    assert any(
        n.startswith(
            "the walking cycle was refined to 100 nodes: 60 nodes: the P = 20 "
            "controller's own stride did not settle (settle_cycle: the last two"
        )
        for n in result.summary["notes"]
    ), result.summary["notes"]


def test_a_schedule_that_falls_on_a_constant_belt_is_refused_before_the_walk(monkeypatch, tmp_path):
    """The P-point controller falls on the constant belt at every cycle tried (1.6 m/s at
    P = 20): nothing is simulated or written, and the message says what would help."""
    from colloc.gait.settle import WalkerFellError
    from colloc.gait.workflow import GaitSimulationSettings, UnstableControllerError, simulate_trial

    calls: list = []
    error = WalkerFellError("settle_cycle: the closed loop did not walk 15 strides")
    fake_pipeline(monkeypatch, calls, settle_error=error)
    out = tmp_path / "out"
    settings = GaitSimulationSettings(duration=6.0, out=out, perturbed=False)
    with pytest.raises(UnstableControllerError) as info:
        simulate_trial(settings)
    message = str(info.value)
    assert message.count("does not walk a constant belt") == 3  # 60, 100 and 160 nodes
    assert "a P = 20 schedule cannot hold this speed's stride" in message
    assert "--points" in message and "nothing was simulated" in message
    assert not any(c[0] == "simulate" for c in calls) and not out.exists()


def test_a_schedule_that_falls_is_designed_on_a_finer_schedules_stride(monkeypatch, tmp_path):
    """1.6 m/s at P = 20: designed on the full-state stride the P = 20 walker falls; the
    P = 50 one walks, and P = 20 designed on the P = 50 walker's stride is the trial's."""
    from colloc.gait.settle import WalkerFellError
    from colloc.gait.workflow import ORBIT_LADDER, GaitSimulationSettings, simulate_trial

    calls: list = []
    error = WalkerFellError("settle_cycle: the closed loop did not walk 15 strides")
    fake_pipeline(monkeypatch, calls, settle_error=error, failing={2})
    settings = GaitSimulationSettings(duration=6.0, out=tmp_path / "out", perturbed=False)
    result = simulate_trial(settings)
    designs = [(c[1], c[2]["cycle"].stats.get("settled")) for c in calls if c[0] == "design"]
    # settling (P = 200), P = 20 on the full-state stride (settle 1), P = 50 on it, P = 20 on
    # the P = 50 walker's stride (settle 3), the trial's P = 20 on its own stride (settle 4)
    assert ORBIT_LADDER == (50,)
    assert designs == [(200, None), (20, 1), (50, 1), (20, 3), (20, 4)]
    assert any("stride of the P = 50 controller's walker" in n for n in result.notes)
    assert any(c[0] == "simulate" for c in calls) and not result.fell
    assert (
        "P = 20 controller designed on the stride of the P = 50" in (result.cycle.stats["source"])
    )


def test_belt_input_from_the_measured_record():
    from colloc.gait.settings import GaitSimulationSettings, belt_input

    settings = GaitSimulationSettings(duration=400.0, speed=1.0)
    (times, speed), description = belt_input(settings)
    # Shifted to the new mean, deviations unchanged (record: mean 1.200, sd 0.097 m/s).
    assert times[0] == 0.0 and times[-1] == pytest.approx(400.0)
    assert np.mean(speed[times <= 349.99]) == pytest.approx(1.0, abs=2e-3)
    assert np.std(speed[times <= 349.99]) == pytest.approx(description["record_std_speed"], 0.01)
    assert description["record_mean_speed"] == pytest.approx(1.2, abs=1e-3)
    assert description["source"].endswith("RandomSlowSpeed1.txt")
    constant, described = belt_input(GaitSimulationSettings(perturbed=False, speed=1.3))
    assert constant is None and described == {"source": "constant", "mean_speed": 1.3}


def test_simulate_trial_writes_a_complete_output(monkeypatch, tmp_path):
    import json

    from colloc.gait.walking_cycle import WalkingCycle
    from colloc.gait.workflow import (
        ORBIT_TOLERANCE,
        SETTLE_POINTS,
        GaitSimulationSettings,
        motor_seed,
        simulate_trial,
    )

    calls: list = []
    Tstar, K = fake_pipeline(monkeypatch, calls)
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")  # not ours: must survive
    steps = []
    settings = GaitSimulationSettings(
        duration=6.0, speed=1.1, seed=5, out=out, num_points=4, animation_seconds=0.5,
        structure="joint-isolated", feedback="joints", body_mass=70.0, motor_noise=2.0,
        cache=False,
    )  # fmt: skip
    result = simulate_trial(settings, progress=lambda step, detail: steps.append(step))
    assert steps == [
        "cycle", "settle", "orbit", "design", "simulate", "trial", "figures", "animation",
    ]  # fmt: skip
    cycles = [c for c in calls if c[0] == "cycle"]
    assert len(cycles) == 1 and cycles[0][2]["cache"] is False
    assert cycles[0][2]["num_nodes"] == 60  # the first of AUTO_NUM_NODES settled
    # The settling controller feeds back every state but the hip's place; the trial's the
    # joints.
    designs = [c for c in calls if c[0] == "design"]
    assert designs[0][2]["feedback"].tolist() == list(range(1, 18))
    # Settling always uses SETTLE_POINTS; only the trial's controller takes num_points.
    assert designs[0][1] == SETTLE_POINTS and designs[1][1] == settings.num_points != SETTLE_POINTS
    settles = [c for c in calls if c[0] == "settle"]
    assert settles[0][1] == list(range(1, 18))
    assert designs[1][2]["feedback"].tolist() == [*range(3, 9), *range(12, 18)]
    # The trial's P-point controller walks its own stride (feedback on the joints, the
    # looser orbit tolerance), and the trial's controller is designed on that stride.
    assert settles[1][1] == [*range(3, 9), *range(12, 18)]
    assert settles[1][2]["tol"] == ORBIT_TOLERANCE
    assert designs[1][2]["cycle"].stats["settled"] == 1
    assert designs[2][1] == settings.num_points and designs[2][2]["cycle"].stats["settled"] == 2
    assert designs[2][2]["feedback"].tolist() == [*range(3, 9), *range(12, 18)]
    assert cycles[0][2]["params"].body_mass == 70.0
    simulate = next(c for c in calls if c[0] == "simulate")
    assert simulate[1] == 6.0 and simulate[2][0][-1] == pytest.approx(6.0)
    assert simulate[3]["dynamics"] == "dynamics" and simulate[3]["torque_noise"] == 2.0
    assert simulate[3]["seed"] == motor_seed(5) != 5
    assert sorted(p.name for p in out.iterdir()) == [
        "contact_forces.png", "cycle.npz", "joint_angles.png", "notes.txt", "summary.json",
        "trial", "walking.gif",
    ]  # fmt: skip
    assert set(result.files) == {
        "trial",
        "cycle",
        "joint_angles",
        "contact_forces",
        "animation",
        "summary",
    }
    summary = json.loads((out / "summary.json").read_text())
    record = make_record(duration=6.0, step=0.01)
    assert summary["fell"] is False and result.fell is False
    # Right strikes 0.3 + 1.1 k <= 6 s: k = 0..5, 5 strides; left 0.85 + 1.1 k: 5 strikes.
    assert summary["strides"] == {"right": 5, "left": 4}
    hip = record.states[:, 1]
    assert summary["hip_height_range"] == pytest.approx([hip.min(), hip.max()])
    assert set(summary["wall_times"]) == set(steps)
    assert summary["notes"] == []
    assert summary["cycle"]["cycle_nodes"] == 60
    trial = read_trial(out / "trial")
    Tstar_back, K_back, _ = controller_from_metadata(trial.metadata)
    np.testing.assert_array_equal(Tstar_back, Tstar)
    np.testing.assert_array_equal(K_back, K)
    assert trial.metadata["controller"]["phase_convention"].startswith("causal")
    assert trial.metadata["controller"]["feedback"] == list(
        JOINT_ANGLE_COLUMNS + JOINT_RATE_COLUMNS
    )
    assert trial.metadata["body_mass"] == 70.0
    assert trial.metadata["cycle_nodes"] == 60
    assert trial.metadata["noise"]["seed"] == 5
    assert trial.metadata["belt"]["source"].endswith("RandomSlowSpeed1.txt")
    assert WalkingCycle.from_npz(out / "cycle.npz").duration == PERIOD
    assert (out / "notes.txt").read_text() == "mine"


def test_a_failure_leaves_the_previous_output_untouched(monkeypatch, tmp_path):
    import colloc.gait.workflow as workflow
    from colloc.gait.workflow import GaitSimulationSettings, simulate_trial

    fake_pipeline(monkeypatch, [])
    out = tmp_path / "out"
    settings = GaitSimulationSettings(duration=3.0, out=out, animation_seconds=0.2, seed=1)
    simulate_trial(settings)
    before = {p.name: p.stat().st_mtime_ns for p in out.rglob("*")}
    old_trial = (out / "trial" / "trial.csv").read_bytes()

    def broken(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(workflow, "write_animation", broken)
    with pytest.raises(RuntimeError, match="disk full"):
        simulate_trial(GaitSimulationSettings(duration=3.0, out=out, seed=2))
    assert {p.name: p.stat().st_mtime_ns for p in out.rglob("*")} == before
    assert (out / "trial" / "trial.csv").read_bytes() == old_trial


def test_controller_phase_is_kept_noise_free_when_the_record_has_one(tmp_path):
    from dataclasses import dataclass as _dc

    from colloc.gait.trials import CONTROLLER_PHASE_COLUMN

    base = make_record(duration=3.0)

    @_dc
    class WithPhase(FakeRecord):
        phase: np.ndarray = None  # type: ignore[assignment]

    phase = (base.times - 0.3) / PERIOD  # unwrapped, cycles
    record = WithPhase(**base.__dict__, phase=phase)
    trial = record_to_trial(record, seed=1, sample_rate=100.0)
    expected = np.interp(trial.time, record.times, phase)
    np.testing.assert_allclose(trial.signals[CONTROLLER_PHASE_COLUMN], expected, atol=1e-12)
    assert CONTROLLER_PHASE_COLUMN not in record_to_trial(base, seed=1).signals
    # the extra column survives writing and reading the trial
    from colloc.data import read_trial

    trial.write(tmp_path / "t")
    back = read_trial(tmp_path / "t")
    np.testing.assert_allclose(back.signals[CONTROLLER_PHASE_COLUMN], expected, atol=1e-9)


def test_cli_reports_bad_settings_without_work(monkeypatch, capsys, tmp_path):
    from colloc.cli import main

    calls: list = []
    fake_pipeline(monkeypatch, calls)
    code = main(
        ["gait", "simulate", "--duration", "-1", "--feedback", "eyes", "--out", str(tmp_path)]
    )
    err = capsys.readouterr().err
    assert code == 2 and calls == []
    assert "duration: expected a positive finite number" in err
    assert "feedback: expected one of ['joints', 'joints+trunk', 'all'], found 'eyes'" in err


def test_cli_runs_the_workflow_and_reports_strides(monkeypatch, capsys, tmp_path):
    from colloc.cli import main

    calls: list = []
    fake_pipeline(monkeypatch, calls)
    out = tmp_path / "sim"
    code = main(
        ["gait", "simulate", "--duration", "6", "--feedback", "joints+trunk", "--out", str(out)]
    )
    printed = capsys.readouterr().out
    assert code == 0, printed
    designs = [c for c in calls if c[0] == "design"]
    assert designs[1][2]["feedback"].tolist() == [*range(2, 9), *range(11, 18)]
    # Without --points the trial's controller has the settings' default P (20), the
    # settling controller its own 200.
    assert [d[1] for d in designs] == [200, 20, 20]
    assert "strides: 5 right, 4 left; fell: False (walked the whole duration)" in printed
    assert (out / "summary.json").is_file()
    calls.clear()
    assert main(["gait", "simulate", "--duration", "6", "--points", "7", "--out", str(out)]) == 0
    assert [c[1] for c in calls if c[0] == "design"] == [200, 7, 7]
    simulate = next(c for c in calls if c[0] == "simulate")
    assert simulate[3]["torque_noise"] == 0.0  # no motor noise unless asked for


def test_cli_writes_the_lab_export_of_the_simulated_walk(monkeypatch, capsys, tmp_path):
    from colloc.cli import main
    from colloc.lab import read_lab_export

    calls: list = []
    fake_pipeline(monkeypatch, calls)
    out = tmp_path / "sim"
    assert main(["gait", "simulate", "--duration", "6", "--lab-export", "--out", str(out)]) == 0
    said = capsys.readouterr().out
    for role, name in (
        ("tsv", "lab-export.tsv"),
        ("trc", "lab-export.trc"),
        ("mot", "lab-export_grf.mot"),
        ("c3d", "lab-export.c3d"),
    ):
        assert f"lab export ({role}): {out / name}" in said
    export = read_lab_export(out / "lab-export.tsv")
    from colloc.lab import lab_file_format

    assert lab_file_format(out / "lab-export.c3d") == "C3D"
    assert lab_file_format(out / "lab-export_grf.mot") == "MOT"
    record = next(c for c in calls if c[0] == "simulate")
    assert export.time.size == 601 and sorted(export.plates) == ["FP1", "FP2"]
    assert len(export.markers) == 12 and sorted(export.columns) == [
        "LeftBeltSpeed",
        "RightBeltSpeed",
    ]
    # the fake record's right heel and toe forces (sin(t), sin(t + 2); forward components
    # sin(t + 0), sin(t + 2)) with the default 2 N noise
    forward = np.sin(export.time) + np.sin(export.time + 2)
    assert np.std(export.plates["FP2"][:, 0] - forward) == pytest.approx(2.0, rel=0.15)
    assert record[1] == 6.0


def test_cli_passes_motor_and_sensor_noise(monkeypatch, capsys, tmp_path):
    import json

    from colloc.cli import main

    calls: list = []
    fake_pipeline(monkeypatch, calls)
    out = tmp_path / "sim"
    argv = ["gait", "simulate", "--duration", "6", "--motor-noise", "2.5", "--noise", "0"]
    assert main([*argv, "--out", str(out)]) == 0, capsys.readouterr()
    simulate = next(c for c in calls if c[0] == "simulate")
    assert simulate[3]["torque_noise"] == 2.5
    summary = json.loads((out / "summary.json").read_text())
    assert summary["settings"]["motor_noise"] == 2.5 and summary["settings"]["noise"] == 0.0
    assert main(["gait", "simulate", "--motor-noise", "-1", "--out", str(out)]) == 2
    assert "motor_noise: expected a number from 0 to 100.0" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["--duration", "0.001"], "duration: expected at least 3.0 s (two complete strides"),
        (["--speed", "1e-9"], "speed: expected a walking speed from 0.5 to 2.0 m/s"),
        (
            ["--nodes", "1000000"],
            "num_nodes: expected None (automatic) or an integer from 20 to 400",
        ),
        (["--motor-noise", "1e9"], "motor_noise: expected a number from 0 to 100.0"),
        (["--points", "100000"], "num_points: expected an integer from 2 to 200"),
        (["--out", ""], "argument --out: expected a path, found an empty one"),
    ],
)
def test_gait_simulate_refuses_what_it_cannot_walk_before_any_work(
    flags, message, monkeypatch, capsys, tmp_path
):
    """Each of these used to be accepted and fail 15-45 s later, unclearly (issue 32)."""
    from colloc.cli import main

    calls: list = []
    fake_pipeline(monkeypatch, calls)
    monkeypatch.chdir(tmp_path)
    argv = ["gait", "simulate", "--unperturbed", "--out", str(tmp_path / "o"), *flags]
    try:
        code = main(argv)
    except SystemExit as stop:  # argparse's own refusal (an empty path)
        code = stop.code
    assert code == 2
    assert message in capsys.readouterr().err
    assert calls == [] and not (tmp_path / "o").exists()


def test_the_slowest_walks_start_from_the_finer_cycle():
    """Below 0.85 m/s the 60-node cycle's walker tripped (7 of 20 walks of 480 s at 0.8 m/s
    with 3-5 N m fell) and the 100-node one's walked the same seeds: it is tried first."""
    from colloc.gait.settings import AUTO_NUM_NODES, SLOW_CYCLE_SPEED, GaitSimulationSettings

    assert GaitSimulationSettings(speed=0.8).nodes_to_try() == (100, 160)
    assert GaitSimulationSettings(speed=SLOW_CYCLE_SPEED).nodes_to_try() == AUTO_NUM_NODES
    assert GaitSimulationSettings(speed=1.2).nodes_to_try() == (60, 100, 160)
    assert GaitSimulationSettings(speed=0.8, num_nodes=60).nodes_to_try() == (60,)


def test_joint_isolated_structure_needs_joint_feedback():
    from colloc.gait.settings import GaitSimulationSettings

    bad = GaitSimulationSettings(structure="joint-isolated", feedback="joints+trunk")
    assert bad.problems() == [
        "structure: 'joint-isolated' needs feedback 'joints' (each torque from its own joint's "
        "angle and rate), found feedback 'joints+trunk'"
    ]
    assert GaitSimulationSettings(structure="joint-isolated", feedback="joints").problems() == []


def test_perturbation_scale_shrinks_the_deviations_and_is_validated():
    from colloc.gait.settings import GaitSimulationSettings, belt_input

    (_, full), _ = belt_input(GaitSimulationSettings(duration=300.0))
    (_, half), described = belt_input(
        GaitSimulationSettings(duration=300.0, perturbation_scale=0.5)
    )
    np.testing.assert_allclose(half - 1.2, 0.5 * (full - 1.2), atol=1e-12)
    assert described["deviation_scale"] == 0.5
    (_, flat), _ = belt_input(GaitSimulationSettings(duration=10.0, perturbation_scale=0.0))
    np.testing.assert_allclose(flat, 1.2)
    assert GaitSimulationSettings(perturbation_scale=-0.1).problems() == [
        "perturbation_scale: expected a finite number >= 0, found -0.1"
    ]


def test_a_cycle_that_does_not_settle_is_reported_with_a_hint(monkeypatch, tmp_path):
    import colloc.gait.workflow as workflow
    from colloc.gait.settings import GaitSimulationSettings
    from colloc.gait.settle import CycleNotSettledError

    calls: list = []
    fake_pipeline(monkeypatch, calls)

    def falls(*args, **kwargs):
        raise CycleNotSettledError("settle_cycle: the closed loop did not walk 15 strides")

    monkeypatch.setattr(workflow, "settle_cycle", falls)
    out = tmp_path / "out"
    settings = GaitSimulationSettings(duration=3.0, out=out, perturbed=False, num_nodes=70)
    with pytest.raises(
        CycleNotSettledError,
        match=r"^70 nodes: settle_cycle: .*did not walk 15 strides; .*too coarse.*--nodes\)$",
    ):
        workflow.simulate_trial(settings)
    assert [c[2]["num_nodes"] for c in calls if c[0] == "cycle"] == [70]  # given: alone
    assert not out.exists()


def _refined_to_100_nodes(workflow, calls, out):
    """A 3 s constant-belt trial made into ``out``, its cycle tried at 60 nodes, then 100."""
    from colloc.gait.settings import GaitSimulationSettings

    settings = GaitSimulationSettings(duration=3.0, out=out, perturbed=False, animation_seconds=0.5)
    result = workflow.simulate_trial(settings)
    assert [c[2]["num_nodes"] for c in calls if c[0] == "cycle"] == [60, 100]
    return result


def _cycles_by_nodes(calls):
    """A stand-in for find_walking_cycle whose cycles say their node count (``stats``)."""
    from colloc.gait.walking_cycle import WalkingCycle

    def cycle_of(speed, **kwargs):
        calls.append(("cycle", speed, kwargs))
        n = kwargs["num_nodes"]
        times = np.linspace(0.0, PERIOD, n)
        return WalkingCycle(
            times, np.zeros((n, 18)), np.zeros((n, 6)), np.zeros((n, 8)), speed, PERIOD,
            stats={"nodes": n},
        )  # fmt: skip

    return cycle_of


def test_a_cycle_that_does_not_settle_is_refined_and_the_trial_says_so(monkeypatch, tmp_path):
    import json

    import colloc.gait.workflow as workflow
    from colloc.gait.settle import CycleNotSettledError

    calls: list = []
    fake_pipeline(monkeypatch, calls)

    def falls_when_coarse(cycle, *args, **kwargs):
        if cycle.stats["nodes"] < 100:
            raise CycleNotSettledError("settle_cycle: fell at t = 2.18 s")
        return cycle

    monkeypatch.setattr(workflow, "settle_cycle", falls_when_coarse)
    monkeypatch.setattr(workflow, "find_walking_cycle", _cycles_by_nodes(calls))
    out = tmp_path / "out"
    result = _refined_to_100_nodes(workflow, calls, out)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["cycle"]["cycle_nodes"] == 100
    assert summary["settings"]["num_nodes"] is None
    assert any(
        n.startswith("the walking cycle was refined to 100 nodes: 60 nodes: settle_cycle: fell")
        for n in summary["notes"]
    )
    assert result.trial.metadata["cycle_nodes"] == 100
    assert summary["wall_times"]["cycle"] > 0


def test_a_settling_design_that_breaks_down_refines_the_cycle(monkeypatch, tmp_path):
    """A 60-node cycle whose settling LQR's Riccati recursion overflowed (measured on a
    1.25 m/s cycle with a swing clearance) stopped the whole command with numpy's bare
    'Singular matrix'; it is now one node count that failed, and the finer cycle is tried."""
    import colloc.gait.workflow as workflow
    from colloc.control.periodic_lqr import RiccatiBreakdownError
    from colloc.gait.settings import GaitSimulationSettings

    calls: list = []
    fake_pipeline(monkeypatch, calls)
    fake_design = workflow.design_controller

    def breaks_when_coarse(cycle, num_points, **kwargs):
        if cycle.stats["nodes"] < 100:
            raise RiccatiBreakdownError("sampled_periodic_lqr: ... (S overflowed)")
        return fake_design(cycle, num_points, **kwargs)

    monkeypatch.setattr(workflow, "design_controller", breaks_when_coarse)
    monkeypatch.setattr(workflow, "find_walking_cycle", _cycles_by_nodes(calls))
    out = tmp_path / "out"
    result = _refined_to_100_nodes(workflow, calls, out)
    assert result.trial.metadata["cycle_nodes"] == 100
    assert any(
        "60 nodes: the settling controller's design: sampled_periodic_lqr" in n
        for n in result.summary["notes"]
    )
    # every node count breaking down: the command's error names each
    monkeypatch.setattr(
        workflow,
        "design_controller",
        lambda *a, **k: (_ for _ in ()).throw(RiccatiBreakdownError("overflowed")),
    )
    with pytest.raises(RiccatiBreakdownError, match="60 nodes: .*100 nodes: .*160 nodes: "):
        workflow.simulate_trial(GaitSimulationSettings(duration=3.0, out=tmp_path / "o2"))
    assert not (tmp_path / "o2" / "summary.json").exists()


def test_a_cycle_the_solver_does_not_find_is_one_failed_try(monkeypatch, tmp_path):
    """At 1.17 m/s the 60-node stride fell while settling and the 100-node cycle's solve
    stopped at its iteration limit: that RuntimeError ended the command before the 160-node
    cycle was tried. It is now one node count that failed, named in the trial's notes; with
    ``--nodes N`` alone, or when every count fails, the command's error still says why."""
    import colloc.gait.workflow as workflow
    from colloc.gait.settings import GaitSimulationSettings
    from colloc.gait.settle import CycleNotSettledError

    calls: list = []
    fake_pipeline(monkeypatch, calls)
    by_nodes = _cycles_by_nodes(calls)

    def not_found_at_100(speed, **kwargs):
        if kwargs["num_nodes"] == 100:
            calls.append(("cycle", speed, kwargs))
            raise RuntimeError("walking cycle: IPOPT stopped with Maximum_Iterations_Exceeded")
        return by_nodes(speed, **kwargs)

    def falls_when_coarse(cycle, *args, **kwargs):
        if cycle.stats["nodes"] < 100:
            raise CycleNotSettledError("settle_cycle: fell at t = 0.33 s")
        return cycle

    monkeypatch.setattr(workflow, "settle_cycle", falls_when_coarse)
    monkeypatch.setattr(workflow, "find_walking_cycle", not_found_at_100)
    settings = GaitSimulationSettings(
        duration=3.0, out=tmp_path / "out", perturbed=False, animation_seconds=0.5
    )
    result = workflow.simulate_trial(settings)
    assert [c[2]["num_nodes"] for c in calls if c[0] == "cycle"] == [60, 100, 160]
    assert result.trial.metadata["cycle_nodes"] == 160
    assert any(
        n.startswith("the walking cycle was refined to 160 nodes: 60 nodes: settle_cycle: fell")
        and "100 nodes: the walking cycle: walking cycle: IPOPT stopped with Maximum" in n
        for n in result.summary["notes"]
    ), result.summary["notes"]

    # one node count asked for: its solver's error is the command's, as before
    calls.clear()
    with pytest.raises(RuntimeError, match="Maximum_Iterations_Exceeded"):
        workflow.simulate_trial(
            GaitSimulationSettings(duration=3.0, out=tmp_path / "o2", num_nodes=100)
        )
    assert not (tmp_path / "o2" / "summary.json").exists()

    # every count failing: the error names each
    monkeypatch.setattr(
        workflow,
        "find_walking_cycle",
        lambda speed, **k: (_ for _ in ()).throw(RuntimeError("no cycle")),
    )
    with pytest.raises(RuntimeError, match="60 nodes: .*100 nodes: .*160 nodes: "):
        workflow.simulate_trial(GaitSimulationSettings(duration=3.0, out=tmp_path / "o3"))
    assert not (tmp_path / "o3" / "summary.json").exists()


def test_foot_ground_reactions_sum_each_foot_and_weigh_its_centre_of_pressure():
    from colloc.gait.strikes import foot_ground_reactions

    # heel then toe of the right foot, then of the left: (Fx, Fy) pairs
    forces = np.array([[1.0, 300.0, 2.0, 100.0, -1.0, 5.0, 0.5, 10.0]])
    x = np.array([[0.1, 0.3, -0.2, 0.0]])
    (out,) = foot_ground_reactions(forces, x)
    assert out[:2].tolist() == [3.0, 400.0]
    assert out[2] == pytest.approx((0.1 * 300 + 0.3 * 100) / 400)
    assert out[3:5].tolist() == [-0.5, 15.0]
    assert np.isnan(out[5])  # 15 N < 20 N: unloaded, no centre of pressure


def test_ground_reactions_are_written_with_their_noise_and_read_back_with_gaps(tmp_path):
    import dataclasses

    record = make_record()
    N = record.times.size
    grf = np.column_stack([np.full(N, 10.0), np.full(N, 700.0), np.full(N, 0.4)] * 2)
    grf[: N // 2, 5] = np.nan  # the left foot unloaded for the first half
    grf[: N // 2, 4] = 0.0
    with_grf = dataclasses.replace(record, ground_reactions=grf)
    trial = record_to_trial(with_grf, seed=3, sample_rate=None)
    assert set(GRF_COLUMNS) <= set(trial.signals.columns)
    noise = trial.signals["right_grf_y"].to_numpy() - 700.0
    assert np.std(noise) == pytest.approx(DEFAULT_NOISE_STD["ground_reaction_force"], rel=0.1)
    cop = trial.signals["left_cop_x"].to_numpy()
    assert np.isnan(cop[: N // 2]).all() and np.isfinite(cop[N // 2 :]).all()
    # the older groups' noise is what it was without ground reactions (same seed)
    plain = record_to_trial(record, seed=3, sample_rate=None)
    np.testing.assert_array_equal(
        plain.signals[list(TORQUE_COLUMNS)], trial.signals[list(TORQUE_COLUMNS)]
    )
    back = read_trial(trial.write(tmp_path / "trial"))
    np.testing.assert_array_equal(back.signals["left_cop_x"], trial.signals["left_cop_x"])


def test_a_plate_rate_must_be_a_whole_multiple_of_the_sample_rate():
    from colloc.gait.settings import GaitSimulationSettings

    assert GaitSimulationSettings(plate_rate=1000.0).plate_substeps_exact() == 10
    assert GaitSimulationSettings().plate_substeps_exact() == 1
    for bad in (1050.0, 50.0, float("nan"), 1e6):
        problems = GaitSimulationSettings(plate_rate=bad).problems()
        assert problems == [
            f"plate_rate: expected None or a whole multiple (1 to 20) of sample_rate 100.0 Hz, "
            f"found {bad!r}"
        ]
