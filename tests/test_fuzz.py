"""Seeded fuzzing of what users hand colloc: trial folders, pendulum settings, command lines.

Every outcome must be a valid result or one colloc error naming the problem: a
:class:`colloc.data.checks.TrialError` (or ``FileNotFoundError`` for a missing folder) from
the trial reader, a list of problem sentences from the settings, ``SystemExit(2)`` from the
argument parser, and problem sentences from the pendulum command's checks after parsing.
Any other exception is a defect. Each case is bounded in time; together they
run in well under a minute.
"""

from __future__ import annotations

import contextlib
import io
import re
import shutil
import time
from pathlib import Path

import numpy as np
import pytest

from colloc.cli import build_parser
from colloc.cli.pendulum import pendulum_checks
from colloc.data.checks import TrialError
from colloc.data.trial import read_trial
from colloc.identify.pendulum.settings import PendulumSettings

FIXTURE = Path(__file__).resolve().parent / "data" / "fixtures" / "gait_trial_tsv"
CASE_SECONDS = 5.0

STRANGE = [0, -1, 1e300, -1e300, float("nan"), float("inf"), "abc", "", True, "1e3", "NaN"]


def _mutate_table(text: str, rng: np.random.Generator) -> str:
    """One random corruption of a delimited table."""
    lines = text.splitlines()
    if len(lines) < 2:  # already emptied or truncated by an earlier corruption
        return text
    sep = "\t" if "\t" in lines[0] else ","
    rows = [line.split(sep) for line in lines]
    kind = int(rng.integers(9))
    i = int(rng.integers(1, len(rows)))
    j = int(rng.integers(len(rows[0])))
    if kind == 0:  # a strange cell
        rows[i][j] = str(STRANGE[int(rng.integers(len(STRANGE)))])
    elif kind == 1:  # a column dropped
        rows = [r[:j] + r[j + 1 :] for r in rows]
    elif kind == 2:  # a header renamed
        rows[0][j] = rows[0][j].upper() + "x"
    elif kind == 3:  # rows shuffled
        body = rows[1:]
        rng.shuffle(body)
        rows = [rows[0], *body]
    elif kind == 4:  # truncated
        rows = rows[: int(rng.integers(1, 4))]
    elif kind == 5:  # a ragged row
        rows[i] = rows[i] + ["1", "2"]
    elif kind == 6:  # a column scaled
        for r in rows[1:]:
            with contextlib.suppress(ValueError):
                r[j] = repr(float(r[j]) * float(rng.choice([1000.0, 57.3, -1.0])))
    elif kind == 7:  # a duplicated header
        rows[0][j] = rows[0][(j + 1) % len(rows[0])]
    else:  # empty
        return ""
    return "\n".join(sep.join(r) for r in rows) + "\n"


def _mutate_folder(folder: Path, rng: np.random.Generator) -> None:
    """One to three random corruptions of a trial folder."""
    for _ in range(int(rng.integers(1, 4))):
        target = ["trial.tsv", "events.csv", "metadata.yaml", "extra"][int(rng.integers(4))]
        path = folder / target
        choice = int(rng.integers(6))
        if target == "extra":
            (folder / "trial.csv").write_text("time\n0\n1\n")
        elif choice == 0 and path.exists():
            path.unlink()
        elif choice == 1:
            path.write_bytes(bytes(rng.integers(0, 256, 64, dtype=np.uint8)))
        elif choice == 2 and target == "metadata.yaml":
            path.write_text(
                ["[1, 2", "- a\n- b\n", "sample_rate: -5\n", "units: 3\n", "a: {b: c"][
                    int(rng.integers(5))
                ]
            )
        elif path.exists() and target != "metadata.yaml":
            path.write_text(_mutate_table(path.read_text(errors="replace"), rng))


@pytest.mark.parametrize("seed", range(600))
def test_fuzzed_trial_folders_give_a_trial_or_one_clear_error(tmp_path, seed):
    folder = tmp_path / "trial"
    shutil.copytree(FIXTURE, folder)
    _mutate_folder(folder, np.random.default_rng(seed))
    start = time.perf_counter()
    try:
        trial = read_trial(folder)
    except TrialError as error:
        assert error.problems and all(isinstance(p, str) and p for p in error.problems)
    except FileNotFoundError as error:
        assert str(folder) in str(error) or "does not exist" in str(error)
    else:
        assert trial.problems() == []
    assert time.perf_counter() - start < CASE_SECONDS


