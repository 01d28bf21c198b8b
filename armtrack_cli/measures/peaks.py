"""Peaks of a sampled signal with a least prominence and a least spacing, in numpy alone: the
peaks ``scipy.signal.find_peaks(x, prominence=p, distance=d)`` returns, by its own rules
(a flat top's middle sample, the higher peak kept first when two are closer than d, then
the prominence over the lowest point to each side before a higher sample), without
importing scipy.signal (over a second). tests/test_peaks.py holds it to scipy's answer."""

from __future__ import annotations

import numpy as np

GRID_MAX = 200_000  # peaks × samples up to which prominences are found on one grid
TABLE_MAX = 1 << 15  # samples up to which they are found on sparse tables (8 MB at most)
#                      as they stand; a longer signal is first cut down to its maxima


def local_maxima(x: np.ndarray) -> np.ndarray:
    """Indices of the samples above both neighbours; a flat top (a run of equal samples with
    lower ones on both sides) gives its middle sample, rounded down."""
    n = x.size
    if n < 3:
        return np.zeros(0, int)
    starts = np.flatnonzero(np.r_[True, x[1:] != x[:-1]])  # runs of equal samples
    ends = np.r_[starts[1:] - 1, n - 1]
    inner = (starts > 0) & (ends < n - 1)
    starts, ends = starts[inner], ends[inner]
    peak = (x[starts - 1] < x[starts]) & (x[ends + 1] < x[ends])
    return (starts[peak] + ends[peak]) // 2


def by_distance(peaks: np.ndarray, height: np.ndarray, distance: int) -> np.ndarray:
    """Boolean mask over ``peaks``: the highest kept first, its neighbours closer than
    ``distance`` samples dropped (ties in the order np.argsort gives, as scipy's)."""
    keep = np.ones(peaks.size, bool)
    lo = np.searchsorted(peaks, peaks - distance, side="right")  # the first closer than it
    hi = np.searchsorted(peaks, peaks + distance, side="left")  # past the last closer
    for j in np.argsort(height)[::-1].tolist():
        if keep[j]:
            keep[lo[j]:j] = False
            keep[j + 1:hi[j]] = False
    return keep


