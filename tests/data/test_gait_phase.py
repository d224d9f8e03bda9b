"""Gait phase against hand-computed values."""

from __future__ import annotations

from pathlib import Path

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


def test_causal_phase_is_the_simulated_controllers_own():
    """On a simulated trial the causal phase from the recorded heel strikes, the cycle's stride
    duration and the phase at a strike is the controller's ``controller_phase`` column."""
    from colloc.data import causal_gait_phase, read_trial

    trial = read_trial(Path(__file__).parents[1] / "identify" / "data" / "gait_trial_p20")
    t = trial.time
    column = trial.signals["controller_phase"].to_numpy(dtype=float)
    strikes = trial.right_heel_strikes
    first = int(np.searchsorted(t, strikes[0]))  # the first sample that knows of the strike
    phi0 = float(np.mod(column[first] - (t[first] - strikes[0]) / 1.2153340054141708, 1.0))
    phase = causal_gait_phase(t, strikes, 1.2153340054141708, phi0)
    after = t >= strikes[0]
    assert np.all(np.isnan(phase[~after]))
    # the same up to a whole number of strides (the column counts from the trial's start)
    offset = np.round(column[first] - phase[first])
    np.testing.assert_allclose(phase[after] + offset, column[after], atol=1e-9)
    assert np.all(np.diff(phase[after]) >= 0)


def test_causal_phase_holds_at_the_strides_end_and_checks_its_arguments():
    from colloc.data import causal_gait_phase

    t = np.array([0.5, 1.0, 1.5, 2.9, 3.0, 3.5])
    phase = causal_gait_phase(t, [1.0, 3.0], 1.0, 0.25)
    np.testing.assert_allclose(phase[1:], [0.25, 0.75, 1.25, 1.25, 1.75])  # held, then reset
    assert np.isnan(phase[0])
    for kwargs, message in (
        ({"heel_strikes": []}, "heel_strikes"),
        ({"stride_duration": 0.0}, "stride_duration"),
        ({"phase_at_strike": 1.0}, "phase_at_strike"),
    ):
        arguments = {"heel_strikes": [1.0], "stride_duration": 1.0, "phase_at_strike": 0.0}
        with pytest.raises(ValueError, match=message):
            causal_gait_phase(t, **{**arguments, **kwargs})


def _strided_sine(strikes, rate=200.0, shift=0.0):
    """sin(2 pi phi) and phi**2 sampled over strides of unequal length: their gait-cycle
    shapes are known exactly whatever the strides' durations."""
    from colloc.data.phase import gait_phase

    t = np.arange(strikes[0] - 0.3, strikes[-1] + 0.3, 1.0 / rate)
    phi = gait_phase(t, np.asarray(strikes) + shift, extrapolate=True)
    return t, np.column_stack([np.sin(2 * np.pi * phi), phi**2])


def test_phase_normalised_strides_have_the_signals_known_shape():
    from colloc.data.phase import phase_normalised

    strikes = [0.0, 1.1, 2.0, 3.3, 4.2]
    t, x = _strided_sine(strikes)
    phase, cycles, mean = phase_normalised(t, x, strikes, points=41)
    assert cycles.shape == (4, 41, 2)
    # linear interpolation of 200 Hz samples: the error of a sine's chord at 5 ms steps
    np.testing.assert_allclose(mean[:, 0], np.sin(2 * np.pi * phase), atol=2e-3)
    np.testing.assert_allclose(mean[:-1, 1], phase[:-1] ** 2, atol=2e-4)  # phi wraps at 1
    # strides the samples do not wholly cover are left out; none gives NaN
    assert phase_normalised(t, x, [-1.0, 0.5, 1.1, 9.0])[1].shape[0] == 1
    assert np.isnan(phase_normalised(t, x, [-1.0, 9.0])[2]).all()


def test_a_drift_in_phase_is_not_an_error_between_mean_strides():
    from colloc.identify.gait.walk import phase_difference
    from colloc.identify.validation import rms

    strikes = np.array([0.0, 1.1, 2.2, 3.3, 4.4, 5.5])
    t, x = _strided_sine(strikes)
    # the same strides half a stride later, sampled at the same times
    later = _strided_sine(strikes, shift=0.55)[1]
    n = len(t)
    # sample by sample the two walks are opposite in the sine: RMS about sqrt(2)
    assert rms(x[:n, 0] - later[:n, 0]) > 1.2
    drift = phase_difference((t, x, strikes), (t, later, strikes + 0.55))
    assert drift is not None and np.max(drift) < 2e-3
    # a different shape is seen: twice the amplitude differs by the sine's own RMS
    bigger = phase_difference((t, x, strikes), (t, 2 * x, strikes))
    assert bigger is not None and bigger[0] == pytest.approx(np.sqrt(0.5), rel=0.03)
    assert phase_difference((t, x, strikes), (t, x, [0.0, 99.0])) is None


def test_phase_normalised_names_bad_arguments():
    from colloc.data.phase import phase_normalised

    with pytest.raises(ValueError, match="points"):
        phase_normalised([0.0, 1.0], [1.0, 2.0], [0.0, 1.0], points=1)
    with pytest.raises(ValueError, match=r"shapes \(N,\) and \(N, m\)"):
        phase_normalised([0.0, 1.0, 2.0], [1.0, 2.0], [0.0, 1.0])
    with pytest.raises(ValueError, match="strictly increasing"):
        phase_normalised([0.0, 0.0], [1.0, 2.0], [0.0, 1.0])
