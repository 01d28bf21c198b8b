"""A measure's uncertainty by sampling the filter's posterior.

Each draw adds to the estimate an error with the posterior SD of every frame (the *_sd
columns) that is correlated in time with a Gaussian correlation exp(−τ²/τc²), τc =
s.draw_corr_s (the columns give the spread of each frame, not how errors of nearby frames go
together: the correlation time is our stated assumption). The correlation is Gaussian, not
AR(1), because a smoothed trajectory's error is smooth: an AR(1) process has rough paths whose
frame-to-frame steps, √(2(1 − e^(−Δt/τc)))·σ, made up a velocity error of about σ·√(2/(τc·Δt))
(7.7 σ per second at 30 fps, τc = 1 s) and so a peak-speed SD near the peak speed itself
(0.13 m/s for a 0.17 m/s rectangle whose error was 0.8 %); the Gaussian process's velocity
error is √2·σ/τc. The measure's uncertainty is the SD of its values over s.draws draws
(seeded, so reruns give the same numbers)."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from armtrack_cli.measures.base import Settings

BLOCK_SAMPLES = 1 << 16  # draws × frames of one block of draws (1.6 MB for 3 columns)


def draw_blocks(t: np.ndarray, sd: np.ndarray, s: Settings,
                block_samples: int = BLOCK_SAMPLES) -> Iterator[np.ndarray]:
    """s.draws zero-mean errors, a block of draws at a time (c, N, d), as many per block as
    make block_samples frames (memory flat in the session's length), marginal SD sd (N, d)
    (NaN -> 0), correlation exp(−τ²/τc²) in time: white noise smoothed by a Gaussian kernel
    of SD τc/2 (in frames at the median frame interval; circular, so every frame has unit
    variance) and rescaled by 1/√(Σ kernel²). Draw i is the i-th (N, d) block of one seeded
    stream of standard normals, however the draws are grouped."""
    rng = np.random.default_rng(s.seed)
    sd = np.nan_to_num(np.asarray(sd, float), nan=0.0)
    n, d = sd.shape
    dt = float(np.median(np.diff(t))) if n > 1 else 1.0
    sigma = 0.5 * s.draw_corr_s / dt if np.isfinite(dt) and dt > 0 else 0.0
    gain = 1.0
    if sigma >= 0.1:
        delta = np.zeros(n)
        delta[0] = 1.0
        gain = np.sqrt(np.sum(gaussian_wrap(delta, sigma, axis=0) ** 2))
    per = max(1, block_samples // max(n, 1))
    for first in range(0, s.draws, per):
        w = rng.standard_normal((min(per, s.draws - first), n, d))
        if sigma >= 0.1:
            w = gaussian_wrap(w, sigma, axis=1) / gain
        yield w * sd


def gaussian_wrap(x: np.ndarray, sigma: float, *, axis: int) -> np.ndarray:
    """x smoothed along ``axis`` by a Gaussian of SD sigma (samples) truncated at 4 SD,
    circularly: scipy.ndimage.gaussian_filter1d(x, sigma, axis, mode="wrap") exactly (its
    kernel, and its correlation's order of operations for a symmetric kernel: the centre tap,
    then each pair of taps from the outermost in), without importing scipy.ndimage (~0.7 s
    and ~13 MB in fuse's process; tests/test_scipy_ports.py holds it to scipy's)."""
    r = int(4.0 * sigma + 0.5)
    k = np.arange(-r, r + 1)
    w = np.exp(-0.5 / (sigma * sigma) * k**2)
    w = (w / w.sum())[::-1]
    x = np.moveaxis(np.asarray(x, float), axis, -1)
    n = x.shape[-1]
    ext = np.take(x, np.arange(-r, n + r) % n, axis=-1)  # the periodic extension
    out = ext[..., r:r + n] * w[r]
    pair = np.empty_like(out)
    for j in range(-r, 0):  # out += (left + right) · w, in place
        np.add(ext[..., r + j:r + j + n], ext[..., r - j:r - j + n], out=pair)
        pair *= w[r + j]
        out += pair
    return np.moveaxis(out, -1, axis)


def smooth_draws(t: np.ndarray, sd: np.ndarray, s: Settings) -> Iterator[np.ndarray]:
    """The draws of ``draw_blocks`` one at a time (N, d)."""
    for block in draw_blocks(t, sd, s, block_samples=1):
        yield from block


def spread(samples) -> float:
    """SD of the computable draws (finite numbers: a string or NaN is a draw without one), a
    list or an array; NaN when fewer than half of them gave a value."""
    if isinstance(samples, np.ndarray):
        x = np.asarray(samples, float)
    else:
        x = np.array([v if isinstance(v, float) else np.nan for v in samples], float)
    n = x.size
    x = x[np.isfinite(x)]
    return float(np.std(x, ddof=1)) if x.size >= 2 and 2 * x.size >= n else float("nan")


def spread_rows(x: np.ndarray) -> np.ndarray:
    """spread of each row of x (k, draws): the rows without a NaN through one np.std call
    (the same sums per row as one at a time), the others one at a time."""
    x = np.asarray(x, float)
    out = np.empty(x.shape[0])
    full = np.isfinite(x).all(axis=1)
    if x.shape[1] >= 2:
        out[full] = np.std(x[full], axis=1, ddof=1)
    else:
        out[full] = np.nan
    for i in np.flatnonzero(~full).tolist():
        out[i] = spread(x[i])
    return out
