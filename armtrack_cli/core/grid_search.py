"""A coarse-to-fine search over a grid of candidates (the clock offsets of fuse/imu_sync.py and
compare/sync.py): score every ``every``-th candidate (cheaply, with ``rough``, where given),
then every candidate within ``radius`` of the best few coarse minima; a cost smooth over
``every`` candidates has its minimum there, for a fraction of the evaluations."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def coarse_to_fine(n: int, cost: Callable[[int], float], *, every: int, radius: int,
                   basins: int = 1, rough: Callable[[int], float] | None = None,
                   with_last: bool = False) -> np.ndarray:
    """Costs (n,) of candidates 0 … n − 1, inf where not evaluated.

    The coarse pass scores candidates 0, every, 2·every, … (and n − 1 ``with_last``) by
    ``rough`` (kept apart: a cheaper cost, e.g. on fewer samples) or by ``cost`` (kept). Its
    local minima (≤ both coarse neighbours, finite), lowest first (ties in index order), give
    up to ``basins`` centres; every candidate within ``radius`` of a centre not yet scored by
    ``cost`` is, in increasing order, centre by centre. When ``rough`` scores nothing finite,
    every candidate is scored by ``cost``; without ``rough``, nothing more is. ``cost`` is
    called in that order (a caller may carry state from one call to the next)."""
    coarse = np.arange(0, n, every)
    if with_last:
        coarse = np.unique(np.r_[coarse, n - 1])
    costs = np.full(n, np.inf)
    done = np.zeros(n, bool)
    first = np.array([(rough or cost)(int(i)) for i in coarse], float)
    if rough is None:
        costs[coarse], done[coarse] = first, True
    if not np.isfinite(first).any():
        return costs if rough is None else np.array([cost(i) for i in range(n)], float)
    inner = np.r_[np.inf, first, np.inf]
    dips = np.flatnonzero((first <= inner[:-2]) & (first <= inner[2:]) & np.isfinite(first))
    for c in coarse[dips[np.argsort(first[dips], kind="stable")][:basins]]:
        for j in range(max(c - radius, 0), min(c + radius + 1, n)):
            if not done[j]:
                costs[j], done[j] = cost(j), True
    return costs
