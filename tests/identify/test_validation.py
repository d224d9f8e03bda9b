"""Validation metrics against hand-computed values."""

import numpy as np
import pytest

from colloc.identify.validation import rms, variance_accounted_for


def test_vaf_matches_its_definition_per_column():
    rng = np.random.default_rng(0)
    y = rng.standard_normal((500, 3)) * [1.0, 2.0, 3.0]
    error = rng.standard_normal((500, 3)) * 0.1
    vaf = variance_accounted_for(y, y - error)
    expected = [1 - np.var(error[:, j]) / np.var(y[:, j]) for j in range(3)]
    np.testing.assert_allclose(vaf, expected, rtol=1e-12)
    assert variance_accounted_for(y[:, 0], y[:, 0]) == 1.0
    # a prediction equal to the mean accounts for nothing; a worse one for less
    assert variance_accounted_for(y[:, 0], np.full(500, y[:, 0].mean())) == pytest.approx(0.0)
    assert variance_accounted_for(y[:, 0], -y[:, 0]) < 0


def test_vaf_of_a_constant_column_is_nan_and_bad_shapes_are_named():
    y = np.ones((10, 2))
    y[:, 1] = np.arange(10)
    out = variance_accounted_for(y, y)
    assert np.isnan(out[0]) and out[1] == 1.0
    with pytest.raises(ValueError, match="equal shapes"):
        variance_accounted_for(np.ones((4, 2)), np.ones((4, 3)))
    with pytest.raises(ValueError, match="finite"):
        variance_accounted_for([1.0, np.nan], [1.0, 2.0])


def test_rms_per_column():
    np.testing.assert_allclose(rms([[3.0, 1.0], [4.0, -1.0]]), [np.sqrt(12.5), 1.0])
