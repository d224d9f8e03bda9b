"""Batch files: sweeps, templates, and every problem of every entry reported at once."""

from __future__ import annotations

from pathlib import Path

import pytest

from colloc.batch import BatchSpecError, expand_batch, read_batch_spec, task_key
from colloc.cli import build_parser
from colloc.cli.batch import KINDS, build_tasks, entry_argv
from colloc.cli.pendulum import pendulum_checks

KIND_NAMES = tuple(KINDS)


def test_sweeps_expand_to_every_combination_with_templates_filled(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for name in ("b", "a"):
        (tmp_path / f"trial-{name}").mkdir()
    raw = {
        "runs": [
            {
                "kind": "pendulum",
                "seed": {"range": [0, 6, 2]},
                "numlinks": {"values": [1, 2]},
                "out": "res/n{numlinks}-s{seed}",
            },
            {"kind": "gait-identify", "trial": {"glob": "trial-*"}, "out": "{trial}-fit"},
        ],
        "workers": 2,
    }
    spec = expand_batch(raw, KIND_NAMES)
    pendulum = [e for e in spec.entries if e.kind == "pendulum"]
    assert [(e.options["seed"], e.options["numlinks"]) for e in pendulum] == [
        (0, 1),
        (0, 2),
        (2, 1),
        (2, 2),
        (4, 1),
        (4, 2),
    ]
    assert pendulum[3].options["out"] == "res/n2-s2"
    gait = [e for e in spec.entries if e.kind == "gait-identify"]
    assert [e.options["trial"] for e in gait] == ["trial-a", "trial-b"]  # sorted matches
    assert gait[0].options["out"] == "trial-a-fit"
    assert [e.position for e in spec.entries] == list(range(8)) and spec.workers == 2


def test_every_problem_of_the_file_is_listed_at_once():
    raw = {
        "runs": [
            {"kind": "rocket"},
            {"kind": "pendulum", "seed": {"range": [0]}},
            {"kind": "pendulum", "seed": {"every": 2}},
            {"kind": "pendulum", "out": "r-{missing}"},
            {"kind": "pendulum", "trial": {"glob": "/nonexistent/*"}},
            {"kind": "pendulum", "seed": 3},
            "numlinks: 1",
        ],
        "workers": 0,
        "dbb": "x",
    }
    with pytest.raises(BatchSpecError) as caught:
        expand_batch(raw, KIND_NAMES)
    text = str(caught.value)
    for expected in (
        "'dbb': unknown key",
        "workers: expected an integer >= 1, found 0",
        "runs[0].kind: expected one of ['pendulum', 'gait-simulate', 'gait-identify'], "
        "found 'rocket'",
        "runs[1].seed: range expects [start, stop]",
        "runs[2].seed: a sweep is a mapping with one key of ['range', 'values', 'glob']",
        "runs[3].out: the template 'r-{missing}' cannot be filled",
        "runs[4].trial: the sweep {'glob': '/nonexistent/*'} gives no values",
        "runs[6]: expected a mapping of options",
    ):
        assert expected in text
    assert len(caught.value.problems) == 8
    # only the sound run expanded: no follow-on problems from the others
    assert [e.options for e in caught.value.partial.entries] == [{"seed": 3}]


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (b"runs: [\n", "not valid YAML"),
        ("runs:\n  - kind: pendulum\n    note: J\xfcrgen\n".encode("latin-1"), "not UTF-8"),
        (b"- kind: pendulum\n", "expected a mapping with a list 'runs', found list"),
        (b"runs: []\n", "runs: expected a non-empty list"),
        (b"!!python/object:os.system {}\n", "not valid YAML"),  # safe_load refuses objects
        (
            b"runs:\n  - kind: pendulum\n    seed: 4\n    seed: 5\n",
            r"not valid YAML \(found the key 'seed' twice \(lines 3 and 4\)",
        ),
    ],
)
def test_a_bad_file_names_itself_and_what_is_wrong(tmp_path, content, message):
    path = tmp_path / "batch.yaml"
    path.write_bytes(content)
    with pytest.raises(BatchSpecError, match=message) as caught:
        read_batch_spec(path, KIND_NAMES)
    assert str(path) in str(caught.value)


