"""The wrist path measures of many posterior draws at once (table.py's uncertainty): the speed
profiles of a block of draws in one pass, then each segment's measures as arrays over the
draws, NaN where a draw's measure is not computable. The arithmetic is that of signal.py,
path.py and smoothness.py on one signal, with each draw's onset-to-offset span as a mask
over its segment (sums then add the same terms in another order: equal to round-off;
tests/test_measure_draws.py holds every measure to those functions, one draw at a time).
Without it, a 10-minute session's 40 draws × 120 laps made 40,000 small measure calls."""

from __future__ import annotations

import numpy as np

from armtrack_cli.measures.base import ONE_MOVEMENT, NotComputable, Settings
from armtrack_cli.measures.peaks import count_peaks_rows
from armtrack_cli.measures.signal import lowpass, uniform
from armtrack_cli.measures.vec3 import norm3

Values = dict[str, np.ndarray]  # measure -> (c,) over the draws, NaN = not computable


def speed_profiles(t: np.ndarray, xyz: np.ndarray, s: Settings
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """signal.speed_profile of c draws (c, N, 3) sharing their missing frames:
    (t_u (M,), p (c, M, 3), v (c, M))."""
    c, n, _ = xyz.shape
    t_u, p = uniform(t, np.moveaxis(xyz, 0, 1).reshape(n, 3 * c), s, "wrist trajectory")
    p = lowpass(p, 1.0 / (t_u[1] - t_u[0]), s.lowpass_hz)
    v = norm3(np.gradient(p, t_u, axis=0).reshape(-1, c, 3))
    return t_u, np.moveaxis(p.reshape(-1, c, 3), 1, 0), np.ascontiguousarray(v.T)


def _spans(v: np.ndarray, inside: np.ndarray, s: Settings):
    """path.peak and path.onset_offset of each row's samples ``inside``: (k, v[k], a, b)."""
    R, W = v.shape
    i = np.arange(W)
    k = np.argmax(np.where(inside, v, -np.inf), axis=1)
    vk = v[np.arange(R), k]
    high = inside & (v >= s.min_segment_peak * vk[:, None])
    h0, h1 = np.argmax(high, axis=1), W - 1 - np.argmax(high[:, ::-1], axis=1)
    low = inside & (v < s.onset_fraction * vk[:, None])
    a = np.where(low & (i < h0[:, None]), i, -1).max(axis=1) + 1
    after = np.where(low & (i >= h1[:, None]), i, W).min(axis=1)
    return k, vk, a, np.minimum(after, inside.sum(axis=1)) - 1


def _masked_sum(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Σ x[r, lo[r] : hi[r]] of each row."""
    i = np.arange(x.shape[1])
    return np.sum(np.where((i >= lo[:, None]) & (i < hi[:, None]), x, 0.0), axis=1)


SPECTRA = 1 << 18  # rows × FFT length of one block of spectra (4 MB of complex numbers)


def _sparc(v: np.ndarray, a: np.ndarray, n: np.ndarray, fs: float, s: Settings,
           ok: np.ndarray) -> np.ndarray:
    """smoothness.sparc of each row's v[a : a + n] (rows ``ok``), rows of one FFT length
    together, a block of them at a time."""
    out = np.full(v.shape[0], np.nan)
    nfft = (2 ** (np.ceil(np.log2(np.maximum(n, 1))) + s.sparc_pad)).astype(int)
    for size in np.unique(nfft[ok]).tolist():
        rows = np.flatnonzero(ok & (nfft == size))
        for r in np.array_split(rows, min(rows.size, -(-rows.size * size // SPECTRA))):
            out[r] = _sparc_rows(v, r, a[r], n[r], fs, size, s)
    return out


def _sparc_rows(v, r, a, n, fs, size, s):
    j = np.arange(int(n.max()))
    inside = j < n[:, None]
    x = np.where(inside, v[r[:, None], np.where(inside, a[:, None] + j, 0)], 0.0)
    spectrum = np.fft.rfft if s.sparc_fc_hz < fs / 2 else np.fft.fft  # as smoothness.sparc
    mag = np.abs(spectrum(x, size, axis=1))
    top = mag.max(axis=1, keepdims=True)
    f = np.arange(mag.shape[1]) * fs / size
    sel = int(np.count_nonzero(f <= s.sparc_fc_hz))  # f increases: the first sel bins
    mag = mag[:, :sel] / top  # the normalised spectrum up to the cut-off
    above = mag >= s.sparc_amp_th
    k0, k1 = np.argmax(above, axis=1), sel - 1 - np.argmax(above[:, ::-1], axis=1)
    cut = int(k1.max()) + 1  # no arc beyond the last bin above the threshold
    mag, f = mag[:, :cut], f[:cut]
    df = np.diff(f)[None, :] / (f[k1] - f[k0])[:, None]
    arc = np.sqrt(df**2 + np.diff(mag, axis=1) ** 2)
    return np.where(above.any(axis=1) & (k1 > k0), -_masked_sum(arc, k0, k1), np.nan)


NAMES = ["wrist_peak_speed", "wrist_mean_speed", "time_to_peak_speed", "movement_time",
         "wrist_path_length", "movement_units", "sparc", "ldlj"]


def window_values(t: np.ndarray, o: np.ndarray, length: np.ndarray, p: np.ndarray,
                  v: np.ndarray, dist: np.ndarray, fs: float, reach: bool, s: Settings, *,
                  skip: tuple[str, ...] = ()) -> Values:
    """table._path_values of R windows at once (windows of draws): row r holds length[r]
    samples from sample o[r] of the clock t (M,) s, positions p (R, W, 3) m and speeds v (R, W)
    m/s, anything finite past them; dist (R,) the movement units' least peak spacing. The
    measures named in ``skip`` are neither computed nor returned."""
    with np.errstate(divide="ignore", invalid="ignore"):  # rows without a value: masked
        out = _window_values(t, o, length, p, v, dist, fs, reach, s, skip)
    return {m: x for m, x in out.items() if m not in skip}


def _window_values(t, o, length, p, v, dist, fs, reach, s, skip) -> Values:
    R, W = v.shape
    inside = np.arange(W) < length[:, None]
    k, vk, a, b = _spans(v, inside, s)
    moving = (length >= 3) & (vk >= s.min_moving_speed)  # path.peak
    n = b - a + 1
    rows = np.arange(R)
    length_m = _masked_sum(norm3(np.diff(p, axis=1)), a, b)
    out = {"wrist_peak_speed": vk, "wrist_mean_speed": _masked_sum(v, a, b + 1) / n,
           "time_to_peak_speed": t[o + k] - t[o + a],
           "movement_time": np.where(b - a < 2, np.nan, t[o + b] - t[o + a]),
           "wrist_path_length": length_m}
    if reach:
        d = norm3(p[rows, b] - p[rows, a])
        out["straightness"] = np.where(d < s.min_reach_m, np.nan,
                                       length_m / np.maximum(d, 1e-300))
    # smoothness.py on each draw's span; _check: ≥ 10 finite samples, not constant
    span = (np.arange(W) >= a[:, None]) & (np.arange(W) <= b[:, None])
    lowest = np.where(span, v, np.inf).min(axis=1)
    ok = moving & (n >= 10) & (vk != 0) & (vk - lowest != 0) & \
        np.isfinite(np.where(span, v, 0.0)).all(axis=1)
    if "ldlj" not in skip:
        dt = 1.0 / fs
        jerk = np.diff(v, 2, axis=1) / dt**2
        dlj = (n * dt) ** 3 / vk**2 * _masked_sum(jerk**2, a, b - 1) * dt
        out["ldlj"] = np.where(ok & (dlj > 0), -np.log(np.where(dlj > 0, dlj, 1.0)), np.nan)
    if "sparc" not in skip:
        out["sparc"] = _sparc(v, a, n, fs, s, ok)
    units = np.zeros(R)
    for gap in np.unique(dist).tolist():
        r = np.flatnonzero(dist == gap)
        units[r] = count_peaks_rows(v[r], a[r], np.where(ok[r], n[r], 0),
                                    prominence=s.mu_rise, distance=gap)
    out["movement_units"] = np.where(ok, units, np.nan)
    return {m: np.where(moving, x, np.nan) for m, x in out.items()}


def peak_spacing(t: np.ndarray, s: Settings) -> int:
    """smoothness.movement_units' least spacing of peaks on the clock t, in samples."""
    return max(1, int(np.ceil(s.mu_min_gap_s / np.median(np.diff(t)) - 1e-9)))


class PathDraws:
    """table.path_values of draws of the wrist on the estimate's windows, a block of draws
    at a time (``__call__``); the windows' samples, found on the first block, kept."""

    def __init__(self, t: np.ndarray, windows: list, reach: bool, s: Settings):
        self.t, self.windows, self.reach, self.s = t, windows, reach, s
        self.geometry = None

    def _geometry(self, tu: np.ndarray):
        if self.geometry is None:
            segs = np.array([(int(np.searchsorted(tu, a - 1e-9)),
                              int(np.searchsorted(tu, b + 1e-9))) for a, b in self.windows],
                            int).reshape(-1, 2)
            dist = np.array([peak_spacing(tu[a:b], self.s) for a, b in segs], int)
            self.geometry = (segs, dist, peak_spacing(tu, self.s))
        return self.geometry

    def __call__(self, wrist: np.ndarray) -> dict[tuple[str, str], np.ndarray]:
        """{(measure, segment): (c,)} of c draws (c, N, 3); empty when the trajectory has no
        speed profile."""
        s = self.s
        try:
            tu, p, v = speed_profiles(self.t, wrist, s)
        except NotComputable:
            return {}
        c, M = v.shape
        fs = 1.0 / (tu[1] - tu[0])
        segs, dist, whole = self._geometry(tu)
        zero = np.zeros(c, int)
        several = ONE_MOVEMENT if len(segs) > 1 else ()  # as table.path_values
        out = {(m, "session"): x for m, x in window_values(
            tu, zero, zero + M, p, v, zero + whole, fs, False, s, skip=several).items()}
        if not several:
            return out
        o, length = segs[:, 0], segs[:, 1] - segs[:, 0]
        idx = np.minimum(o[:, None] + np.arange(max(int(length.max()), 1)), M - 1)
        S = len(segs)
        got = window_values(tu, np.tile(o, c), np.tile(length, c),
                            p[:, idx].reshape(c * S, -1, 3), v[:, idx].reshape(c * S, -1),
                            np.tile(dist, c), fs, self.reach, s)
        for m, x in got.items():
            for j, col in enumerate(x.reshape(c, S).T, 1):
                out[(m, str(j))] = col
        return out