FIELDS = {
    "num_links": [1, 2, 0, -3, 2.5, "2", True, None, 10**9],
    "duration": [10.0, 0.0, -1.0, 1e9, float("nan"), float("inf"), "10", None],
    "sample_rate": [50.0, 0.0, -5.0, 1e-3, 1e12, float("nan"), "x"],
    "initial_guess": ["close", "direct", "zero", "bogus", 3, None],
    "scheme": ["midpoint", "backward-euler", "rk4", "", None],
    "noise_std_deg": [0.25, -1.0, float("inf"), "0.1"],
    "force_amplitude": [10.0, 1e300, -1.0, float("nan")],
    "seed": [0, -1, 2**40, 1.5, "7", True],
    "hessian": ["exact", "limited-memory", "newton"],
    "uncertainty": ["sandwich", "kkt", "bootstrap"],
    "process_noise": [0.0, 1.0, -2.0, float("inf")],
    "noise_model": [True, False, "yes", 1],
}


@pytest.mark.parametrize("seed", range(200))
def test_fuzzed_pendulum_settings_give_problems_never_an_exception(seed):
    rng = np.random.default_rng(1000 + seed)
    chosen = {
        name: values[int(rng.integers(len(values)))]
        for name, values in FIELDS.items()
        if rng.random() < 0.6
    }
    settings = PendulumSettings(**chosen)
    problems = settings.problems()
    assert isinstance(problems, list) and all(isinstance(p, str) and p for p in problems)
    if not problems:  # a valid run can be sized without error
        assert settings.estimated_needs()["memory_bytes"] > 0
        assert isinstance(settings.too_big(24 * 2**30), list)


FLAGS = [
    "-n",
    "-d",
    "-s",
    "-i",
    "-r",
    "-p",
    "-a",
    "--scheme",
    "--hessian",
    "--seed",
    "--amplitude",
    "--noise-std",
    "--process-noise",
    "--input-noise",
    "--uncertainty",
    "--json",
    "--db",
    "--out",
    "--no-store",
    "--noise-model",
    "--bogus",
    "list",
    "--kind",
    "--yes",
]
VALUES = ["1", "-1", "0", "1e300", "nan", "inf", "abc", "", "close", "/proc/x", "--", "2.5"]


@pytest.mark.parametrize("seed", range(200))
def test_fuzzed_command_lines_parse_or_exit_2(seed):
    rng = np.random.default_rng(5000 + seed)
    command = [["pendulum"], ["runs"], ["runs", "list"], ["cache"], ["gait", "identify"]][
        int(rng.integers(5))
    ]
    argv = list(command)
    for _ in range(int(rng.integers(0, 6))):
        argv.append(FLAGS[int(rng.integers(len(FLAGS)))])
        if rng.random() < 0.7:
            argv.append(VALUES[int(rng.integers(len(VALUES)))])
    parser = build_parser()
    with contextlib.redirect_stderr(io.StringIO()) as err:
        try:
            args = parser.parse_args(argv)
        except SystemExit as exit_:
            assert exit_.code == 2
            assert "error:" in err.getvalue()
            return
    if args.command == "pendulum":  # what the command checks before any work
        _, problems = pendulum_checks(args)
        assert all(isinstance(p, str) and p for p in problems)


@pytest.mark.parametrize("seed", range(200))
def test_fuzzed_pendulum_command_lines_are_checked_without_an_exception(seed):
    """Only values the parser accepts, so every case reaches the checks after parsing."""
    rng = np.random.default_rng(9000 + seed)
    numbers = ["1", "0", "-1", "2.5", "1e300", "-1e9", "nan", "inf", "1e9", "0.1", "3"]
    argv = ["pendulum"]
    for flag in ["-n", "-d", "-s", "--seed", "--amplitude", "--noise-std", "--process-noise"]:
        if rng.random() < 0.6:
            argv += [flag, numbers[int(rng.integers(len(numbers)))]]
    for flag in ["-r", "-p", "-a", "--noise-model"]:
        if rng.random() < 0.5:
            argv.append(flag)
    if rng.random() < 0.3:
        argv += ["--json", ["/proc/x.json", "/", "s.json"][int(rng.integers(3))]]
    with contextlib.redirect_stderr(io.StringIO()):
        try:
            args = build_parser().parse_args(argv)
        except SystemExit as exit_:
            assert exit_.code == 2  # e.g. "-n 2.5": not an integer
            return
    settings, problems = pendulum_checks(args)
    assert all(isinstance(p, str) and p for p in problems)
    if not problems:  # a run that may start can be sized
        assert settings.estimated_needs()["memory_bytes"] < 24 * 2**40