def test_entry_command_lines_are_those_of_the_command():
    assert entry_argv(
        "pendulum", {"numlinks": 2, "sensornoise": True, "plot": False, "seed": None}
    ) == ["pendulum", "--numlinks", "2", "--sensornoise"]
    assert entry_argv("gait-identify", {"trial": "t1", "track": ["angles", "trunk"]}) == [
        "gait",
        "identify",
        "t1",
        "--track",
        "angles,trunk",
    ]


def test_entries_get_the_commands_own_checks_named_by_entry(tmp_path):
    spec = expand_batch(
        {
            "runs": [
                {"kind": "pendulum", "duration": 0.1, "out": str(tmp_path)},
                {"kind": "pendulum", "numlinks": "two"},
                {"kind": "pendulum", "no-store": True},
            ]
        },
        KIND_NAMES,
    )
    tasks, problems = build_tasks(spec.entries)
    _, direct = pendulum_checks(build_parser().parse_args(["pendulum", "--duration", "0.1"]))
    assert problems[0] == f"runs[0] (pendulum, entry 0): {direct[0]}"
    assert problems[1].startswith("runs[1] (pendulum, entry 1): argument -n/--numlinks")
    assert "['no-store'] are set for the whole batch" in problems[2]
    assert len(problems) == 3 and tasks == []  # an entry with a problem makes no task


def test_option_names_are_exact_not_prefixes(tmp_path):
    """argparse matched prefixes: ``numlink: 2`` ran 2 links and ``no-s: true`` slipped past
    the per-entry ban on ``no-store``; ``rep: 3`` was ignored (issue 32 item 9)."""
    spec = expand_batch(
        {
            "runs": [
                {"kind": "pendulum", "numlink": 2},
                {"kind": "pendulum", "no-s": True},
                {"kind": "pendulum", "rep": 3},
                {"kind": "pendulum", "numlinks": 2, "out": str(tmp_path)},
            ]
        },
        KIND_NAMES,
    )
    tasks, problems = build_tasks(spec.entries)
    assert len(problems) == 3 and len(tasks) == 1
    for i, name in enumerate(("--numlink", "--no-s", "--rep")):
        assert problems[i].startswith(f"runs[{i}] (pendulum, entry {i}): ")
        assert f"unrecognized arguments: {name}" in problems[i]


def test_a_simulated_trial_feeds_the_identification_that_reads_it(tmp_path):
    trial = tmp_path / "trials" / "seed-1"
    spec = expand_batch(
        {
            "runs": [
                {"kind": "gait-simulate", "duration": 5, "seed": 1, "out": str(trial)},
                {"kind": "gait-identify", "trial": str(trial / "trial"), "no-plots": True},
                {"kind": "gait-identify", "trial": str(tmp_path / "absent"), "no-plots": True},
                {"kind": "gait-identify", "trial": str(trial), "no-plots": True},
            ]
        },
        KIND_NAMES,
    )
    tasks, problems = build_tasks(spec.entries)
    assert tasks[1].after == (0,)  # runs once the simulation has written the trial
    assert problems == [
        f"runs[2] (gait-identify, entry 2): trial: expected an existing directory, found "
        f"{str(tmp_path / 'absent')!r}",
        f"runs[3] (gait-identify, entry 3): trial {str(trial)!r} is the output folder of the "
        f"simulation of entry 0; its trial is {str(trial / 'trial')!r}",
    ]


