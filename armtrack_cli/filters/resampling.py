"""Resampling schemes, by name. Each takes normalised weights (N,) and a generator and returns
ancestor indices (N,) such that E[count of i] = N · w_i (all four are unbiased; see
tests/test_resampling.py, which checks that statistically).

References: Douc, Cappé & Moulines (2005), "Comparison of resampling schemes for particle
filtering"; Liu & Chen (1998) for residual resampling.
"""

from __future__ import annotations

import numpy as np


def _search(cdf: np.ndarray, u: np.ndarray) -> np.ndarray:
    idx = np.searchsorted(cdf, u, side="right")
    return np.minimum(idx, cdf.size - 1)


def _cdf(w: np.ndarray) -> np.ndarray:
    c = np.cumsum(w)
    return c / c[-1]


def multinomial(w: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """N independent draws from the weights. (The uniforms are sorted before the search:
    the draws are exchangeable, so the offspring counts have the same law, and a search with
    sorted keys is faster.)"""
    return _search(_cdf(w), np.sort(rng.random(w.size)))


def stratified(w: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One uniform draw in each of N equal strata of [0, 1)."""
    n = w.size
    return _search(_cdf(w), (np.arange(n) + rng.random(n)) / n)


def systematic(w: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One uniform offset shared by N evenly spaced points."""
    n = w.size
    return _search(_cdf(w), (np.arange(n) + rng.random()) / n)


def residual(w: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """floor(N w_i) copies of each particle, then the R = N − Σ floor(N w_i) left over drawn
    multinomially from the residual weights (N w_i − floor(N w_i)) / R.

    E[count_i] = floor(N w_i) + R · (N w_i − floor(N w_i)) / R = N w_i: unbiased. (The
    residual draws must use the renormalised fractional parts with R draws; drawing them
    with weights that were not renormalised, or a fixed count, biases the counts.)
    """
    n = w.size
    nw = w * (n / w.sum())  # N w_i, by a multiply as the compiled kernel's
    counts = nw.astype(np.int64)  # floor, the weights being non-negative
    det = np.repeat(np.arange(n), counts)
    k = n - det.size
    if k == 0:
        return det
    cdf = np.cumsum(nw - counts)
    extra = np.searchsorted(cdf, np.sort(rng.random(k)) * cdf[-1], side="right")
    return np.concatenate([det, np.minimum(extra, n - 1)])


SCHEMES = {"residual": residual, "systematic": systematic, "stratified": stratified,
           "multinomial": multinomial}


def scheme(name: str):
    try:
        return SCHEMES[name]
    except KeyError:
        raise ValueError(f"unknown resampling scheme {name!r}; schemes are "
                         f"{', '.join(SCHEMES)}") from None
