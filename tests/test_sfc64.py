"""filters/sfc64.py, the generator the compiled particle filters draw from inline, against
numpy itself: the same seed gives bit for bit the normals and uniforms of
np.random.Generator(np.random.SFC64(seed)), and leaves the generator where numpy's would be."""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.filters import sfc64


@pytest.mark.parametrize("seed", [0, 12345])
def test_normals_are_numpys_bit_for_bit(seed):
    """2.4 million draws: about 1 % take the ziggurat's wedge test and a few hundred its tail
    beyond r = 3.65, so every path of numpy's algorithm is compared."""
    ref = np.random.Generator(np.random.SFC64(seed))
    rng = sfc64.generator(seed)
    state = sfc64.get_state(rng)
    out = np.empty((200_000, 12))
    sfc64.fill_normals(state, out)
    expect = ref.standard_normal((200_000, 12))
    assert np.array_equal(out, expect)
    assert (np.abs(expect) > 3.6541528853610088).sum() > 100  # the tail was exercised
    sfc64.set_state(rng, state)
    assert rng.random() == ref.random()  # the state handed back is numpy's


def test_a_transposed_array_is_filled_in_draw_order():
    ref = np.random.Generator(np.random.SFC64(3))
    state = sfc64.get_state(sfc64.generator(3))
    eps = np.empty((12, 50))
    sfc64.fill_normals(state, eps.T)  # as the kernel fills its (12, N) rows
    np.testing.assert_array_equal(eps, ref.standard_normal((50, 12)).T)


def test_uniforms_are_numpys_bit_for_bit():
    ref = np.random.Generator(np.random.SFC64(7))
    state = sfc64.get_state(sfc64.generator(7))
    out = np.empty(100_000)
    sfc64.fill_random(state, out)
    assert np.array_equal(out, ref.random(100_000))
    assert sfc64.random(state) == ref.random()


def test_only_an_sfc64_state_is_taken():
    with pytest.raises(TypeError, match="SFC64"):
        sfc64.get_state(np.random.default_rng(0))
