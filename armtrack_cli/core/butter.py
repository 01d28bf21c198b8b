"""The 4th-order zero-phase Butterworth low-pass the measures and compare use, in numpy alone:
the same filter as ``scipy.signal.sosfiltfilt(butter(4, fc, fs=fs, output="sos"), x)``
(odd extension of 3 × 5 samples at each end, steady-state initial conditions scaled by the
first sample, forward then backward), equal to it within round-off (tests/test_butter.py),
without importing scipy.signal (over a second of import), and cheap to repeat at many
cut-offs on one signal (Winter's residual analysis, compare/residual.py).

Each pass is linear: the zero-state response, a convolution with the impulse response h
(truncated where it has decayed below 1e-20 of its start: the filter is stable), plus the
response to the initial state, C·A^n·s0. Both passes together are one multiplication by
|H|² in the frequency domain and corrections at the two ends (zero_phase); the FFT of the
extended signal is taken once for every cut-off (ZeroPhase), and a filter's spectrum once for
every signal of the same length (a marker's coordinates in compare/residual.py).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from functools import lru_cache

import numpy as np

ORDER = 4
PAD = 3 * (2 * (ORDER // 2) + 1)  # scipy's sosfiltfilt: 3 × (2 × sections + 1) samples
DECAY = 1e-20  # the impulse response is cut where ρ^n falls below this (ρ: the largest pole)


def butter_sections(fc: float, fs: float) -> np.ndarray:
    """(2, 6) second-order sections [b0 b1 b2 1 a1 a2] of the digital 4th-order Butterworth
    low-pass at fc (Hz) for samples at fs (Hz), as scipy.signal.butter(4, fc, fs=fs,
    output="sos") makes them: the analogue prototype's poles, pre-warped, mapped by the
    bilinear transform (Oppenheim & Schafer, Discrete-Time Signal Processing, 3rd ed.,
    eq. 7.26), the four zeros at z = −1, the gain (DC = 1) on the first section."""
    warped = 4.0 * np.tan(np.pi * (2.0 * fc / fs) / 2.0)  # scipy's pre-warp, with fs = 2
    m = np.arange(-ORDER + 1, ORDER, 2)
    p = -np.exp(1j * np.pi * m / (2 * ORDER)) * warped  # analogue poles (left half-plane)
    k = warped**ORDER / np.real(np.prod(4.0 - p))
    pz = (4.0 + p) / (4.0 - p)  # bilinear transform, eq. 7.26 (T = 1/2)
    upper = pz[pz.imag > 0]
    upper = upper[np.argsort(np.abs(upper))]  # the pair nearest the unit circle last
    sos = np.zeros((ORDER // 2, 6))
    for i, q in enumerate(upper):
        sos[i] = [1.0, 2.0, 1.0, 1.0, -2.0 * q.real, abs(q) ** 2]
    sos[0, :3] *= k
    return sos


def _state_space(sos: np.ndarray):
    """A, B, C, D of the cascade of direct-form-II-transposed sections (scipy's sosfilt), and
    its steady state for a unit input (scipy's sosfilt_zi)."""
    n = 2 * len(sos)
    A, B, C, D = np.zeros((n, n)), np.zeros(n), np.zeros(n), 1.0
    zi = np.zeros(n)
    scale = 1.0
    for i, (b0, b1, b2, _, a1, a2) in enumerate(sos):
        Ai = np.array([[-a1, 1.0], [-a2, 0.0]])
        Bi = np.array([b1 - a1 * b0, b2 - a2 * b0])
        s = slice(2 * i, 2 * i + 2)
        A[s, :] += np.outer(Bi, C)  # the section's input is the cascade so far: C s + D x
        A[s, s] = Ai
        B[s] = Bi * D
        zi[s] = np.linalg.solve(np.eye(2) - Ai, Bi) * scale
        scale *= (b0 + b1 + b2) / (1.0 + a1 + a2)
        C = b0 * C
        C[2 * i] += 1.0
        D = b0 * D
    return A, B, C, D, zi


@lru_cache(maxsize=64)
def _response(fc: float, fs: float, n_max: int):
    """(h (L,), R (L, n), zi (n,)): the impulse response, the rows C·A^k (the response to an
    initial state) for k < L = min(n_max, the decay length), and the unit steady state."""
    A, B, C, D, zi = _state_space(butter_sections(fc, fs))
    rho = float(np.max(np.abs(np.linalg.eigvals(A))))
    L = int(min(n_max, np.ceil(np.log(DECAY) / np.log(rho)) + 1))
    block = 64
    Q = np.empty((block, len(B)))
    Q[0] = C
    for k in range(1, block):
        Q[k] = Q[k - 1] @ A
    Ab = np.linalg.matrix_power(A, block)
    rows, P = [], np.eye(len(B))
    for _ in range(-(-L // block)):
        rows.append(Q @ P)
        P = P @ Ab
    R = np.concatenate(rows)[:L]
    h = np.r_[D, R[:L - 1] @ B]
    return h, R, zi


def fast_len(n: int) -> int:
    """The smallest 2^a 3^b 5^c ≥ n (a length pocketfft transforms fast)."""
    best = 1 << max(int(n - 1).bit_length(), 0)
    f5 = 1
    while f5 < best:
        f35 = f5
        while f35 < best:
            m = f35
            while m < n:
                m *= 2
            best = min(best, m)
            f35 *= 3
        f5 *= 5
    return best


class ZeroPhase:
    """x (S, N) signals (N > PAD, finite) made ready for zero-phase low-passing at any of
    ``cutoffs`` (Hz, below fs/2): the odd extension and its transform, taken once.
    ``at(fc, power)`` gives them low-passed at fc; ``power`` (the filter's |H|² on this
    transform's bins, ``power_at``) may be shared by other signals of the same length and
    cut-offs (compare/residual.py: the three coordinates of a marker).

    With c = h * ext (the forward pass without its initial state), the backward pass is
    Σ_k h[k] y1[m + k] with y1 = c on [0, ne) plus the initial state's response z1: one
    inverse FFT of ext's transform times |H|² gives it for the whole of c, and two short
    direct sums (length of h) take off c's tail beyond ne and add z1's share."""

    def __init__(self, x: np.ndarray, fs: float, cutoffs: Iterable[float]):
        x = np.atleast_2d(np.asarray(x, float))
        self.fs, self.n_signals = fs, len(x)
        ext = np.concatenate([2 * x[:, :1] - x[:, PAD:0:-1], x,
                              2 * x[:, -1:] - x[:, -2:-(PAD + 2):-1]], axis=1)  # odd
        self.ne = ne = ext.shape[1]
        longest = max(len(_response(float(f), fs, ne)[0]) for f in cutoffs)
        self.nfft = fast_len(ne + longest)
        self.E = np.fft.rfft(ext, self.nfft)
        # at() reads only the extension's first sample and its last `longest`: the rest of it
        # (a copy of x) is not kept (three coordinates of a 60-minute marker: 9 MB; issue 15)
        self.first, self.tail = ext[:, :1].copy(), ext[:, ne - longest:].copy()

    def power_at(self, fc: float) -> np.ndarray:
        """|H(fc)|² on the transform's bins."""
        H = np.fft.rfft(_response(fc, self.fs, self.ne)[0], self.nfft)
        return H.real**2 + H.imag**2

    def at(self, fc: float, power: np.ndarray | None = None) -> np.ndarray:
        """(S, N) the signals low-passed forward and backward at fc: scipy's sosfiltfilt."""
        ne, nfft, end = self.ne, self.nfft, self.tail.shape[1]  # ext[:, ne - end:] is tail
        h, R, zi = _response(fc, self.fs, ne)
        L = len(h)
        if L > end:
            raise ValueError(f"{fc} Hz is not one of the cut-offs made ready")
        y = np.fft.irfft(self.E * (self.power_at(fc) if power is None else power), nfft)[:, :ne]
        g = h[::-1]
        z1 = (self.first * zi) @ R.T  # (S, L): the forward pass's initial-state response
        for i in range(self.n_signals):
            if L > 1:  # c beyond ne (it is cut from y1), from ext's last L − 1 samples
                tail = np.convolve(h, self.tail[i, end - L + 1:])[L - 1:2 * L - 2]
                y[i, ne - L + 1:] -= np.convolve(g, tail)[:L - 1]
            y[i, :L] += np.convolve(g, z1[i])[L - 1:2 * L - 1]
        last = self.tail[:, end - L:][:, ::-1] @ h + z1[:, -1] * (L == ne)  # y1[ne − 1]
        y[:, ne - L:] += ((last[:, None] * zi) @ R.T)[:, ::-1]  # backward initial state
        return y[:, PAD:ne - PAD]


def zero_phase(x: np.ndarray, fs: float, cutoffs: Iterable[float]) -> Iterator[np.ndarray]:
    """x (S, N) signals (N > PAD, finite); for each cut-off in turn (Hz, below fs/2), the
    signals low-passed forward and backward: (S, N), scipy.signal.sosfiltfilt's result
    (ZeroPhase's). Lazy: stop iterating and the remaining cut-offs cost nothing."""
    cutoffs = [float(f) for f in cutoffs]
    if not cutoffs:
        return
    ready = ZeroPhase(x, fs, cutoffs)
    for fc in cutoffs:
        yield ready.at(fc)


def lowpass_columns(x: np.ndarray, fs: float, fc: float) -> np.ndarray:
    """(N, d) samples, each column low-passed forward and backward at fc (N > PAD)."""
    return next(zero_phase(np.asarray(x, float).T, fs, [fc])).T
