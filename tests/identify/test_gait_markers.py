"""The marker smoother's data handling: plates averaged onto the nodes, markers matched to
them, the noise levels and where they came from."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from colloc.data.tables import PLATE_COLUMNS
from colloc.identify.gait.markers import (
    DEFAULT_MARKER_STD,
    TORQUE_PRIOR_STD,
    MarkerNoise,
    markers_on_nodes,
    measured_lengths,
    plates_on_nodes,
)


def test_plates_are_averaged_over_each_nodes_interval():
    nodes = np.arange(0.0, 1.0, 0.01)
    # ten plate samples per node, none on a cell's edge, each cell's values 0..9 + node index
    stamps = (nodes[:, None] + (np.arange(10) - 4.5) * 0.001).ravel()
    values = np.tile(np.arange(10.0), nodes.size) + np.repeat(np.arange(nodes.size), 10)
    table = pd.DataFrame(
        {"time": stamps, **{c: values * (k + 1) for k, c in enumerate(PLATE_COLUMNS)}}
    )
    found, samples = plates_on_nodes(table, nodes)
    assert samples == 10
    for k in range(len(PLATE_COLUMNS)):
        np.testing.assert_allclose(found[:, k], (4.5 + np.arange(nodes.size)) * (k + 1))


def test_a_node_without_plate_samples_is_left_out():
    nodes = np.arange(0.0, 0.1, 0.01)
    table = pd.DataFrame({"time": nodes[:5], **{c: np.ones(5) for c in PLATE_COLUMNS}})
    found, samples = plates_on_nodes(table, nodes)
    assert samples == 1
    assert np.isfinite(found[:5]).all() and np.isnan(found[5:]).all()


def test_markers_are_taken_at_the_nodes_and_left_out_where_none_falls():
    nodes = np.arange(0.0, 0.1, 0.01)
    stamps = nodes.copy()
    stamps[3] += 0.004  # not a node's sample: left out, not interpolated
    table = pd.DataFrame({"time": stamps, "A_x": np.arange(10.0), "A_y": -np.arange(10.0)})
    table.loc[6, "A_x"] = np.nan
    found = markers_on_nodes(table, nodes)["A"]
    assert np.isnan(found[3]).all() and np.isnan(found[6, 0])
    keep = [0, 1, 2, 4, 5, 7, 8, 9]
    np.testing.assert_array_equal(found[keep, 1], -np.arange(10.0)[keep])


def test_noise_levels_say_where_each_came_from():
    meta = {"markers": {"noise_std_m": 0.0012}, "plates": {"force_noise_std_n": 0.0}}
    noise = MarkerNoise.from_metadata(meta, {"moment": 0.5})
    assert (noise.marker, noise.moment, noise.torque_prior) == (0.0012, 0.5, TORQUE_PRIOR_STD)
    assert noise.force == 2.0  # the record's 0 is no estimate
    assert "marker estimated from the record" in noise.source
    assert "force colloc's default (the record shows none)" in noise.source
    assert "moment given" in noise.source
    assert MarkerNoise.from_metadata({}).marker == DEFAULT_MARKER_STD
    with pytest.raises(ValueError, match="unknown skin.*marker=-1"):
        MarkerNoise.from_metadata({}, {"skin": 1.0, "marker": -1})


def test_segment_lengths_are_both_sides_mean():
    lengths = {
        f"{side}_{seg}": {"measured": value, "model": 0.44}
        for side, seg, value in [
            ("right", "thigh", 0.40),
            ("left", "thigh", 0.42),
            ("right", "shank", 0.43),
            ("left", "shank", 0.45),
        ]
    }
    found = measured_lengths({"lab": {"segment_lengths_m": lengths}})
    assert found == pytest.approx({"thigh": 0.41, "shank": 0.44})
    assert measured_lengths({}) == {}


def test_the_ankle_height_is_the_loaded_malleolus_plus_the_contacts_sinking():
    from colloc.lab.ankle import ankle_height

    t = np.arange(0.0, 1.0, 0.01)
    weight = 75.0 * 9.81
    markers = pd.DataFrame(
        {
            "time": t,
            "RLM_x": 0 * t, "RLM_y": np.full(t.size, 0.05),  # the malleolus, lowest
            "RKNEE_x": 0 * t, "RKNEE_y": np.full(t.size, 0.45),
            "LLM_x": 0 * t, "LLM_y": np.full(t.size, 0.30),  # the left foot in the air
        }
    )  # fmt: skip
    plates = pd.DataFrame({"time": t, **{c: np.zeros(t.size) for c in PLATE_COLUMNS}})
    plates["right_force_y"] = np.where(t < 0.5, weight, 0.5 * weight)  # loaded half the time
    segments = {"RLM": "right_shank", "RKNEE": "right_shank", "LLM": "left_shank"}
    k = 5e7
    found = ankle_height(markers, plates, segments, 75.0, k)
    assert found == pytest.approx(0.05 + (weight / (2 * k)) ** (1 / 3), rel=1e-9)
    plates["right_force_y"] = 0.5 * weight  # never loaded above 80 % of the weight
    assert ankle_height(markers, plates, segments, 75.0, k) is None