GAIT_SIMULATE_FLAGS = [
    "--duration",
    "--speed",
    "--seed",
    "--points",
    "--nodes",
    "--motor-noise",
    "--noise",
    "--perturbation-scale",
]
GAIT_IDENTIFY_FLAGS = [
    "--fit-fraction",
    "--points",
    "--start",
    "--duration",
    "--segment-nodes",
    "--max-iter",
    "--seed",
    "--process-noise",
    "--workers",
    "--window-strides",
]
GAIT_NUMBERS = [
    "1",
    "0",
    "-1",
    "2.5",
    "1e300",
    "-1e9",
    "nan",
    "inf",
    "1e6",
    "0.75",
    "3",
    "1,2",
    "0.001",  # the values of issue 32's list, which failed 15-45 s into the work
    "1e-9",
    "1000000",
    "1e9",
    "100000",
    "1.2",
    "60",
]
GAIT_CHOICES = {
    "--structure": ["full", "joint-isolated", "bogus"],
    "--feedback": ["all", "joints", "joints+trunk", "metadata", "x"],
    "--track": ["angles", "angles,trunk,torques", "torques", "angles,angles", ",", "bogus"],
    "--scheme": ["midpoint", "backward-euler", "rk4"],
}


@pytest.mark.parametrize("seed", range(150))
def test_fuzzed_gait_command_lines_are_checked_without_an_exception(seed, tmp_path):
    """``colloc gait simulate|identify``: the parser's exit 2, or the checks after parsing
    give problem sentences (a trial too big for the machine among them) and nothing else."""
    from colloc.cli.gait import gait_identify_checks, gait_simulate_checks

    rng = np.random.default_rng(13000 + seed)
    simulate = bool(rng.integers(2))
    argv = ["gait", "simulate"] if simulate else ["gait", "identify"]
    if not simulate:
        argv.append([str(FIXTURE), str(tmp_path / "missing"), "/proc/x"][int(rng.integers(3))])
    for flag in GAIT_SIMULATE_FLAGS if simulate else GAIT_IDENTIFY_FLAGS:
        if rng.random() < 0.5:
            argv += [flag, GAIT_NUMBERS[int(rng.integers(len(GAIT_NUMBERS)))]]
    for flag, choices in GAIT_CHOICES.items():
        if simulate and flag in ("--track", "--scheme"):
            continue  # identification only
        if rng.random() < 0.3:
            argv += [flag, choices[int(rng.integers(len(choices)))]]
    if simulate and rng.random() < 0.4:
        argv.append("--unperturbed")
    if not simulate and rng.random() < 0.3:  # a scheduler, with or without --workers
        argv += ["--scheduler", ["tcp://127.0.0.1:1", "garbage", ""][int(rng.integers(3))]]
    argv += [
        "--out",
        [str(tmp_path / "o"), "/proc/x", str(FIXTURE / "trial.tsv")][int(rng.integers(3))],
    ]
    with contextlib.redirect_stderr(io.StringIO()) as err:
        try:
            args = build_parser().parse_args(argv)
        except SystemExit as exit_:
            assert exit_.code == 2 and "error:" in err.getvalue()
            return
    started = time.perf_counter()
    checks = gait_simulate_checks if simulate else gait_identify_checks
    settings, problems = checks(args)
    assert time.perf_counter() - started < CASE_SECONDS
    assert all(isinstance(p, str) and p for p in problems)
    if simulate and not problems:  # a simulation that may start fits the machine and its ranges
        _assert_a_simulation_that_may_start(settings)
    assert not (tmp_path / "o").exists()  # checking writes nothing


