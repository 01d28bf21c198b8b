"""The truth's denoising low-pass (compare.score.denoised: each coordinate of each run of seen
frames at the cut-off Winter's residual analysis picks from the whole run) on a capture held a
window at a time (issue 15).

A run that fits in one window and its margins is read and filtered whole, as denoised does
(the same numbers). A longer run's cut-off is chosen from its residuals R(fc) summed window by
window (each window's inner rows low-passed with MARGIN_S of the run either side: the filter's
impulse response has decayed below 1e-20 well within them, core/butter.py), the same choice
compare.residual makes over the run at once up to round-off in the sums; its filtered values
are then made a window at a time, with the same margins, at that cut-off: the whole run's
filter to ~1e-12 m (tests/test_flat_compare.py)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from armtrack_cli.compare.residual import MIN_HZ, winter_lowpass_into
from armtrack_cli.core.butter import ZeroPhase
from armtrack_cli.measures.signal import lowpass

Rows = Callable[[int, int], np.ndarray]  # rows [lo, hi) of one joint's (n, 3) markers
BATCH = 4  # grid cut-offs tried a pass over a long run (each pass transforms each window once)


@dataclass(frozen=True)
class Run:
    a: int  # rows [a, b) of the capture, every one seen
    b: int
    cut: tuple[float, ...] | None  # a long run's cut-off per coordinate; None: filtered whole


def seen_runs(rows: Rows, n: int, block: int) -> list[tuple[int, int]]:
    """[(a, b)] the runs of rows whose three coordinates are all finite, read ``block`` rows
    at a time (denoised's runs)."""
    edges, prev = [], False
    for lo in range(0, n, block):
        seen = np.isfinite(rows(lo, min(lo + block, n))).all(axis=1)
        d = np.flatnonzero(np.diff(np.r_[prev, seen].astype(np.int8))) + lo
        edges += d.tolist()
        prev = bool(seen[-1]) if seen.size else prev
    if prev:
        edges.append(n)
    return list(zip(edges[::2], edges[1::2]))


def _pieces(a: int, b: int, inner: int, margin: int):
    """(read lo, read hi, inner lo, inner hi) tiling [a, b) by ``inner`` rows, each read with
    ``margin`` rows either side (clipped to the run)."""
    for lo in range(a, b, inner):
        hi = min(lo + inner, b)
        yield max(a, lo - margin), min(b, hi + margin), lo, hi


def _grid(fs: float, max_hz: float) -> tuple[np.ndarray, list[float]]:
    """compare.residual's noise band and its cut-offs tried (band, grid, max_hz)."""
    nyq = fs / 2.0
    band = np.linspace(0.3 * nyq, 0.45 * nyq, 8)
    grid = np.arange(MIN_HZ, max_hz + 1e-9, 0.25)
    return band, [float(f) for f in (*band, *grid, max_hz)]


def _residuals(rows: Rows, a: int, b: int, fs: float, cutoffs: list[float], inner: int,
               margin: int) -> np.ndarray:
    """(len(cutoffs), 3) R(fc) of the run [a, b): each window's inner rows' squared residuals
    (low-passed with its margins) summed, over the run's rows."""
    ss = np.zeros((len(cutoffs), 3))
    for lo, hi, ilo, ihi in _pieces(a, b, inner, margin):
        x = rows(lo, hi)
        ready = ZeroPhase(x.T, fs, cutoffs)
        own = slice(ilo - lo, ihi - lo)
        for k, fc in enumerate(cutoffs):
            d = x[own] - ready.at(fc).T[own]
            ss[k] += np.einsum("ij,ij->j", d, d)
    return np.sqrt(ss / (b - a))


def long_cutoffs(rows: Rows, a: int, b: int, fs: float, max_hz: float, inner: int,
                 margin: int) -> tuple[float, ...]:
    """The cut-off per coordinate winter_lowpass_into picks for the run [a, b), from its
    residuals summed a window at a time: the noise band's in one pass, then the grid's
    rising, BATCH cut-offs a pass, until every coordinate has met its noise level."""
    nyq = fs / 2.0
    if b - a < 2 * fs or max_hz <= MIN_HZ or 0.3 * nyq <= max_hz:
        return (max_hz,) * 3
    band, cutoffs = _grid(fs, max_hz)
    r_band = _residuals(rows, a, b, fs, list(band), inner, margin)
    level = {}
    for j in range(3):
        slope, a_j = np.polyfit(band, r_band[:, j], 1)
        if np.isfinite(a_j) and a_j > 0:
            level[j] = a_j
    out = [max_hz] * 3
    grid = cutoffs[len(band):-1]
    for k in range(0, len(grid), BATCH):
        if not level:
            break
        some = grid[k:k + BATCH]
        r = _residuals(rows, a, b, fs, some, inner, margin)
        for j in list(level):
            met = [fc for fc, rk in zip(some, r[:, j]) if rk <= level[j]]
            if met:
                out[j] = met[0]
                del level[j]
    return tuple(out)


def plan(rows: Rows, n: int, fs: float, max_hz: float, inner: int, margin: int) -> list[Run]:
    """Every run of the joint's capture (n rows), a long one (longer than a window and its
    margins) with its cut-offs."""
    whole = inner + 2 * margin
    return [Run(a, b, None if b - a <= whole else
                long_cutoffs(rows, a, b, fs, max_hz, inner, margin))
            for a, b in seen_runs(rows, n, whole)]


def denoised_rows(rows: Rows, runs: list[Run], lo: int, hi: int, fs: float, max_hz: float,
                  margin: int) -> tuple[int, int, np.ndarray]:
    """(first, last row, (last − first, 3) markers): rows [lo, hi) and whatever more a run
    crossing them needs (a short run whole), denoised: NaN in gaps, as denoised gives them."""
    first = min([lo, *(r.a for r in runs if r.cut is None and r.a < hi and r.b > lo)])
    last = max([hi, *(r.b for r in runs if r.cut is None and r.a < hi and r.b > lo)])
    x = rows(first, last)
    out = np.full_like(x, np.nan)
    for r in runs:
        a, b = max(r.a, first), min(r.b, last)
        if a >= b:
            continue
        if r.cut is None:  # whole (first..last holds it): denoised's own arithmetic
            winter_lowpass_into(x[a - first:b - first], fs, max_hz, out[a - first:b - first])
            continue
        ra, rb = max(r.a, a - margin), min(r.b, b + margin)
        piece = rows(ra, rb)
        for fc in sorted(set(r.cut)):  # the coordinates of one cut-off filtered together
            cols = [j for j, c in enumerate(r.cut) if c == fc]
            out[a - first:b - first, cols] = lowpass(piece[:, cols], fs, fc)[a - ra:b - ra]
    return first, last, out
