"""Heel-strike detection: synthetic signals with known crossings, and two real recordings."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from colloc.data.events import detect_heel_strikes, lowpass
from colloc.data.records import read_vertical_grf

RECORDS = Path(__file__).resolve().parent / "records"  # copies with their SOURCE.md
GRF = RECORDS / "gatk-grf-and-treadmill-speed" / "example_vertical_grf.csv"
LEG2D = RECORDS / "gatk-leg2d-sagittal-gait-3s" / "rawdata.txt"

# Force 600 sin(w t) - 300 N crosses 25 N upward where sin(w t) = 325/600.
PERIOD = 1.2
OMEGA = 2 * np.pi / PERIOD


def sine_force(time: np.ndarray) -> np.ndarray:
    return 600.0 * np.sin(OMEGA * time) - 300.0


def exact_crossings(end: float) -> np.ndarray:
    first = np.arcsin(325.0 / 600.0) / OMEGA
    crossings = first + PERIOD * np.arange(int(end / PERIOD) + 1)
    return crossings[crossings <= end]


def test_synthetic_crossings_on_jittered_clock() -> None:
    rng = np.random.default_rng(3)
    time = np.cumsum(rng.uniform(0.0009, 0.0011, 10_000))
    detected = detect_heel_strikes(time, sine_force(time))
    expected = exact_crossings(time[-1])
    assert expected.size == 9
    # Linear interpolation of a smooth crossing on a 1 ms grid: error ~ f'' h^2 / f' << 1e-5 s.
    np.testing.assert_allclose(detected, expected, atol=1e-5)


def test_interpolated_crossing_of_a_ramp_is_exact() -> None:
    time = np.array([0.0, 0.1, 0.2, 0.3])
    force = np.array([0.0, 10.0, 50.0, 90.0])  # 25 N reached 3/8 of the way from 0.1 to 0.2
    np.testing.assert_allclose(detect_heel_strikes(time, force), [0.1375])
    # Starting in stance: no strike for that stance.
    assert detect_heel_strikes(time, force + 100.0).size == 0


def test_debounce_drops_chatter() -> None:
    time = np.arange(8) * 0.01
    force = np.array([0.0, 30.0, 20.0, 30.0, 40.0, 10.0, 0.0, 0.0])
    # Upward crossings: 0 -> 30 N at 25/30 of the first step, 20 -> 30 N halfway (0.025 s).
    np.testing.assert_allclose(detect_heel_strikes(time, force), [0.01 * 25 / 30])
    np.testing.assert_allclose(
        detect_heel_strikes(time, force, min_interval=0.0), [0.01 * 25 / 30, 0.025]
    )


def test_lowpass_follows_the_butterworth_response() -> None:
    time = np.arange(2000) / 100.0
    for frequency in (1.0, 15.0, 40.0):
        signal = np.sin(2 * np.pi * frequency * time)
        filtered = lowpass(time, signal, 10.0)
        # Digital (bilinear) 2nd-order Butterworth: |H|^2 = 1 / (1 + (tan(pi f/fs) /
        # tan(pi fc/fs))^4), and filtfilt applies |H|^2 with zero phase.
        ratio = np.tan(np.pi * frequency / 100.0) / np.tan(np.pi * 10.0 / 100.0)
        gain = 1.0 / (1.0 + ratio**4)
        middle = slice(500, 1500)
        np.testing.assert_allclose(filtered[middle], gain * signal[middle], atol=2e-3)


def test_lowpass_removes_noise_chatter() -> None:
    rng = np.random.default_rng(11)
    time = np.arange(0.0, 12.0, 0.01)
    force = sine_force(time) + rng.normal(0.0, 40.0, time.size)
    raw = detect_heel_strikes(time, force, min_interval=0.0)
    filtered = detect_heel_strikes(time, force, lowpass_hz=6.0, min_interval=0.0)
    expected = exact_crossings(time[-1])
    assert raw.size > expected.size
    np.testing.assert_allclose(filtered, expected, atol=0.01)


def test_real_vertical_grf_strides() -> None:
    time, force = read_vertical_grf(GRF)
    strikes = detect_heel_strikes(time, force, threshold=25.0)
    # SOURCE.md: ~46 heel strikes at 25 N, mean stride ~1.20 s.
    assert strikes.size == 46
    assert np.mean(np.diff(strikes)) == pytest.approx(1.20, abs=0.005)
    after = np.searchsorted(time, strikes)
    assert np.all(force[after - 1] < 25.0) and np.all(force[after] >= 25.0)
    smoothed = detect_heel_strikes(time, force, threshold=25.0, lowpass_hz=15.0)
    np.testing.assert_allclose(smoothed, strikes, atol=0.015)


def test_real_force_plate_right_heel_strikes() -> None:
    raw = pd.read_csv(LEG2D, sep="\t")
    time, force = raw.iloc[:, 0].to_numpy(), raw["FP2.ForY"].to_numpy()
    strikes = detect_heel_strikes(time, force, threshold=20.0)
    # SOURCE.md: right heel strikes ~7.21, 8.41, 9.60 s (FP2.ForY crossing 20 N).
    np.testing.assert_allclose(strikes, [7.21, 8.41, 9.60], atol=0.01)


def test_input_errors() -> None:
    time = np.arange(5) * 0.1
    force = np.zeros(5)
    with pytest.raises(ValueError, match=r"vertical_force must have the shape of time \(5,\)"):
        detect_heel_strikes(time, force[:4])
    with pytest.raises(ValueError, match=r"time must be 1-D with at least 2 samples"):
        detect_heel_strikes([0.0], [0.0])
    with pytest.raises(ValueError, match="vertical_force has 1 NaN/infinite values"):
        detect_heel_strikes(time, np.where(time == 0.2, np.nan, force))
    with pytest.raises(ValueError, match="time must be strictly increasing; sample 3"):
        detect_heel_strikes(time[[0, 1, 2, 2, 4]], force)
    with pytest.raises(ValueError, match="time has 1 NaN/infinite values"):
        detect_heel_strikes(np.where(time == 0.2, np.inf, time), force)
    with pytest.raises(ValueError, match="threshold must be a finite force"):
        detect_heel_strikes(time, force, threshold=np.nan)
    with pytest.raises(ValueError, match="min_interval must be a non-negative time"):
        detect_heel_strikes(time, force, min_interval=-0.1)
    with pytest.raises(ValueError, match=r"lowpass_hz\) must lie strictly between 0 and the Nyq"):
        detect_heel_strikes(time, force, lowpass_hz=5.0)
