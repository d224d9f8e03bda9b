"""Batch reports: the per-gain table against a hand computation, the per-trial gait table."""

from __future__ import annotations

import numpy as np
import pandas as pd

from colloc.batch import gait_table, pendulum_table, write_batch_report
from colloc.store import ParameterRow, RunRecord, RunStore


def pendulum_record(run_id: str, seed: int, estimate: float, se: float) -> RunRecord:
    return RunRecord(
        run_id=run_id,
        kind="pendulum",
        settings={"num_links": 1, "seed": seed},
        versions={"python": "3.11"},
        statistics={"success": True},
        ipopt_log="",
        parameters=[ParameterRow("k", 2.0, estimate, se), ParameterRow("c", -1.0, -1.0, None)],
        arrays={"times": np.arange(3.0)},
    )


def test_the_pendulum_table_is_the_statistics_of_the_estimates():
    estimates, ses = [2.1, 1.8, 2.3, 1.9], [0.15, 0.25, 0.11, 0.06]
    with RunStore("sqlite://") as store:
        for i, (e, s) in enumerate(zip(estimates, ses, strict=True)):
            store.add(pendulum_record(f"r{i}", i, e, s))
        table = pendulum_table(store, [f"r{i}" for i in range(4)])
    row = table[table["gain"] == "k"].iloc[0]
    assert row["runs"] == 4 and row["group"] == 0  # seeds grouped together
    assert np.isclose(row["bias"], np.mean(estimates) - 2.0)
    assert np.isclose(row["spread"], np.std(estimates, ddof=1))
    assert np.isclose(row["spread_over_se"], np.std(estimates, ddof=1) / np.mean(ses))
    # |error| / se = 0.67, 0.8, 2.73, 1.67
    assert (row["within_2se"], row["within_3se"]) == (0.75, 1.0)
    missing = table[table["gain"] == "c"].iloc[0]  # no standard errors: no coverage
    assert np.isnan(missing["mean_se"]) and np.isnan(missing["within_3se"])


def test_gait_runs_get_a_row_each_with_their_vaf(tmp_path):
    with RunStore(f"sqlite:///{tmp_path / 'r.db'}") as store:
        for i in range(2):
            store.add(
                RunRecord(
                    run_id=f"g{i}",
                    kind="gait-identify",
                    settings={"trial": f"trials/seed-{i}/trial"},
                    versions={"python": "3.11"},
                    statistics={
                        "K_relative_error": 0.1 * (i + 1),
                        "validation": {
                            "torque_vaf": {"collocation": {"right_hip": 0.9, "left_hip": 0.8}},
                            "walks": True,
                        },
                    },
                    ipopt_log="",
                    parameters=[ParameterRow("K[0]", 1.0, 1.1, 0.1)],
                    arrays={"times": np.arange(3.0)},
                )
            )
        table = gait_table(store, ["g0", "g1"])
        assert list(table["K_relative_error"]) == [0.1, 0.2]
        assert list(table["vaf_right_hip"]) == [0.9, 0.9] and list(table["walks"]) == [True, True]
        store.batches.start(
            "b1",
            {},
            [{"kind": "gait-identify", "entry_key": f"k{i}", "settings": {}} for i in range(2)],
        )
        for i in range(2):
            store.batches.record("b1", i, "done", run_id=f"g{i}")
        written = write_batch_report(store, "b1", tmp_path / "report")
    assert {p.name for p in written} == {
        "entries.csv",
        "entries.md",
        "gait-runs.csv",
        "gait-runs.md",
        "gait-runs.png",
        "gait-runs.svg",
    }
    assert pd.read_csv(tmp_path / "report" / "gait-runs.csv")["run_id"].tolist() == ["g0", "g1"]
    markdown = (tmp_path / "report" / "gait-runs.md").read_text().splitlines()
    assert markdown[0].startswith("| run_id | trial |") and len(markdown) == 4
