"""The resampling of the compiled particle filters (fuse/pf_kernel.py): the schemes of
filters/resampling.py drawing the same uniforms from the same splitmix stream
(filters/splitmix.py). The resampled particles are gathered in fuse/pf_kernel.py's passes
that use them (_gather_predict, _gather_walk)."""

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
    work (3, N) floats, start (2N + 2,) int."""
    n = w.size
    cdf = work[2]
    if scheme == 0:
        _residual(w, s, idx, work, start)
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
def _residual(w, s, idx, work, start):
    """Residual resampling (Liu & Chen 1998), filters/resampling.residual: floor(N w_i) copies
    of each particle, then R = N − Σ floor(N w_i) draws from the fractional parts, emitted in
    ascending order as the reference's searchsorted of its sorted uniforms emits them. The
    draws are counted per particle instead of sorted: each u_j·top is looked up in the
    cumulative fractional parts from a bucket table (one bucket per particle, filled in the
    cumulative sum's own pass) and walked to searchsorted's exact answer, #{cdf ≤ u_j·top}
    (at most N − 1): one step without a branch, then the rest (one step: 4.31 against 4.66 µs
    a call for three, 500 particles, circle-01's weights). start (2N + 2,) int work."""
    n = w.size
    nw, cdf = work[1], work[2]
    k = n - np.int64(_floors(w, _total(w), nw, cdf))
    first, pos = start[:n + 1], start[n + 1:2 * n + 1]
    first[:] = 0
    scale = n / k if k > 0 else 0.0  # ≈ N / Σ frac, the buckets' scale (they only guide)
    m, acc = 0, 0.0
    for i in range(n):  # serial: the copies, the cumulative sum, its buckets (NaN: 0)
        m = _emit(idx, m, i, np.int64(nw[i]))
        acc += cdf[i]
        cdf[i] = acc
        first[max(0, min(np.int64(acc * scale), n - 1)) + 1] += 1
    k = n - m
    if k <= 0:
        return
    for b in range(n):  # first[b]: how many cdf entries lie below bucket b
        first[b + 1] += first[b]
    u, top = work[0, :k], cdf[n - 1]
    fill_random(s, u)
    for j in range(k):  # a bucket holds about one entry: one step, then the rare rest
        v = u[j] * top
        i = first[min(np.int64(u[j] * n), n - 1)]
        if i < 0:  # never (first ≥ 0): an exit that keeps LLVM from vectorising the loop,
            break  # whose dependent gathers are slower than loads one at a time
        pos[j] = i + np.int64((i < n) & (cdf[min(i, n - 1)] <= v))
    counts = first[:n]
    counts[:] = 0
    for j in range(k):  # the rare rest, and round-off at bucket edges; then count
        i, v = pos[j], u[j] * top
        while i < n and cdf[i] <= v:
            i += 1
        while i > 0 and cdf[i - 1] > v:
            i -= 1
        counts[min(i, n - 1)] += 1
    for i in range(n):
        m = _emit(idx, m, i, counts[i])


@njit(cache=True, error_model="numpy", fastmath=SUMS)
def _floors(w, total, nw, frac):
    """nw_i = floor(N w_i / total) and frac_i = N w_i / total − nw_i (SIMD, w_i · (N / total),
    a multiply as the reference's); returns Σ nw."""
    n, m, c = w.size, 0.0, w.size / total
    for i in range(n):
        v = w[i] * c
        f = np.floor(v)
        nw[i], frac[i] = f, v - f
        m += f
    return m


@njit(cache=True, inline="always")
def _emit(idx, m, i, c):
    """idx[m : m + c] = i; returns m + c. Without a branch for the usual c ≤ 2: idx[m] and
    idx[m + 1] are written whatever c (a later particle overwrites what was not its)."""
    n = idx.size
    if m < n:
        idx[m] = i
    if m + 1 < n:
        idx[m + 1] = i
    for t in range(m + 2, m + c):
        idx[t] = i
    return m + c


@njit(cache=True, error_model="numpy", fastmath=SUMS)
def _total(w):
    s = 0.0
    for i in range(w.size):  # by index: LLVM vectorises this, not numba's array iterator
        s += w[i]
    return s
