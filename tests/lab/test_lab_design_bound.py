"""The lab design's bound (colloc.identify.gait.design_bound.lab_signals): the markers and
plates the marker smoother tracked, as the closed loop's information sees them."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from colloc.control.gain_scheduled import GainScheduled
from colloc.data.columns import TORQUE_COLUMNS
from colloc.gait.orbit import GaitDynamics
from colloc.identify.gait.design_bound import (
    ClosedLoopInformation,
    WindowDesign,
    lab_signals,
)
from colloc.identify.gait.markers import marker_smoother
from colloc.identify.gait.read import state_names
from colloc.lab import LabSettings, lab_export_from_record, process_lab
from colloc.models.gait2d_params import load_parameters

SUBJECT = (75.0, 1.8)  # the session walk's (tests/lab/conftest.py)
ROWS = np.arange(100, 150)  # 0.5 s of the lab trial


@pytest.fixture(scope="module")
def lab(walk):
    export = lab_export_from_record(walk, load_parameters(*SUBJECT), seed=5)  # 1 mm, 2 N, 1 N m
    trial = process_lab(export, LabSettings(*SUBJECT, belt_speed="RightBeltSpeed")).trial
    dyn = GaitDynamics.build(load_parameters(*SUBJECT))
    _, facts = marker_smoother(dyn, trial, ROWS)
    return trial, dyn, facts


def test_the_lab_design_is_what_the_marker_smoother_tracked(lab):
    trial, _, facts = lab
    times = trial.time[ROWS]
    signals, (observed,) = lab_signals(trial, [facts], [times])
    names = list(facts["markers"])
    assert [n for n, _ in signals.segments] == names
    for name, segment in signals.segments:
        assert segment == facts["markers"][name]["segment"]
    for name, (a, b) in signals.local:
        np.testing.assert_allclose((a, b), facts["markers"][name]["in_segment_m"], rtol=1e-12)
    lengths = facts["segment_lengths_m"]
    assert dict(signals.constants) == {
        "l_thigh": lengths["thigh"], "l_shank": lengths["shank"],
        "h_ankle": lengths["ankle_height"],
    }  # fmt: skip
    assert signals.marker_std == facts["noise"]["marker_m"]
    shrink = np.sqrt(max(facts["plate_samples_per_node"], 1.0))
    assert signals.plate_std == pytest.approx(
        (facts["noise"]["force_n"] / shrink, facts["noise"]["moment_nm"] / shrink), rel=1e-12
    )
    # every marker seen at every node, and the plates' six channels after them
    assert observed.shape == (ROWS.size, 2 * len(names) + 6) and observed.all()
    # two windows' places are averaged
    moved = {**facts, "markers": {n: {**m, "in_segment_m": [m["in_segment_m"][0] + 0.002,
                                                             m["in_segment_m"][1]]}
                                  for n, m in facts["markers"].items()}}  # fmt: skip
    both, _ = lab_signals(trial, [facts, moved], [times, times])
    a, _ = dict(both.local)[names[0]]
    assert a == pytest.approx(facts["markers"][names[0]]["in_segment_m"][0] + 0.001, abs=1e-12)


def test_a_hidden_marker_is_left_out_where_it_was_hidden(lab):
    trial, _, facts = lab
    times = trial.time[ROWS]
    table = trial.tables["markers"].copy()
    name = list(facts["markers"])[3]
    hidden = table.index[(table["time"] >= times[10] - 1e-9) & (table["time"] <= times[19] + 1e-9)]
    table.loc[hidden, [f"{name}_x", f"{name}_y"]] = np.nan
    gappy = replace(trial, tables={**trial.tables, "markers": table})
    _, (observed,) = lab_signals(gappy, [facts], [times])
    assert not observed[10:20, 6:8].any() and observed[:10, 6:8].all()
    assert observed[:, :6].all() and observed[:, 8:].all()


def test_plates_and_markers_seen_inform_the_controller(lab):
    """The plates add information (Loewner order); a marker hidden takes some away."""
    trial, dyn, facts = lab
    times = trial.time[ROWS]
    signals, (observed,) = lab_signals(trial, [facts], [times])
    names = list(state_names())
    feedback = [dyn.model.states[names.index(n)] for n in names[3:9]]  # the joint angles
    gs = GainScheduled(4, feedback, dyn.gait.torques)
    Tstar, K = np.zeros((4, 6)), np.zeros((4, 6, 6))
    rows = trial.signals.iloc[ROWS]
    window = WindowDesign(
        times,
        rows[names].to_numpy(float),
        rows[list(TORQUE_COLUMNS)].to_numpy(float),
        rows["belt_speed"].to_numpy(float),
        # a schedule of zero gains whose cycle spans the window: every point is reached
        (times - times[0]) / (times[-1] - times[0] + 0.01),
        observed,
    )
    markers = 2 * len(signals.segments)
    both = ClosedLoopInformation(dyn, gs, {}, 3.0, lab=signals)(window, Tstar, K)
    alone = ClosedLoopInformation(dyn, gs, {}, 3.0, lab=replace(signals, plate_std=None))(
        replace(window, observed=observed[:, :markers]), Tstar, K
    )
    gap = np.linalg.eigvalsh(both - alone)
    assert gap.min() > -1e-6 * gap.max() and gap.max() > 0.05 * np.linalg.eigvalsh(alone).max()
    fewer = observed.copy()
    fewer[:25, :4] = False  # the first two markers hidden for half the window
    less = ClosedLoopInformation(dyn, gs, {}, 3.0, lab=signals)(
        replace(window, observed=fewer), Tstar, K
    )
    gap = np.linalg.eigvalsh(both - less)
    assert gap.min() > -1e-6 * gap.max() and gap.max() > 0


def test_windows_that_disagree_are_named(lab):
    trial, _, facts = lab
    times = trial.time[ROWS]
    with pytest.raises(ValueError, match="expected one of each per window, found 1 and 2"):
        lab_signals(trial, [facts], [times, times])
    fewer = {**facts, "markers": dict(list(facts["markers"].items())[1:])}
    with pytest.raises(ValueError, match="the same markers in every window"):
        lab_signals(trial, [facts, fewer], [times, times])