def _assert_a_simulation_that_may_start(settings) -> None:
    """It lies in the ranges the simulation works in, and fits the machine."""
    from colloc.gait import settings as gait_settings

    assert settings.duration >= gait_settings.MIN_DURATION
    low, high = gait_settings.SPEED_RANGE
    assert low <= settings.speed <= high
    nodes = settings.num_nodes  # None: the automatic refinement, at most its last
    assert (max(gait_settings.AUTO_NUM_NODES) if nodes is None else nodes) <= (
        gait_settings.MAX_NUM_NODES
    )
    assert settings.num_points <= gait_settings.MAX_NUM_POINTS
    assert 0 <= settings.motor_noise <= gait_settings.MAX_MOTOR_NOISE
    assert settings.estimated_needs()["memory_bytes"] < 24 * 2**30


@pytest.mark.parametrize("flag", GAIT_SIMULATE_FLAGS)
def test_each_gait_simulate_number_alone_is_refused_by_name_or_lies_in_its_range(flag, tmp_path):
    """One flag at a time, the rest at their defaults: every value either passes the checks
    and lies in the range the simulation works in, or a problem names the flag."""
    from colloc.cli.gait import gait_simulate_checks

    passed = 0
    for value in GAIT_NUMBERS:
        argv = ["gait", "simulate", flag, value, "--out", str(tmp_path / "o")]
        with contextlib.redirect_stderr(io.StringIO()) as err:
            try:
                args = build_parser().parse_args(argv)
            except SystemExit as exit_:
                assert exit_.code == 2 and flag in err.getvalue(), (value, err.getvalue())
                continue
        settings, problems = gait_simulate_checks(args)
        if problems:
            name = flag.lstrip("-").replace("-", "_").split("_")[0]
            assert any(name in p for p in problems), (value, problems)
            continue
        passed += 1
        _assert_a_simulation_that_may_start(settings)
    assert passed >= 1  # some value of each flag is a run
    assert not (tmp_path / "o").exists()


BELT = Path(__file__).resolve().parents[1] / "src" / "colloc" / "gait" / "reference"


def _record_cases(tmp_path: Path) -> list[tuple[str, Path, object]]:
    """(name, a short copy of a real record, its reader) for the record readers."""
    from colloc.data import read_belt_perturbation, read_vertical_grf, read_winter_gait_cycle

    belt = tmp_path / "belt.txt"
    belt.write_text("\n".join((BELT / "RandomSlowSpeed1.txt").read_text().splitlines()[:40]))
    grf = tmp_path / "grf.csv"
    grf.write_text("".join(f"{534.1 + 0.01 * i:.4f},{200.0 + 10 * i:.3f}\n" for i in range(30)))
    cases: list[tuple[str, Path, object]] = [
        ("belt", belt, read_belt_perturbation),
        ("grf", grf, read_vertical_grf),
    ]
    copy = tmp_path / "winter.csv"
    copy.write_bytes((BELT / "Winter_normal.csv").read_bytes())
    cases.append(("winter", copy, read_winter_gait_cycle))
    return cases


@pytest.mark.parametrize("seed", range(100))
def test_fuzzed_belt_and_force_records_give_arrays_or_one_error_naming_the_file(tmp_path, seed):
    rng = np.random.default_rng(17000 + seed)
    cases = _record_cases(tmp_path)
    name, path, reader = cases[int(rng.integers(len(cases)))]
    if rng.random() < 0.15:
        path.write_bytes(bytes(rng.integers(0, 256, 80, dtype=np.uint8)))
    else:
        text = path.read_text(encoding="utf-8-sig")
        for _ in range(int(rng.integers(1, 4))):
            text = _mutate_table(text, rng)
        path.write_text(text)
    started = time.perf_counter()
    try:
        result = reader(path)
    except ValueError as error:  # the readers' one error: it names the file
        assert str(path) in str(error), (name, error)
    else:
        arrays = result if isinstance(result, tuple) else (result.hip, result.knee)
        for array in arrays:
            assert isinstance(array, np.ndarray) and np.all(np.isfinite(array))
    assert time.perf_counter() - started < CASE_SECONDS


