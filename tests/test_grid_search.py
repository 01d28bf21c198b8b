"""core/grid_search.coarse_to_fine against scoring the whole grid."""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.core.grid_search import coarse_to_fine


def _counted(f):
    calls = []

    def g(i):
        calls.append(i)
        return f(i)
    return g, calls


@pytest.mark.parametrize("seed", range(5))
def test_finds_the_whole_grids_minimum_with_fewer_evaluations(seed):
    """A cost smooth over the coarse step with several basins (a sum of wide wells)."""
    rng = np.random.default_rng(seed)
    x = np.linspace(-3, 3, 181)
    centres, depths = rng.uniform(-3, 3, 4), rng.uniform(0.5, 1.5, 4)
    full = 2.0 - sum(d * np.exp(-((x - c) / 0.4) ** 2) for c, d in zip(centres, depths))
    cost, calls = _counted(lambda i: float(full[i]))
    costs = coarse_to_fine(x.size, cost, every=3, radius=3, basins=2)
    assert int(np.argmin(costs)) == int(np.argmin(full))
    assert len(calls) == len(set(calls)) < x.size / 2  # each at most once
    assert np.array_equal(costs[np.isfinite(costs)], full[np.isfinite(costs)])
    rough, r_calls = _counted(lambda i: float(full[i]))
    cost, calls = _counted(lambda i: float(full[i]))
    costs = coarse_to_fine(x.size, cost, every=3, radius=3, basins=2, rough=rough)
    assert int(np.argmin(costs)) == int(np.argmin(full))
    assert r_calls == list(range(0, x.size, 3))  # the rough pass: the coarse candidates


def test_with_last_scores_the_end_and_refines_about_the_single_best():
    full = np.abs(np.arange(10) - 9.0)  # minimum at the last candidate, off the coarse step
    cost, calls = _counted(lambda i: float(full[i]))
    costs = coarse_to_fine(10, cost, every=4, radius=3, with_last=True)
    assert calls == [0, 4, 8, 9, 6, 7]  # coarse in order, then about the best, once each
    assert int(np.argmin(costs)) == 9 and np.isinf(costs[[1, 2, 3, 5]]).all()


def test_nothing_finite_coarsely():
    """Without a rough cost nothing more is scored; with one, every candidate is."""
    cost, calls = _counted(lambda i: np.inf)
    assert np.isinf(coarse_to_fine(7, cost, every=3, radius=2)).all() and calls == [0, 3, 6]
    cost, calls = _counted(lambda i: float(i))
    costs = coarse_to_fine(7, cost, every=3, radius=2, rough=lambda i: np.inf)
    assert np.array_equal(costs, np.arange(7.0)) and calls == list(range(7))
