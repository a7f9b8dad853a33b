"""sorted_quantiles is np.quantile to the last bit, only faster."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from vsmp_imu.quantiles import sorted_quantiles

FLOATS = st.floats(-1e6, 1e6, allow_nan=False, width=32)


@settings(max_examples=300, deadline=None, derandomize=True)
@given(
    values=hnp.arrays(st.sampled_from([np.float32, np.float64]),
                      hnp.array_shapes(min_dims=1, max_dims=3, min_side=1, max_side=9), elements=FLOATS),
    probs=st.lists(st.floats(0.0, 1.0), min_size=1, max_size=12),
    method=st.sampled_from(["linear", "hazen"]),
    data=st.data(),
)
def test_equals_numpy_quantile(values, probs, method, data):
    axis = data.draw(st.integers(0, values.ndim - 1))
    probs = np.array(probs)
    expected = np.quantile(values, probs, axis=axis, method=method)
    got = sorted_quantiles(values, probs, axis=axis, method=method)
    assert got.dtype == expected.dtype
    assert np.array_equal(got, expected)


def test_ties_and_nan_slices_as_numpy():
    values = np.array([[1.0, 2.0, np.nan], [1.0, 2.0, 3.0], [1.0, 5.0, 4.0], [1.0, 2.0, 0.0]])
    probs = np.array([0.0, 0.1, 0.5, 0.9, 1.0])
    for method in ("linear", "hazen"):
        expected = np.quantile(values, probs, axis=0, method=method)
        assert np.array_equal(sorted_quantiles(values, probs, 0, method), expected, equal_nan=True)
    assert np.isnan(sorted_quantiles(values, probs, 0)[:, 2]).all()


def test_large_grid_equal():
    rng = np.random.default_rng(3)
    values = np.round(rng.normal(size=(20000, 3)), 2)  # quantized: many ties
    probs = np.concatenate([[0.0], (np.arange(4096) + 0.5) / 4096, [1.0]])
    assert np.array_equal(sorted_quantiles(values, probs, 0, "hazen"),
                          np.quantile(values, probs, axis=0, method="hazen"))


def test_unknown_method_is_an_error():
    with pytest.raises(ValueError, match="method"):
        sorted_quantiles(np.arange(5.0), np.array([0.5]), method="nearest")
