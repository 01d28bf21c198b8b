"""A marker's low-pass cut-off chosen from its own data: Winter's residual analysis (Winter,
Biomechanics and Motor Control of Human Movement, 4th ed. 2009, §3.4.4.3).

The residual R(fc) = √(mean (x − x̂_fc)²) between a coordinate and its low-passed copy falls as
the cut-off fc rises. Above the signal's band only noise is left to remove, and R falls along a
straight line whose intercept at fc = 0, a, is the RMS of the noise; the cut-off is where R
meets that level: below it the filter starts to take signal (R > a), above it lets noise through.
A slow reach recorded with 0.3 mm of noise gets 2–3 Hz, a fast one more; the noise a 6 Hz filter
lets through would otherwise raise a maximum such as the peak speed by 2–3 % on a 0.09 m/s reach
(docs/validation-measures.md).
"""

from __future__ import annotations

import numpy as np

from armtrack_cli.core.butter import ZeroPhase, zero_phase
from armtrack_cli.measures.signal import lowpass

MIN_HZ = 1.0  # the lowest cut-off tried: a marker at rest is not filtered below it


def residuals(x: np.ndarray, fs: float, cutoffs: np.ndarray) -> np.ndarray:
    """(len(cutoffs),) R(fc) of one coordinate x (N,): 4th-order zero-lag Butterworth."""
    return np.array([_rms(x, y[0]) for y in zero_phase(x[None], fs, cutoffs)])


def _rms(x: np.ndarray, y: np.ndarray) -> float:
    d = x - y
    np.square(d, out=d)  # in place: (x − y)² without a second temporary of x's length
    return float(np.sqrt(np.mean(d)))


def winter_cutoff(x: np.ndarray, fs: float, *, max_hz: float) -> float:
    """The cut-off (Hz, MIN_HZ … max_hz) where R(fc) falls to the noise level a, the intercept of
    the straight line fitted to R over the noise band (0.3–0.45 × fs/2; Winter 2009 §3.4.4.3).
    x: (N,) one coordinate, evenly sampled at fs; max_hz when too short to tell (< 2 s)."""
    return winter_lowpass(x, fs, max_hz=max_hz)[0]


def winter_lowpass(x: np.ndarray, fs: float, *, max_hz: float) -> tuple[float, np.ndarray]:
    """(winter_cutoff's cut-off, x low-passed at it (N,)): the cut-offs of the grid are tried
    in rising order and the first at the noise level ends the search, its filtered copy the
    result (the transform of x is taken once for all of them: core/butter.py)."""
    return winter_lowpass_columns(x[:, None], fs, max_hz=max_hz)[0]


def winter_lowpass_columns(x: np.ndarray, fs: float, *, max_hz: float
                           ) -> list[tuple[float, np.ndarray]]:
    """winter_lowpass of each column of x (N, d), [(cut-off, filtered column (N,))]: the
    columns side by side through the cut-offs, each filter's spectrum taken once for them
    all (a column's arithmetic is its own, so its numbers are those it has alone)."""
    out = np.empty(x.shape)
    return [(fc, out[:, j]) for j, fc in enumerate(winter_lowpass_into(x, fs, max_hz, out))]


def winter_lowpass_into(x: np.ndarray, fs: float, max_hz: float, out: np.ndarray
                        ) -> list[float]:
    """winter_lowpass_columns's cut-offs, each column's filtered copy written into ``out``
    (N, d) as soon as it is found (``out`` may be x itself: a column is written once it is
    no longer read), and its transforms let go of then (issue 15: a 60-minute marker's three
    coordinates held their transforms and results to the end, 26 MB)."""
    nyq = fs / 2.0
    d = x.shape[1]
    cut = [max_hz] * d
    if len(x) < 2 * fs or max_hz <= MIN_HZ or 0.3 * nyq <= max_hz:
        for j in range(d):
            out[:, j] = lowpass(x[:, j:j + 1], fs, max_hz)[:, 0]
        return cut
    noise_band = np.linspace(0.3 * nyq, 0.45 * nyq, 8)
    grid = np.arange(MIN_HZ, max_hz + 1e-9, 0.25)
    cutoffs = [float(f) for f in (*noise_band, *grid, max_hz)]
    ready = {j: ZeroPhase(x[None, :, j], fs, cutoffs) for j in range(d)}
    r_noise = [[] for _ in range(d)]
    for fc in cutoffs[:len(noise_band)]:
        power = ready[0].power_at(fc)
        for j in range(d):
            r_noise[j].append(_rms(x[:, j], ready[j].at(fc, power)[0]))
    level = {}  # column -> its noise level a, while its search goes on
    for j in range(d):
        slope, a = np.polyfit(noise_band, r_noise[j], 1)
        if np.isfinite(a) and a > 0:
            level[j] = a
    found = set()
    for fc in cutoffs[len(noise_band):-1]:  # the grid
        if not level:
            break
        power = ready[next(iter(level))].power_at(fc)  # the same for every column
        for j in list(level):
            y = ready[j].at(fc, power)[0]
            if _rms(x[:, j], y) <= level[j]:
                out[:, j], cut[j] = y, float(fc)
                found.add(j)
                del level[j], ready[j], y
    del ready
    for j in sorted(set(range(d)) - found):  # never at the noise level (or none to meet): max_hz
        out[:, j] = lowpass(x[:, j:j + 1], fs, max_hz)[:, 0]
    return cut