def test_two_entries_writing_the_same_place_are_refused(tmp_path):
    spec = expand_batch(
        {
            "runs": [
                {
                    "kind": "pendulum",
                    "seed": {"range": [0, 2]},
                    "plot": True,
                    "out": str(tmp_path / "figures"),
                }
            ]
        },
        KIND_NAMES,
    )
    _, problems = build_tasks(spec.entries)
    assert problems == [
        f"runs[0] (pendulum, entry 1): writes into {str(tmp_path / 'figures')!r} as entry 0 "
        "does; give each entry its own (e.g. out: 'results/seed-{seed}')"
    ]


def test_task_keys_follow_what_determines_the_run():
    a = task_key("pendulum", {"seed": 1, "num_links": 1}, {})
    assert a == task_key("pendulum", {"num_links": 1, "seed": 1}, {})  # order-free
    assert a != task_key("pendulum", {"seed": 2, "num_links": 1}, {})
    assert a != task_key("pendulum", {"seed": 1, "num_links": 1}, {"trial": "x"})
    assert a != task_key("gait-identify", {"seed": 1, "num_links": 1}, {})


def test_batch_paths_in_the_spec_are_relative_to_the_working_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "t").mkdir()
    spec = expand_batch({"runs": [{"kind": "gait-identify", "trial": {"glob": "t"}}]}, KIND_NAMES)
    assert Path(spec.entries[0].options["trial"]) == Path("t")


def test_an_identification_of_a_batch_made_trial_is_keyed_by_the_simulation(tmp_path):
    """Change the simulation and the identification of its trial is new work too."""
    trial = tmp_path / "t"
    keys = []
    for seed in (1, 2):
        spec = expand_batch(
            {
                "runs": [
                    {"kind": "gait-simulate", "duration": 5, "seed": seed, "out": str(trial)},
                    {"kind": "gait-identify", "trial": str(trial / "trial"), "no-plots": True},
                ]
            },
            KIND_NAMES,
        )
        tasks, problems = build_tasks(spec.entries)
        assert problems == []
        keys.append(tasks[1].key)
    assert keys[0] != keys[1]


def _bomb(levels: int = 9) -> str:
    """Billion laughs: each level is nine aliases of the one before."""
    lines = ["l0: &l0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    for i in range(1, levels):
        lines.append(f"l{i}: &l{i} [" + ", ".join([f"*l{i - 1}"] * 9) + "]")
    return "\n".join(lines)


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (_bomb() + "\nruns:\n  - kind: pendulum\n    seed: {values: *l8}\n", "alias bomb"),
        (_bomb() + "\nruns:\n  - kind: pendulum\n    note: *l8\n", "alias bomb"),
        ("runs: &r\n  - kind: pendulum\n    seed: *r\n", "contains itself"),
        ("runs: " + "[" * 3000 + "]" * 3000 + "\n", "nested too deeply"),
        ("runs: " + "[" * 80 + "]" * 80 + "\n", "nested 81 levels deep"),
    ],
    ids=["bomb-in-sweep", "bomb-as-value", "recursive", "deeper-than-the-parser", "deep"],
)
def test_an_oversized_document_is_refused_before_it_is_walked(tmp_path, content, message):
    import time

    path = tmp_path / "batch.yaml"
    path.write_text(content)
    started = time.perf_counter()
    with pytest.raises(BatchSpecError, match=message) as caught:
        read_batch_spec(path, KIND_NAMES)
    assert str(path) in str(caught.value)
    assert time.perf_counter() - started < 10  # the bomb hung for ever


def test_anchors_and_aliases_of_a_normal_size_still_work(tmp_path):
    path = tmp_path / "batch.yaml"
    path.write_text(
        "common: &c [0, 1]\nruns:\n  - kind: pendulum\n    seed: {values: *c}\n"
        "  - kind: pendulum\n    numlinks: 2\n    seed: {values: *c}\n"
    )
    with pytest.raises(BatchSpecError, match="'common': unknown key"):
        read_batch_spec(path, KIND_NAMES)  # the anchor's home is an unknown top key
    path.write_text(
        "runs:\n  - kind: pendulum\n    seed: {values: &c [0, 1]}\n"
        "  - kind: pendulum\n    numlinks: 2\n    seed: {values: *c}\n"
    )
    assert len(read_batch_spec(path, KIND_NAMES).entries) == 4


