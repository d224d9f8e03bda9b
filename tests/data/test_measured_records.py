"""Readers of the shared measured records, checked against values read by hand from the files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from colloc.data.belt import belt_position, read_belt_perturbation, rescale_belt_speed
from colloc.data.records import read_vertical_grf, read_winter_gait_cycle

# the package ships the belt record and Winter's cycle; the tests keep their own copies of the
# rest (tests/data/records/*/SOURCE.md): a clone has nothing beside it
REFERENCE = Path(__file__).resolve().parents[2] / "src" / "colloc" / "gait" / "reference"
RECORDS = Path(__file__).resolve().parent / "records"
BELT = REFERENCE / "RandomSlowSpeed1.txt"
WINTER = REFERENCE / "Winter_normal.csv"
GRF = RECORDS / "gatk-grf-and-treadmill-speed" / "example_vertical_grf.csv"


def test_belt_perturbation_record() -> None:
    time, velocity = read_belt_perturbation(BELT)
    # SOURCE.md: 35002 rows, 0-349.995 s; mean 1.200, SD 0.097, min 0.88, max 1.53 m/s.
    assert time.size == velocity.size == 35002
    assert (time[0], time[1], time[-1]) == (0.0, 0.010021, 349.995)
    assert (velocity[0], velocity[-1]) == (1.24793, 1.21174)
    assert velocity.mean() == pytest.approx(1.200, abs=5e-4)
    assert velocity.std(ddof=1) == pytest.approx(0.097, abs=5e-4)
    assert velocity.min() == pytest.approx(0.88, abs=5e-3)
    assert velocity.max() == pytest.approx(1.53, abs=5e-3)


def test_measured_belt_position_agrees_with_total_integral() -> None:
    time, velocity = read_belt_perturbation(BELT)
    position = belt_position(time, velocity)
    assert position[0] == 0.0
    # Second method: the summed trapezoids of numpy; roughly mean speed x duration.
    assert position[-1] == pytest.approx(np.trapezoid(velocity, time), rel=1e-12)
    assert position[-1] == pytest.approx(1.2 * 350.0, rel=2e-3)


def test_belt_position_of_a_sine_on_uneven_steps() -> None:
    rng = np.random.default_rng(5)
    time = np.cumsum(rng.uniform(0.004, 0.006, 2000))
    velocity = 1.2 + 0.1 * np.cos(time)
    exact = 2.0 + 1.2 * (time - time[0]) + 0.1 * (np.sin(time) - np.sin(time[0]))
    np.testing.assert_allclose(belt_position(time, velocity, initial=2.0), exact, atol=1e-7)
    with pytest.raises(ValueError, match=r"velocity must have the shape of time \(2000,\)"):
        belt_position(time, velocity[:-1])
    with pytest.raises(ValueError, match="time must be strictly increasing"):
        belt_position(time[::-1], velocity)
    with pytest.raises(ValueError, match="time and velocity must be finite"):
        belt_position(time, np.where(time > 1.0, np.nan, velocity))


def test_rescale_belt_speed_shifts_the_mean() -> None:
    _, velocity = read_belt_perturbation(BELT)
    shifted = rescale_belt_speed(velocity, 0.8)
    assert shifted.mean() == pytest.approx(0.8, abs=1e-12)
    assert shifted.std() == pytest.approx(velocity.std(), rel=1e-12)
    np.testing.assert_allclose(np.diff(shifted), np.diff(velocity), atol=1e-12)
    scaled = rescale_belt_speed(velocity, 0.8, deviation_scale=0.8 / velocity.mean())
    np.testing.assert_allclose(scaled, velocity * 0.8 / velocity.mean(), atol=1e-12)


def test_rescale_belt_speed_errors() -> None:
    with pytest.raises(ValueError, match=r"velocity must be a non-empty 1-D array"):
        rescale_belt_speed([], 1.0)
    with pytest.raises(ValueError, match="velocity has 1 NaN/infinite values"):
        rescale_belt_speed([1.0, np.nan], 1.0)
    with pytest.raises(ValueError, match="mean_speed must be finite.*deviation_scale must be"):
        rescale_belt_speed([1.0, 1.1], np.inf, deviation_scale=np.nan)


def test_belt_reader_errors(tmp_path: Path) -> None:
    path = tmp_path / "belt.txt"
    path.write_text("Timestamp (s)\tPitch Moment (Nm)\n0\t1\n")
    with pytest.raises(ValueError, match="one column whose header starts with 'Belt Velocity'"):
        read_belt_perturbation(path)
    path.write_text("Timestamp (s)\tBelt Velocity (m/s)\n0\t1\n0.01\tx\n0.01\t1\n")
    with pytest.raises(ValueError) as info:
        read_belt_perturbation(path)
    assert "belt velocity has 1 missing/non-numeric values (first in data row 1)" in str(info.value)
    assert "time must be strictly increasing" in str(info.value)


def test_winter_gait_cycle() -> None:
    cycle = read_winter_gait_cycle(WINTER)
    assert cycle.cycle_duration == 1.1396 and cycle.walking_speed == 1.325
    np.testing.assert_allclose(cycle.percent, np.arange(0, 101, 2))
    assert cycle.time[-1] == pytest.approx(1.1396)
    # Row 1: hip 19.33, knee 3.97, ankle 0.02 deg; row 51: 19.01, 2.21, 0.58 deg.
    np.testing.assert_allclose(
        [cycle.hip[0], cycle.knee[0], cycle.ankle[0]], np.deg2rad([19.33, -3.97, 0.02])
    )
    np.testing.assert_allclose(
        [cycle.hip[-1], cycle.knee[-1], cycle.ankle[-1]], np.deg2rad([19.01, -2.21, 0.58])
    )
    assert (cycle.horizontal_grf[0], cycle.vertical_grf[0]) == (0.03, 0.64)
    assert (cycle.hip_moment[-1], cycle.knee_moment[-1], cycle.ankle_moment[-1]) == (
        0.118,
        -0.147,
        0.004,
    )
    frame = cycle.to_pandas()
    assert frame.shape == (51, 9)
    assert frame.index[25] == pytest.approx(0.5 * 1.1396)
    # Stance: the knee flexes (gait2d knee angle goes negative), peak vertical GRF > body weight.
    assert cycle.knee.max() <= 0.0 and cycle.vertical_grf.max() > 9.81


def _winter_lines() -> list[str]:
    return WINTER.read_text(encoding="utf-8-sig").splitlines()


def test_winter_reader_errors(tmp_path: Path) -> None:
    path = tmp_path / "winter.csv"
    lines = _winter_lines()
    path.write_text("\n".join(lines[:1] + lines[2:]), encoding="utf-8-sig")
    with pytest.raises(ValueError, match="no number found on a line starting with 'gait cycle"):
        read_winter_gait_cycle(path)
    path.write_text("\n".join(lines[:4] + lines[6:]), encoding="utf-8")
    with pytest.raises(ValueError, match="no header line starting with 'sample'"):
        read_winter_gait_cycle(path)
    spoiled = lines[:4] + [lines[4].replace("knee angle", "knee")] + lines[5:]
    spoiled[5] = spoiled[5].replace("(deg)", "(rad)", 1)
    path.write_text("\n".join(spoiled), encoding="utf-8")
    with pytest.raises(ValueError) as info:
        read_winter_gait_cycle(path)
    assert "missing columns ['knee angle']" in str(info.value)
    assert "angle units must be '(deg)', found [\"'hip angle': '(rad)'\"]" in str(info.value)
    path.write_text("\n".join(lines[:8] + [lines[8].replace("18.45", "?")]), encoding="utf-8")
    with pytest.raises(ValueError, match="column 'hip angle' holds a missing or non-numeric"):
        read_winter_gait_cycle(path)


def test_vertical_grf_record() -> None:
    time, force = read_vertical_grf(GRF)
    # SOURCE.md: 5559 rows, 534.13-589.71 s, -23 to 1040 N, jittered 8.7-11.2 ms steps.
    assert time.size == force.size == 5559
    assert (time[0], force[0]) == (534.133513, 235.311661)
    assert (time[-1], force[-1]) == (589.712359, -3.268034)
    assert force.min() == pytest.approx(-23, abs=1) and force.max() == pytest.approx(1040, abs=1)
    assert np.diff(time).min() == pytest.approx(0.0087, abs=1e-4)
    assert np.diff(time).max() == pytest.approx(0.0112, abs=1e-4)


def test_vertical_grf_reader_errors(tmp_path: Path) -> None:
    path = tmp_path / "grf.csv"
    path.write_text("0,1,2\n1,2,3\n")
    with pytest.raises(ValueError, match=r"expected 2 columns \(time, force\), found 3"):
        read_vertical_grf(path)
    path.write_text("0,1\n1,oops\n")
    with pytest.raises(ValueError, match=r"1 missing/non-numeric values \(first in data row 1\)"):
        read_vertical_grf(path)
    path.write_text("0,1\n0,2\n")
    with pytest.raises(ValueError, match=r"time \(column 1\) must be strictly increasing"):
        read_vertical_grf(path)


@pytest.mark.parametrize(
    ("reader", "content", "message"),
    [
        (read_belt_perturbation, "time,belt speed\n0,1.2 J\xfcrgen\n".encode("latin-1"), "0xfc"),
        (read_vertical_grf, "0,1\n0.01,2 J\xfcrgen\n".encode("latin-1"), "0xfc"),
        (read_winter_gait_cycle, "gait cycle duration, 1 J\xfcrgen\n".encode("latin-1"), "0xfc"),
        (read_belt_perturbation, b"", "cannot parse it as a table"),
        (read_vertical_grf, b"", "cannot parse it as a table"),
    ],
    ids=["belt-latin1", "grf-latin1", "winter-latin1", "belt-empty", "grf-empty"],
)
def test_unreadable_records_name_their_file(tmp_path: Path, reader, content, message) -> None:
    path = tmp_path / "record.csv"
    path.write_bytes(content)
    with pytest.raises(ValueError, match=message) as error:
        reader(path)
    assert str(path) in str(error.value)