def _maxima_and_valleys(x: np.ndarray, peaks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(y, at): x cut down to its local maxima and its two ends, each two of them with the
    lowest sample of x from the first up to the second between them, and where ``peaks``
    (local maxima of x) lie in y. Every peak has the prominence in y that it has in x: between
    two neighbouring maxima x has no other maximum, so no sample there is higher than both;
    a search from a peak stops at the first maximum higher than it (the samples before it
    on that side that are higher still lead up to it) and passes every lowest sample on its
    way. Comparisons and minima only: exactly the values of x. A 60-minute session's speed
    (108,000 samples) has a few thousand maxima."""
    cand = np.union1d(local_maxima(x), [0, x.size - 1])
    y = np.empty(2 * cand.size - 1)
    y[0::2] = x[cand]
    y[1::2] = np.minimum.reduceat(x, cand)[:-1]  # min x[cand[k] : cand[k + 1]]
    return y, 2 * np.searchsorted(cand, peaks)


def _table(x: np.ndarray, op) -> list[np.ndarray]:
    """Sparse table of ``op`` (np.maximum or np.minimum): level j holds op over x[i : i + 2^j]."""
    out = [x]
    while (1 << len(out)) <= x.size:
        h = 1 << (len(out) - 1)
        out.append(op(out[-1][:-h], out[-1][h:]))
    return out


def _range_min(mins: list[np.ndarray], lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """min x[lo : hi] (hi > lo) from the table of minima: two blocks of 2^j covering it."""
    j = np.frexp(hi - lo)[1] - 1  # ⌊log2(hi − lo)⌋, exactly
    out = np.empty(lo.size)
    for lev in np.unique(j).tolist():
        s = j == lev
        m = mins[lev]
        out[s] = np.minimum(m[lo[s]], m[hi[s] - (1 << lev)])
    return out


def _prominences_table(x: np.ndarray, peaks: np.ndarray) -> np.ndarray:
    """prominences() for many peaks on a long signal: each side's run of samples not higher
    than the peak found by binary lifting over a sparse table of maxima (the longest block
    first), its minimum from a sparse table of minima. Exact: maxima, minima and comparisons
    only, so the values are the grid's."""
    n, top = x.size, x[peaks]
    maxs, mins = _table(x, np.maximum), _table(x, np.minimum)
    lo, hi = peaks.copy(), peaks + 1  # x[lo : p] and x[p + 1 : hi] not higher than x[p]
    for lev in range(len(maxs) - 1, -1, -1):
        m, w = maxs[lev], 1 << lev
        c = lo - w
        ok = c >= 0
        ok[ok] = m[c[ok]] <= top[ok]
        lo[ok] = c[ok]
        ok = hi + w <= n
        ok[ok] = m[hi[ok]] <= top[ok]
        hi[ok] += w
    return top - np.maximum(_range_min(mins, lo, peaks + 1), _range_min(mins, peaks, hi))


def prominences(x: np.ndarray, peaks: np.ndarray) -> np.ndarray:
    """Each peak's height above the higher of the lowest points to its left and right, each
    searched up to the first sample higher than the peak; ``peaks`` are local maxima of x.
    All peaks at once on a (peaks, samples) grid when that is small (a segment's: the same
    samples' minimum, so the same values), else on sparse tables (``_prominences_table``),
    of x itself or, for a long x, of its maxima and the valleys between them."""
    if peaks.size * x.size > GRID_MAX:
        if x.size <= TABLE_MAX:
            return _prominences_table(x, peaks)
        return _prominences_table(*_maxima_and_valleys(x, peaks))
    i = np.arange(x.size)
    top = x[peaks][:, None]
    higher = x[None, :] > top  # (k, n)
    left, right = higher & (i < peaks[:, None]), higher & (i > peaks[:, None])
    # the first sample of each side's run: after the last higher one left, before the first
    # higher one right (or the ends)
    lo = np.where(left.any(axis=1), x.size - 1 - np.argmax(left[:, ::-1], axis=1) + 1, 0)
    hi = np.where(right.any(axis=1), np.argmax(right, axis=1), x.size)
    xs = np.broadcast_to(x, higher.shape)
    lmin = np.where((i >= lo[:, None]) & (i <= peaks[:, None]), xs, np.inf).min(axis=1)
    rmin = np.where((i >= peaks[:, None]) & (i < hi[:, None]), xs, np.inf).min(axis=1)
    return x[peaks] - np.maximum(lmin, rmin)


def find_peaks(x: np.ndarray, *, prominence: float, distance: int) -> np.ndarray:
    """Indices of the local maxima of x (N,) at least ``distance`` samples apart (≥ 1) whose
    prominence is at least ``prominence``."""
    x = np.asarray(x, float)
    peaks = local_maxima(x)
    if distance > 1 and peaks.size > 1:
        peaks = peaks[by_distance(peaks, x[peaks], int(np.ceil(distance)))]
    return peaks[prominences(x, peaks) >= prominence] if peaks.size else peaks


def count_peaks_rows(x: np.ndarray, start: np.ndarray, length: np.ndarray, *,
                     prominence: float, distance: int) -> np.ndarray:
    """(R,) how many peaks ``find_peaks`` gives on each row's stretch x[r, start[r] : start[r]
    + length[r]] of x (R, W), for many rows at once: the stretches laid end to end with +inf
    between them (no peak touches one, no search passes one, and ≥ ``distance`` apart no peak
    of one row is closer than ``distance`` to another's), a block of rows at a time
    (≤ TABLE_MAX samples each, for the sparse tables). Peaks of exactly equal height closer
    than ``distance`` may be taken in another order than one row alone takes them."""
    R, W = x.shape
    width = int(length.max(initial=0)) + max(int(distance), 1) + 1
    per = max(1, TABLE_MAX // width)
    out = np.zeros(R, int)
    j = np.arange(width - 1)
    for r0 in range(0, R, per):
        r = np.arange(r0, min(r0 + per, R))
        inside = j < length[r, None]
        col = np.where(inside, start[r, None] + j, 0)
        flat = np.full((r.size, width), np.inf)
        flat[:, :-1] = np.where(inside, x[r[:, None], np.minimum(col, W - 1)], np.inf)
        flat = flat.ravel()
        pk = local_maxima(flat)
        pk = pk[np.isfinite(flat[pk])]
        if distance > 1 and pk.size > 1:
            pk = pk[by_distance(pk, flat[pk], int(np.ceil(distance)))]
        if pk.size:
            prom = _prominences_table(flat, pk) if flat.size <= TABLE_MAX else \
                prominences(flat, pk)  # a row longer than the tables take
            kept = pk[prom >= prominence]
            out[r] = np.bincount(kept // width, minlength=r.size)
    return out