_SHARED = [3, 4]
BATCH_VALUES = [
    1,
    0,
    -1,
    2.5,
    "abc",
    "",
    None,
    True,
    [1, 2],
    {"range": [0, 2]},
    {"values": []},
    {"glob": "*"},
    {"range": "x"},
    {"bogus": 1},
    "{seed}",
    "{nope}",
    1e300,
    float("nan"),
    float("inf"),
    "{seed.__class__.__name__}",
    {"range": [0, 10**30]},
    {"range": [0, 40]},
    _SHARED,  # the same object twice in a document: YAML writes an anchor and an alias
    {"values": _SHARED},
]
BATCH_KEYS = [
    "numlinks",
    "duration",
    "seed",
    "sensornoise",
    "out",
    "trial",
    "noise",
    "db",
    "bogus",
    "points",
    "samplerate",
    "json",
    "kind",
    3,
    "numlink",  # prefixes of options: argparse matched them (issue 32 item 9)
    "dur",
    "no-s",
    "rep",
    "help",
    "no-store",
    "db-allow-other-tables",
]

_BOMB = "".join(
    [f"b0: &b0 [{', '.join(['lol'] * 9)}]\n"]
    + [f"b{i}: &b{i} [{', '.join([f'*b{i - 1}'] * 9)}]\n" for i in range(1, 9)]
)


@pytest.mark.parametrize("seed", range(150))
def test_fuzzed_batch_files_give_tasks_or_problems_never_another_exception(
    seed, tmp_path, monkeypatch
):
    import yaml

    from colloc.batch import BatchSpecError, read_batch_spec
    from colloc.cli.batch import KINDS, build_tasks

    monkeypatch.chdir(tmp_path)
    rng = np.random.default_rng(21000 + seed)
    runs = []
    for _ in range(int(rng.integers(0, 4))):
        run = {
            "kind": ["pendulum", "gait-simulate", "gait-identify", "rocket"][int(rng.integers(4))]
        }
        for _ in range(int(rng.integers(0, 5))):
            key = BATCH_KEYS[int(rng.integers(len(BATCH_KEYS)))]
            run[key] = BATCH_VALUES[int(rng.integers(len(BATCH_VALUES)))]
        runs.append(run)
    document = {"runs": runs} if rng.random() < 0.9 else runs
    path = tmp_path / "batch.yaml"
    text = yaml.safe_dump(document)
    if rng.random() < 0.1:  # an alias bomb beside (or instead of) the runs
        text = _BOMB + text + ("x: *b8\n" if isinstance(document, dict) else "")
    path.write_text(text)
    started = time.perf_counter()
    try:
        entries = read_batch_spec(path, tuple(KINDS)).entries
    except BatchSpecError as error:
        assert error.problems and all(isinstance(p, str) and p for p in error.problems)
        entries = error.partial.entries if error.partial else []
    tasks, found = build_tasks(entries)
    assert all(isinstance(p, str) and p.startswith("runs[") for p in found)
    made = {task.position for task in tasks}
    named = {int(m) for p in found for m in re.findall(r"entry (\d+)\)", p)}
    for entry in entries:  # each entry became a task, or a problem names it
        assert entry.position in made or entry.position in named
    assert time.perf_counter() - started < CASE_SECONDS


def _pendulum_with_known_torque():
    """A point-mass pendulum from Kane's method, its torque a known input."""
    import sympy as sm
    from sympy.physics.mechanics import KanesMethod, Particle, Point, ReferenceFrame, dynamicsymbols

    from colloc import Model

    theta, omega, torque = dynamicsymbols("theta omega T")
    mass, length, g = sm.symbols("m l g")
    N = ReferenceFrame("N")
    A = N.orientnew("A", "Axis", (theta, N.z))
    A.set_ang_vel(N, omega * N.z)
    origin = Point("O")
    origin.set_vel(N, 0)
    bob = origin.locatenew("P", -length * A.y)
    bob.v2pt_theory(origin, N, A)
    kane = KanesMethod(N, [theta], [omega], kd_eqs=[theta.diff() - omega])
    kane.kanes_equations([Particle("bob", bob, mass)], [(bob, -mass * g * N.y), (A, torque * N.z)])
    return Model.from_kane(kane, known_inputs=[torque]), theta, torque, (mass, length, g)


API_DATA = [
    "text",
    "1,2,3",
    None,
    float("nan"),
    [1.0, 2.0],
    np.zeros(11),
    np.zeros((11, 2)),
    np.full(11, np.nan),
    np.full(11, np.inf),
    np.zeros(11, dtype=complex),
    {"a": 1},
]
API_NUMBERS = [1.0, -1.0, 0.0, float("nan"), float("inf"), -1e-9, 1e300, "1", None, True]