def test_combinations_are_counted_before_they_are_built():
    import time

    started = time.perf_counter()
    with pytest.raises(
        BatchSpecError, match=r"100000 \(seed\) x 100000 \(duration\) = 10000000000"
    ):
        expand_batch(
            {
                "runs": [
                    {
                        "kind": "pendulum",
                        "seed": {"range": [0, 100_000]},
                        "duration": {"range": [1, 100_001]},
                    }
                ]
            },
            KIND_NAMES,
        )
    assert time.perf_counter() - started < 5  # 54 s and a MemoryError before
    with pytest.raises(BatchSpecError, match=r"range \[0, 10{30}\] gives more than 100000"):
        expand_batch({"runs": [{"kind": "pendulum", "seed": {"range": [0, 10**30]}}]}, KIND_NAMES)


def test_a_long_file_name_is_shown_cut(tmp_path):
    name = "x" * 100_000
    with pytest.raises(BatchSpecError) as caught:
        read_batch_spec(tmp_path / name, KIND_NAMES)
    message = str(caught.value)
    assert len(message) < 600 and f"({len(str(tmp_path / name))} characters)" in message


@pytest.mark.parametrize(
    ("run", "message"),
    [
        ({"out": "r/{seed.__class__.__name__}", "seed": 1}, r"has the field \{seed.__class__"),
        ({"out": "r/{0}", "seed": 1}, r"has the field \{0\}"),
        ({"out": "r/{seed[0]}", "seed": 1}, r"has the field \{seed\[0\]\}"),
    ],
)
def test_templates_name_plain_options_only(run, message):
    with pytest.raises(BatchSpecError, match=message):
        expand_batch({"runs": [{"kind": "pendulum", **run}]}, KIND_NAMES)
    spec = expand_batch(
        {"runs": [{"kind": "pendulum", "seed": 7, "out": "r/{seed:03d}"}]}, KIND_NAMES
    )
    assert spec.entries[0].options["out"] == "r/007"


@pytest.mark.parametrize("db", ["", "   ", 5])
def test_an_empty_db_is_refused_not_taken_as_the_working_folders(db):
    with pytest.raises(BatchSpecError, match="db: expected a database URL string"):
        expand_batch({"db": db, "runs": [{"kind": "pendulum"}]}, KIND_NAMES)


def test_entries_that_are_not_runs_or_repeat_another_are_refused(tmp_path):
    spec = expand_batch(
        {
            "runs": [
                {"kind": "pendulum", "help": True},
                {"kind": "pendulum", "duration": float("nan")},
                {"kind": "pendulum", "duration": float("inf")},
                {"kind": "gait-simulate", "duration": float("nan"), "out": str(tmp_path / "s")},
                {"kind": "pendulum", "seed": 4},
                {"kind": "pendulum", "seed": {"values": [4, 5]}},
            ]
        },
        KIND_NAMES,
    )
    tasks, problems = build_tasks(spec.entries)
    assert "runs[0] (pendulum, entry 0): 'help' makes no run" in problems[0]
    assert problems[1].startswith("runs[1] (pendulum, entry 1): duration")
    assert "found nan" in problems[1] and "found inf" in problems[2]
    assert problems[3].startswith("runs[3] (gait-simulate, entry 3): duration")
    assert problems[4] == (
        "runs[5] (pendulum, entry 5): the same run as entry 4 (the same options and inputs); "
        "remove one, or make them differ (e.g. the seed)"
    )
    assert len(problems) == 5 and [t.position for t in tasks] == [4, 5, 6]
