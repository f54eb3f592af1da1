"""The strapdown's written-out cross product (``ins.strapdown._cross``) is numpy's, bit for bit, for every broadcast
the mechanization uses (a rate (3,) against (R, 3) states, (R, 3) against (R, 3))."""

import numpy as np
import pytest

from sarnav.ins.strapdown import _cross


@pytest.mark.parametrize("shape_a, shape_b", [((6, 3), (6, 3)), ((3,), (6, 3)), ((6, 3), (3,)), ((1, 3), (4, 3))])
def test_cross_is_numpys_bit_for_bit(shape_a, shape_b):
    rng = np.random.default_rng(7)
    a = rng.standard_normal(shape_a) * 10.0 ** rng.integers(-6, 6, shape_a)
    b = rng.standard_normal(shape_b) * 10.0 ** rng.integers(-6, 6, shape_b)
    want = np.cross(a, b)
    got = _cross(a, b)
    assert got.shape == want.shape and np.array_equal(got, want)
    assert np.allclose(np.einsum("...i,...i", got, a), 0.0, atol=1e-9 * np.abs(a).max() * np.abs(b).max())