@pytest.mark.parametrize("seed", range(120))
def test_fuzzed_problem_definitions_give_a_problem_or_a_named_error(seed):
    """The API cases of issue 32 item 15 and their neighbours: known trajectories keyed by
    text, weights NaN, data as text, negative or odd known values. Every outcome is a built
    problem or a colloc error naming what was wrong (never another exception, never a
    negative mass that builds)."""
    from colloc import ModelError, Problem, Tracking

    model, theta, torque, (mass, length, g) = _pendulum_with_known_torque()
    rng = np.random.default_rng(31000 + seed)
    times = np.linspace(0.0, 1.0, 11)

    def pick(options):
        return options[int(rng.integers(len(options)))]

    key = pick([torque, "T", theta, "theta", 3])
    known_trajectories = {key: pick([*API_DATA, np.sin(times)])}
    track_key = pick([theta, "theta", torque])
    weight = pick([1.0, *API_NUMBERS])
    known = {mass: pick(API_NUMBERS), length: pick([0.7, *API_NUMBERS]), g: 9.81}
    started = time.perf_counter()
    try:
        tracking = Tracking(
            {track_key: pick([*API_DATA, np.cos(times)])}, weights={track_key: weight}
        )
        problem = Problem(
            model,
            times,
            known_trajectories=known_trajectories,
            known_parameters=known,
            objective=tracking,
            cache=False,
        )
    except (ModelError, ValueError, TypeError, KeyError) as error:
        message = str(error)
        assert message and "Traceback" not in message
        named = ("known", "tracking", "weight", "theta", "T", "m", "l", "mass", "objective")
        assert any(word in message for word in named), message
    else:
        value = known[mass]
        assert isinstance(value, int | float) and not value < 0, known  # a negative mass built
        assert problem.layout.num_variables > 0
    assert time.perf_counter() - started < CASE_SECONDS


LAB_FLAGS = ["--mass", "--height", "--belt-speed", "--cutoff", "--max-gap", "--strike-threshold"]
LAB_NAMED = {
    "--plates": ["right=FP2,left=FP1", "right=FP1,left=FP1", "right=,left=FP1", "x"],
    "--prefixes": ["right=R,left=L", "right=R,left=R", "right=R"],
    "--forward": ["+x", "-z", "+y", "up", ""],
}


@pytest.mark.parametrize("seed", range(80))
def test_fuzzed_trial_from_lab_command_lines_are_checked_without_an_exception(seed, tmp_path):
    """``colloc gait trial-from-lab``: the parser's exit 2, or its checks' problem sentences
    before any work; nothing is written and no input is touched."""
    from colloc.cli.lab import trial_from_lab_checks

    rng = np.random.default_rng(17000 + seed)
    export = tmp_path / "export.tsv"
    export.write_text("time\tRHEE.PosX\tRHEE.PosY\n0\t0\t0\n0.01\t0\t0\n")
    argv = ["gait", "trial-from-lab", str(export)]
    for flag in LAB_FLAGS:
        if rng.random() < 0.7:
            argv += [flag, GAIT_NUMBERS[int(rng.integers(len(GAIT_NUMBERS)))]]
    for flag, choices in LAB_NAMED.items():
        if rng.random() < 0.3:
            argv += [flag, choices[int(rng.integers(len(choices)))]]
    out = [str(tmp_path / "t"), str(tmp_path), "/proc/x", str(export), str(export / "t")]
    argv += ["--out", out[int(rng.integers(len(out)))]]
    if rng.random() < 0.5:
        argv.append("--overwrite")
    with contextlib.redirect_stderr(io.StringIO()) as err:
        try:
            args = build_parser().parse_args(argv)
        except SystemExit as exit_:
            assert exit_.code == 2 and "error:" in err.getvalue()
            return
    started = time.perf_counter()
    _, problems = trial_from_lab_checks(args)
    assert time.perf_counter() - started < CASE_SECONDS
    assert all(isinstance(p, str) and p for p in problems)
    assert export.read_text().startswith("time") and not (tmp_path / "t").exists()
