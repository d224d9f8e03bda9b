"""colloc gait smooth on 3 s of the noise-free fixture trial: the record is its own truth."""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from colloc.cli import main
from colloc.data.columns import JOINT_ANGLE_COLUMNS, TORQUE_COLUMNS
from colloc.data.trial import read_trial
from colloc.gait.metadata import STATE_SIGNAL_NAMES
from colloc.identify.gait.smooth import RESIDUAL_COLUMNS, smooth_trial

FIXTURE = Path(__file__).parent / "data" / "gait_trial_p20"


@pytest.fixture(scope="module")
def smoothed(tmp_path_factory):
    out = tmp_path_factory.mktemp("smooth")
    code = main(["gait", "smooth", str(FIXTURE), "--out", str(out), "--duration", "3"])
    return code, out


def test_the_table_is_the_record_made_dynamically_consistent(smoothed):
    code, out = smoothed
    assert code == 0
    table = pd.read_csv(out / "smoothed.csv")
    assert list(table.columns) == [
        "time", *STATE_SIGNAL_NAMES, *TORQUE_COLUMNS, *RESIDUAL_COLUMNS,
    ]  # fmt: skip
    record = pd.read_csv(FIXTURE / "trial.csv")
    record = record[record["time"] <= 3.0 + 1e-9]
    np.testing.assert_allclose(table["time"], record["time"], atol=1e-9)
    # a noise-free simulated walk: the smoother gives back its angles and torques
    angles = np.degrees(table[list(JOINT_ANGLE_COLUMNS)] - record[list(JOINT_ANGLE_COLUMNS)])
    assert np.sqrt((angles**2).mean()).max() < 0.5
    torques = table[list(TORQUE_COLUMNS)] - record[list(TORQUE_COLUMNS)]
    assert np.sqrt((torques**2).mean()).max() < 2.0
    summary = json.loads((out / "smooth.json").read_text())
    assert summary["success"] is True and summary["samples"] == len(record)
    assert max(summary["angle_rms_deg"].values()) == pytest.approx(
        np.sqrt((angles**2).mean()).max(), rel=1e-6
    )
    # residual forces a body of 75 kg hardly needs on its own walk (its weight: 736 N)
    assert max(summary["residual_rms"].values()) < 10.0
    for stem in ("smoothed_angles", "smoothed_torques"):
        assert (out / f"{stem}.png").stat().st_size > 10_000


def test_a_second_run_keeps_the_first_unless_told(smoothed, capsys):
    _, out = smoothed
    before = (out / "smoothed.csv").read_bytes()
    code = main(["gait", "smooth", str(FIXTURE), "--out", str(out), "--duration", "3"])
    assert code == 2
    assert "already holds ['smoothed.csv', 'smooth.json']; give --overwrite" in (
        capsys.readouterr().err
    )
    assert (out / "smoothed.csv").read_bytes() == before


def test_less_than_a_stride_and_bad_options_are_refused_by_name(tmp_path, capsys):
    with pytest.raises(
        ValueError, match=r"at least one whole stride .* found [01] right heel"
    ) as refused:
        smooth_trial(FIXTURE, duration=0.5)
    # how long a part would do, from the trial's own strides
    strides = np.diff(read_trial(FIXTURE).right_heel_strikes)
    assert (
        f"strides last {np.median(strides):.2f} s (median), so a part of "
        f"{2 * strides.max():.2f} s (two of its longest) holds one" in str(refused.value)
    )
    with pytest.raises(ValueError, match="start: expected seconds >= 0.*window_strides"):
        smooth_trial(FIXTURE, start=-1.0, window_strides=0)
    code = main(["gait", "smooth", str(tmp_path / "none"), "--out", str(tmp_path / "o")])
    assert code == 2
    assert "trial: expected a trial directory" in capsys.readouterr().err
