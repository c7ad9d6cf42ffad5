"""The suite's own helpers (tests/conftest.py): what ``assert_close`` lets through and what not."""

import numpy as np
import pytest
from conftest import assert_close


def test_assert_close_holds_to_its_bound():
    """|actual - expected| <= atol + rtol |expected|, per element (atol may be an array); beyond
    it, or with another shape, it fails."""
    expected = np.array([1.0, -2.0, 0.0])
    assert_close(expected + [1e-6, -2e-6, 0.0], expected, rtol=1e-6, what="on the bound")
    assert_close(expected + [0.0, 0.0, 3e-9], expected, rtol=0.0, atol=np.array([0.0, 0.0, 3e-9]), what="per element")
    for actual, atol in ((expected + [0.0, 0.0, 1e-300], 0.0), (expected + [2e-6, 0.0, 0.0], 0.0),
                         (expected[:2], 1.0)):
        with pytest.raises(AssertionError):
            assert_close(actual, expected, rtol=1e-6, atol=atol, what="beyond")


def test_assert_close_fails_on_nan_unless_asked():
    """A NaN fails on either side and on both (before, NaN against NaN passed: a comparison of two
    failed fits checked nothing); with equal_nan=True NaN equals NaN, and nothing else."""
    for actual, expected in ((np.nan, np.nan), ([1.0, np.nan], [1.0, np.nan]), (np.nan, 1.0), (1.0, np.nan),
                             ([np.nan + 0j], [np.nan + 0j])):
        with pytest.raises(AssertionError, match="NaN"):
            assert_close(actual, expected, rtol=1.0, atol=1.0, what="NaN")
    assert_close([1.0, np.nan], [1.0 + 1e-13, np.nan], rtol=1e-12, what="NaN where both are", equal_nan=True)
    for actual, expected in (([np.nan], [1.0]), ([1.0], [np.nan]), ([np.nan, 1.0], [np.nan, 2.0])):
        with pytest.raises(AssertionError):
            assert_close(actual, expected, rtol=1e-12, what="NaN against a number", equal_nan=True)
    assert_close(np.arange(3), np.arange(3), rtol=0.0, what="integers", equal_nan=True)
