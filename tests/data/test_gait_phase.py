"""Gait phase against hand-computed values."""

from __future__ import annotations

import numpy as np
import pytest

from colloc.data.phase import gait_phase

STRIKES = np.array([1.0, 2.0, 3.5])


def test_phase_between_strikes() -> None:
    time = [0.5, 1.0, 1.25, 1.5, 2.0, 2.75, 3.125, 3.5, 4.0]
    expected = [np.nan, 0.0, 0.25, 0.5, 0.0, 0.5, 0.75, 0.0, np.nan]
    np.testing.assert_allclose(gait_phase(time, STRIKES), expected)


def test_phase_extrapolated_with_neighbouring_strides() -> None:
    # Before: first stride lasts 1 s, so 0.25 s before the first strike is phase 0.75;
    # 1.25 s before is 0.75 again. After: last stride lasts 1.5 s.
    time = [-0.25, 0.75, 3.75, 4.25, 5.375]
    expected = [0.75, 0.75, 0.25 / 1.5, 0.75 / 1.5, 0.25]
    np.testing.assert_allclose(gait_phase(time, STRIKES, extrapolate=True), expected)


def test_phase_keeps_the_shape_of_time() -> None:
    time = np.array([[1.5, 2.375], [3.0, 3.5]])
    np.testing.assert_allclose(gait_phase(time, STRIKES), [[0.5, 0.25], [2 / 3, 0.0]])
    assert gait_phase(2.3, STRIKES).shape == ()
    assert float(gait_phase(2.3, STRIKES)) == pytest.approx(0.2)


def test_phase_errors() -> None:
    with pytest.raises(ValueError, match=r"at least 2 strikes, found shape \(1,\)"):
        gait_phase([1.0], [1.0])
    with pytest.raises(ValueError, match=r"strike 2 \(1.5 s\) is not after strike 1 \(2.0 s\)"):
        gait_phase([1.0], [1.0, 2.0, 1.5])
    with pytest.raises(ValueError, match="heel_strikes has 1 NaN/inf values"):
        gait_phase([1.0], [1.0, np.nan, 3.0])
    with pytest.raises(ValueError, match="time has 1 NaN/infinite values"):
        gait_phase([1.0, np.nan], STRIKES)
