"""Splitting a trial into fit and validation parts."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from colloc.data.columns import REQUIRED_COLUMNS
from colloc.data.split import split, stride_windows
from colloc.data.trial import Trial


def make_trial(num_samples: int = 1201, step: float = 0.01) -> Trial:
    """Trial on 0..12 s; right strikes every 1.1 s from 0.5 s, left half a stride later."""
    time = np.arange(num_samples) * step
    signals = pd.DataFrame({name: np.sin(time + j) for j, name in enumerate(REQUIRED_COLUMNS)})
    right = 0.5 + 1.1 * np.arange(11)
    left = np.append(1.05 + 1.1 * np.arange(8), [9.005, 10.95])
    right, left = right[right <= time[-1]], left[left <= time[-1]]
    metadata = {"sample_rate": 1.0 / step, "controller": {"gains": [1.0, 2.0]}}
    return Trial(time, signals, right, left, metadata)


def test_split_three_quarters() -> None:
    trial = make_trial()
    fit, validate = split(trial)
    # round(0.75 * 1201) = 901 samples: 0..9.00 s; the rest 9.01..12.00 s.
    assert fit.time.size == 901 and validate.time.size == 300
    assert fit.time[-1] == pytest.approx(9.0) and validate.time[0] == pytest.approx(9.01)
    np.testing.assert_array_equal(
        fit.signals.to_numpy(), np.sin(fit.time[:, None] + np.arange(len(REQUIRED_COLUMNS)))
    )
    np.testing.assert_array_equal(
        validate.signals.to_numpy(),
        np.sin(validate.time[:, None] + np.arange(len(REQUIRED_COLUMNS))),
    )
    assert list(validate.signals.index) == list(range(300))
    np.testing.assert_allclose(fit.right_heel_strikes, 0.5 + 1.1 * np.arange(8))
    np.testing.assert_allclose(validate.right_heel_strikes, [9.3, 10.4, 11.5])
    # The strike at 9.005 s lies between the two parts' samples and is dropped.
    np.testing.assert_allclose(fit.left_heel_strikes, 1.05 + 1.1 * np.arange(8))
    np.testing.assert_allclose(validate.left_heel_strikes, [10.95])
    assert fit.metadata["split"] == {"part": "fit", "fit_fraction": 0.75}
    assert validate.metadata["split"]["part"] == "validate"
    fit.metadata["controller"]["gains"].append(3.0)
    assert trial.metadata["controller"]["gains"] == [1.0, 2.0]
    assert "split" not in trial.metadata
    fit.validate()
    validate.validate()


@pytest.mark.parametrize("fraction", [0.0, 1.0, -0.25, 1.5, float("nan")])
def test_fraction_outside_unit_interval(fraction: float) -> None:
    with pytest.raises(ValueError, match="fit_fraction must lie strictly between 0 and 1"):
        split(make_trial(), fraction)


def test_fraction_must_be_a_number() -> None:
    with pytest.raises(TypeError, match="fit_fraction must be a number, found str"):
        split(make_trial(), "0.75")  # type: ignore[arg-type]


def test_too_few_strides_in_validation_part() -> None:
    # round(0.85 * 1201) = 1021 samples: fit 0..10.20 s holds 9 right strikes (8 strides),
    # validation 10.21..12 s holds 10.4 and 11.5 s (1 stride).
    with pytest.raises(ValueError, match="leaves 8 complete strides in the fit part and 1 in"):
        split(make_trial(), 0.85)
    # and how long a trial would do: 2 + 1 strides of 1.1 s in the 15 % held out, 22 s
    with pytest.raises(
        ValueError, match=r"a trial of about 22 s or longer at this trial's stride of 1\.10 s"
    ):
        split(make_trial(), 0.85)


def test_too_few_strides_in_fit_part() -> None:
    # round(0.15 * 1201) = 180 samples: fit 0..1.79 s holds 0.5 and 1.6 s (1 stride).
    with pytest.raises(ValueError, match="leaves 1 complete strides in the fit part and 8"):
        split(make_trial(), 0.15)


def test_too_few_samples() -> None:
    trial = make_trial(num_samples=5)
    with pytest.raises(ValueError, match="leaves 0 fit and 5 validation samples"):
        split(trial, 0.05)


@pytest.mark.parametrize("per_window", [1, 2, 3, 4, 8])
def test_stride_windows_tile_the_record_from_right_heel_strikes(per_window):
    times = np.arange(1201) * 0.01  # 0..12 s
    strikes = 0.5 + 1.1 * np.arange(11)  # 10 strides, the last strike at 11.5 s
    windows = stride_windows(times, strikes, per_window)
    assert windows[0][0] == 0 and windows[-1][1] == times.size
    for (_, stop), (first, _) in zip(windows[:-1], windows[1:], strict=True):
        assert stop == first  # consecutive, disjoint
        # each later window starts at the sample of a right heel strike
        assert np.min(np.abs(strikes - times[first])) < 1e-9
    for first, stop in windows:
        end = times[min(stop, times.size - 1)]  # the next window's first strike, or the end
        whole = np.count_nonzero((strikes >= times[first] - 1e-9) & (strikes <= end + 1e-9)) - 1
        # every window holds at least per_window whole strides, fewer than 2 per_window
        # (one window: all of them)
        assert per_window <= whole and (whole < 2 * per_window or len(windows) == 1)
    expected = 10 // per_window if 10 >= 2 * per_window else 1
    assert len(windows) == expected
    # as even as whole strides allow: window lengths differ by at most one stride
    wholes = [
        np.count_nonzero((strikes >= times[a] - 1e-9) & (strikes <= times[min(b, 1200)] + 1e-9)) - 1
        for a, b in windows
    ]
    assert max(wholes) - min(wholes) <= 1 and sum(wholes) == 10


def test_stride_windows_refuse_what_cannot_be_cut():
    times = np.arange(100) * 0.01
    with pytest.raises(ValueError, match="strides_per_window: expected a whole number >= 1"):
        stride_windows(times, [0.1, 0.5], 0)
    with pytest.raises(ValueError, match="strides_per_window"):
        stride_windows(times, [0.1, 0.5], 1.5)
    with pytest.raises(ValueError, match="times: expected at least two increasing"):
        stride_windows(times[::-1], [0.1, 0.5], 1)


def test_take_rows_keeps_the_strikes_inside_and_its_own_metadata():
    from colloc.data.split import take_rows

    trial = make_trial()
    trial.metadata["nested"] = {"a": [1]}
    piece = take_rows(trial, np.arange(250, 500))  # 2.5 .. 4.99 s
    np.testing.assert_array_equal(piece.time, trial.time[250:500])
    assert list(piece.signals.index) == list(range(250))
    np.testing.assert_array_equal(piece.signals.to_numpy(), trial.signals.iloc[250:500].to_numpy())
    np.testing.assert_allclose(piece.right_heel_strikes, [2.7, 3.8, 4.9])
    np.testing.assert_allclose(piece.left_heel_strikes, [3.25, 4.35])
    piece.metadata["nested"]["a"].append(2)
    assert trial.metadata["nested"] == {"a": [1]}  # a copy, not shared
