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


def test_unwrapped_phase_counts_strides_and_matches_wrapped_phase():
    from colloc.data import unwrapped_gait_phase

    strikes = np.array([1.0, 2.2, 3.1, 4.5])
    t = np.array([0.5, 1.0, 1.6, 2.2, 2.65, 3.1, 3.8, 4.5, 5.0])
    phi = unwrapped_gait_phase(t, strikes)
    # hand-computed: stride k contributes k + (t - t_k) / (t_{k+1} - t_k)
    expected = [np.nan, 0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, np.nan]
    np.testing.assert_allclose(phi, expected, equal_nan=True)
    inside = ~np.isnan(phi)
    np.testing.assert_allclose(
        np.mod(phi[inside], 1.0), np.mod(gait_phase(t, strikes)[inside], 1.0)
    )


def test_unwrapped_phase_needs_increasing_strikes():
    from colloc.data import unwrapped_gait_phase

    with pytest.raises(ValueError, match="strictly increasing"):
        unwrapped_gait_phase([0.0, 1.0], [1.0, 1.0])
