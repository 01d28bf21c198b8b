"""The resampling of the compiled particle filters (fuse/pf_kernel.py): the schemes of
filters/resampling.py drawing the same uniforms from the inline SFC64 generator
(filters/splitmix.py), and the gather of the resampled particles (6, N)."""

from __future__ import annotations

import numpy as np
from numba import njit

from armtrack_cli.filters.splitmix import fill_random
from armtrack_cli.filters.splitmix import random as uniform

RESAMPLING = {"residual": 0, "systematic": 1, "stratified": 2, "multinomial": 3}
SUMS = {"reassoc"}  # sums over particles may be reordered (vectorised): round-off only
# error_model="numpy" everywhere: x / 0 is inf as in numpy, not Python's ZeroDivisionError,
# whose check keeps LLVM from vectorising any loop that divides


@njit(cache=True, error_model="numpy")
def _search_sorted_keys(cdf, u, idx, start):
    """idx[start + j] = min(#{cdf ≤ u_j}, N − 1) for sorted u: searchsorted(side="right")
    by one merge walk."""
    n, i = cdf.size, 0
    for j in range(u.size):
        while i < n and cdf[i] <= u[j]:
            i += 1
        idx[start + j] = min(i, n - 1)


@njit(cache=True, error_model="numpy")
def _sorted_uniforms(s, k, work, start):
    """np.sort(rng.random(k)) into work[0, :k], by bucket sort, O(k) for uniforms: the same
    array, faster. work (3, N) floats (rows: u, sorted, cdf), start (N + 1,) int."""
    u, out, start = work[0, :k], work[1, :k], start[:k + 1]
    fill_random(s, u)
    start[:] = 0
    for v in u:
        start[int(v * k) + 1] += 1
    for b in range(k):
        start[b + 1] += start[b]
    for v in u:
        b = int(v * k)
        out[start[b]] = v
        start[b] += 1
    for i in range(1, k):  # insertion sort: out of order only within a bucket
        v, j = out[i], i - 1
        while j >= 0 and out[j] > v:
            out[j + 1] = out[j]
            j -= 1
        out[j + 1] = v
    u[:] = out
    return u


@njit(cache=True, error_model="numpy")
def _resample(w, s, scheme, idx, work, start):
    """Ancestor indices into idx (N,), as filters/resampling.py, drawing the same uniforms;
    work (3, N) and start (N + 1,) as _sorted_uniforms takes them."""
    n = w.size
    cdf = work[2]
    if scheme == 0:  # residual: floor(N w_i) copies, then R leftovers (Liu & Chen 1998)
        total, nw = _total(w), work[1]
        for i in range(n):  # N w_i and its fractional part (SIMD)
            nw[i] = n * (w[i] / total)
            cdf[i] = nw[i] - np.floor(nw[i])
        m, acc = 0, 0.0
        for i in range(n):
            for _ in range(np.int64(nw[i])):
                idx[m] = i
                m += 1
            acc += cdf[i]
            cdf[i] = acc
        k = n - m
        if k == 0:
            return
        u = _sorted_uniforms(s, k, work, start)
        top = cdf[-1]
        for j in range(k):
            u[j] *= top
        _search_sorted_keys(cdf, u, idx, m)
        return
    acc = 0.0
    for i in range(n):
        acc += w[i]
        cdf[i] = acc
    for i in range(n):
        cdf[i] /= acc
    if scheme == 3:  # multinomial, sorted draws
        u = _sorted_uniforms(s, n, work, start)
    else:
        u = work[0, :n]
        if scheme == 1:  # systematic: one offset for N evenly spaced points
            u0 = uniform(s)
            for i in range(n):
                u[i] = (i + u0) / n
        else:  # stratified: one uniform in each of N strata
            fill_random(s, u)
            for i in range(n):
                u[i] = (i + u[i]) / n
    _search_sorted_keys(cdf, u, idx, 0)


@njit(cache=True, error_model="numpy")
def _take(xs, idx, out):
    """out = xs[:, idx] (the resampled particles, (6, N))."""
    for j in range(6):
        for i in range(idx.size):
            out[j, i] = xs[j, idx[i]]


@njit(cache=True, error_model="numpy", fastmath=SUMS)
def _total(w):
    s = 0.0
    for v in w:
        s += v
    return s
