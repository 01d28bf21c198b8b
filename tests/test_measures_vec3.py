"""measures/vec3.py against numpy's reductions it replaces: the same bits, on vectors of
every scale (and NaN, inf), in one trajectory's shape and a block of draws'."""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.measures.vec3 import dot3, norm3


@pytest.mark.parametrize("shape", [(3,), (500, 3), (4, 700, 3), (2, 1, 5, 3)])
def test_dot3_and_norm3_are_numpys_sum_and_norm(shape):
    rng = np.random.default_rng(len(shape))
    a = rng.standard_normal(shape) * 10.0 ** rng.uniform(-9, 9, shape)
    b = rng.standard_normal(shape) * 10.0 ** rng.uniform(-9, 9, shape)
    if a.ndim > 1:
        a[0, ..., 1], b[-1, ..., 2] = np.nan, np.inf
    np.testing.assert_array_equal(dot3(a, b), np.sum(a * b, -1))
    np.testing.assert_array_equal(norm3(a), np.linalg.norm(a, axis=-1))
    if a.size > 1000:  # the test can tell: another order of the terms differs in last bits
        x = a[..., 0] * b[..., 0] + (a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2])
        assert not np.array_equal(dot3(a, b), x, equal_nan=True)
