"""The random numbers of the particle filters: a counter-based stream that a compiled loop draws
many of at once in SIMD, and that numpy draws identically, so the numba kernels and their numpy
reference see the same numbers (tests/test_splitmix.py: bit for bit).

Raw draws: SplitMix64 (Steele, Lea & Flood 2014, Java's SplittableRandom; passes BigCrush):
raw(c) = mix(key + (c + 1) γ), γ = 2⁶⁴/φ, for the stream's counter c, so draw c is a function
of c alone and N draws are N independent lanes of arithmetic. The state is (key, counter)
uint64 (2,); key is one raw draw of the filter's seeded numpy generator.

Uniforms: the top 53 bits of a raw draw, as numpy's next_double. Normals: two from each raw
draw, one from each 32-bit half (the low half first), by numpy's 256-layer ziggurat in its
32-bit form (Marsaglia & Tsang 2000; numpy's random_standard_normal_f: 8 bits of layer, 1 of
sign, 23 of abscissa), its tables those of numpy's 52-bit ziggurat as numba ships them, cut to 23
bits (abscissa step × 2²⁹, threshold ⌊· / 2²⁹⌋: the same layers, so the law is exact up to the
abscissa's 2⁻²³ grid in each layer). The ~1.3 % that the fast path rejects go on with a
sub-stream of their own, keyed by their raw draw R and half h: sub-draw t = mix(R + (2t + h) γ),
t = 1, 2, …, two per round (the wedge test's uniform and the next attempt's 32 bits, or the
tail's two uniforms, drawn again until they take: a failed pair stays in the tail, as in numpy's
ziggurat; the stream before this one started over from a new attempt, which left the mass
beyond R about 7 % short). n normals take exactly ⌈n / 2⌉ draws of the main stream, whatever their
rejections.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numba.np.random import _constants as _zig  # numpy's ziggurat tables, as numba ships them

from armtrack_cli.filters.fast_exp import exp_le0

_CUT = np.uint64(29)  # 52 − 23 bits of abscissa
_KI, _WI = _zig.ki_double >> _CUT, _zig.wi_double * 2.0**29
_FI = _zig.fi_double.copy()
_R, _INV_R = float(_zig.ziggurat_nor_r), float(_zig.ziggurat_nor_inv_r)
_G = np.uint64(0x9E3779B97F4A7C15)  # γ: the golden ratio's odd 64-bit fraction
_M1, _M2 = np.uint64(0xBF58476D1CE4E5B9), np.uint64(0x94D049BB133111EB)
_U1, _U2, _U8, _U9, _U11 = np.uint64(1), np.uint64(2), np.uint64(8), np.uint64(9), np.uint64(11)
_U27, _U30, _U31, _U32 = np.uint64(27), np.uint64(30), np.uint64(31), np.uint64(32)
_MASK23, _MASK32, _MASK8 = np.uint64(0x7FFFFF), np.uint64(0xFFFFFFFF), np.uint64(0xFF)
_TWO_M53 = 1.0 / 9007199254740992.0
_EXP84, _EXP52 = np.uint64(0x4530000000000000), np.uint64(0x4330000000000000)  # 2⁸⁴, 2⁵²
_TWO84_PLUS_52 = 2.0**84 + 2.0**52


def stream(rng: np.random.Generator) -> np.ndarray:
    """A new stream (key, counter = 0) uint64 (2,), its key one raw draw of ``rng``."""
    return np.array([rng.bit_generator.random_raw(), 0], np.uint64)


# ---------------------------------------------------------------- numba (the kernels' draws)

@njit(cache=True, inline="always")
def _mix(z):
    """SplitMix64's finaliser (Stafford's variant 13)."""
    z = (z ^ (z >> _U30)) * _M1
    z = (z ^ (z >> _U27)) * _M2
    return z ^ (z >> _U31)


@njit(cache=True, inline="always")
def random(s):
    """One uniform on [0, 1) from stream s (2,): the top 53 bits of raw(counter)."""
    c = s[1]
    s[1] = c + _U1
    return np.float64(_mix(s[0] + (c + _U1) * _G) >> _U11) * _TWO_M53


@njit(cache=True, error_model="numpy")
def fill_random(s, out):
    """out (n,) ← n uniforms on [0, 1), as ``uniforms(s, n)``."""
    z, n = s[0] + (s[1] + _U1) * _G, out.size
    for i in range(n):  # SIMD: each lane its own draw, z = base + iγ by induction (no multiply)
        out[i] = _exact_float(_mix(z) >> _U11) * _TWO_M53
        z += _G
    s[1] += np.uint64(n)


@njit(cache=True, inline="always")
def _exact_float(v):
    """float(v) for v < 2⁵³, exactly, from its bits: each 32-bit half put into the mantissa of
    2⁸⁴ and 2⁵² and the two subtracted (LLVM's own lowering of the unsigned conversion, which
    on AVX2 it makes one lane at a time): 4.66 → 4.58 µs a residual resampling, 500 particles."""
    hi = np.uint64((v >> _U32) | _EXP84).view(np.float64) - _TWO84_PLUS_52
    return hi + np.uint64((v & _MASK32) | _EXP52).view(np.float64)


@njit(cache=True, inline="always")
def _attempt(w):
    """The ziggurat's fast path on a 32-bit word w (in a uint64): (layer, ±abscissa, accepted)
    — layer from the low 8 bits, sign from the next, 23 bits of abscissa, as numpy's."""
    idx = np.intp(w & _MASK8)
    rabs = (w >> _U9) & _MASK23
    x = np.float64(np.int64(rabs)) * _WI[idx]
    return idx, -x if (w >> _U8) & _U1 else x, rabs < _KI[idx]


@njit(cache=True, inline="always")
def _sub(key, h, t):
    """Sub-draw t ≥ 1 of the sub-stream keyed by raw draw ``key`` and half h."""
    return _mix(key + (t + t + h) * _G)


@njit(cache=True, inline="always")
def _u53(r):
    return np.float64(r >> _U11) * _TWO_M53


@njit(cache=True, error_model="numpy")
def _slow(key, h, w):
    """The ziggurat after its fast path rejected word w, half h of raw draw ``key``, two
    sub-draws a round: in the tail beyond R (layer 0), Marsaglia's exponential pair, drawn
    again until it takes (as numpy's: a failed pair stays in the tail); else the wedge test,
    and a new attempt where it fails."""
    idx, x, _ = _attempt(w)
    t = np.uint64(1)
    while True:
        u1, r2 = _u53(_sub(key, h, t)), _sub(key, h, t + _U1)
        t += _U2
        if idx == 0:
            xx = -_INV_R * np.log1p(-u1)
            yy = -np.log1p(-_u53(r2))
            if yy + yy > xx * xx:
                return -(_R + xx) if (w >> _U8) & _U1 else _R + xx
            continue
        if (_FI[idx - 1] - _FI[idx]) * u1 + _FI[idx] < exp_le0(-0.5 * x * x):
            return x
        w = r2 & _MASK32
        idx, x, ok = _attempt(w)
        if ok:
            return x


@njit(cache=True, error_model="numpy")
def fill_normals(s, out):
    """out (C-contiguous, any shape) ← standard normals in row-major order, as
    ``normals(s, out.shape)``: the fast path for all, marking the rejected ones; then those
    (~1.3 %), listed, and their first round (the wedge test, or a new attempt) for all in one
    branch-free loop; the tail and the rare second rounds one at a time."""
    fill_normals_with(s, out, normals_work(out.size))


@njit(cache=True, error_model="numpy")
def normals_work(n):
    """The work arrays of fill_normals_with for n normals, made once for many calls."""
    m = 8 * ((n + 7) // 8)
    return (np.zeros(m, np.uint8), np.empty(m + 8, np.int64), np.empty(m // 8, np.int64),
            np.empty(m), np.empty(m, np.bool_), np.empty(m // 2 + 1, np.uint64))


@njit(cache=True, error_model="numpy")
def fill_normals_with(s, out, work):
    """fill_normals with its work arrays given (normals_work(out.size))."""
    n = out.size
    base = s[0] + (s[1] + _U1) * _G
    rejected, pending, words, x, again, raw = work
    flat = out.reshape(n)
    n_raw = (n + 1) // 2
    _fast_path(base, flat, rejected[:n], raw[:n_raw])
    m = _listed(rejected, pending, words)
    if m:
        _first_round(base, pending[:m], x[:m], again[:m])
        for t in range(m):
            i = pending[t]
            flat[i] = x[t]
            if again[t]:  # the tail, or a second rejection
                key, h = raw[i >> 1], np.uint64(i & 1)
                flat[i] = _slow(key, h, (key >> (h * _U32)) & _MASK32)
    s[1] += np.uint64(n_raw)


@njit(cache=True, error_model="numpy")
def _listed(rejected, pending, words):
    """pending[:m] ← the indices where rejected is set; returns m. Without a branch that
    mispredicts: first the words (8 marks each) that hold a mark, then their marks."""
    marks, nw = rejected.view(np.uint64), 0
    for b in range(marks.size):
        words[nw] = b
        nw += np.int64(marks[b] != 0)
    m = 0
    for t in range(nw):
        for i in range(8 * words[t], 8 * words[t] + 8):
            pending[m] = i
            m += np.int64(rejected[i])
    return m


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _first_round(base, pending, out, again):
    """_slow's first round for the rejected normals at ``pending``, all alike in SIMD: the
    wedge test on sub-draw 1, else a new attempt on sub-draw 2, into out; again where that does
    not settle it, or in the tail (layer 0), which _slow draws apart. Their raw draws are made
    anew (base + (i // 2) γ): LLVM vectorises that, not a gather from the raw draws kept."""
    for t in range(pending.size):
        i = pending[t]
        key, h = _mix(base + np.uint64(i >> 1) * _G), np.uint64(i & 1)
        idx, x, _ = _attempt((key >> (h * _U32)) & _MASK32)
        u1 = _u53(_sub(key, h, _U1))
        _, x2, ok2 = _attempt(_sub(key, h, _U2) & _MASK32)
        lo = _FI[max(idx, 1) - 1]  # layer 0 (the tail) never takes the wedge
        wedge = (lo - _FI[idx]) * u1 + _FI[idx] < exp_le0(-0.5 * x * x)
        out[t] = x if wedge else x2
        again[t] = (idx == 0) | (not (wedge | ok2))


@njit(cache=True, error_model="numpy")
def _fast_path(base, flat, rejected, raw):
    """flat (n,) ← the fast path on the halves of raw draws base + iγ (1-D arrays of their own:
    LLVM does not vectorise a loop on a reshaped view), rejected[i] = 1 where it rejects; raw
    (⌈n/2⌉,) the raw draws, kept for the slow path. The raw draws in SIMD, z = base + iγ by
    induction (one 64-bit multiply fewer a draw); the tables' look-ups a pair at a time, one
    at a time each, which here beats LLVM's gathers."""
    z = base
    for i in range(raw.size):
        raw[i] = _mix(z)
        z += _G
    n = flat.size
    for i in range(n // 2):
        r = raw[i]
        idx, x, ok = _attempt(r & _MASK32)
        idx2, x2, ok2 = _attempt(r >> _U32)
        if idx < 0:  # never: an exit that keeps LLVM from vectorising the look-ups
            break
        flat[2 * i], rejected[2 * i] = x, not ok
        flat[2 * i + 1], rejected[2 * i + 1] = x2, not ok2
    if n % 2:
        idx, x, ok = _attempt(raw[n // 2] & _MASK32)
        flat[n - 1], rejected[n - 1] = x, not ok


# ------------------------------------------------------------- numpy (the reference's draws)

def _mix_np(z: np.ndarray) -> np.ndarray:
    z = (z ^ (z >> _U30)) * _M1
    z = (z ^ (z >> _U27)) * _M2
    return z ^ (z >> _U31)


def _raw_np(s: np.ndarray, n: int) -> np.ndarray:
    """raw(counter … counter + n − 1), the counter advanced by n."""
    c = s[1] + np.arange(1, n + 1, dtype=np.uint64)
    s[1] += np.uint64(n)
    return _mix_np(s[0] + c * _G)


def _u53_np(r: np.ndarray) -> np.ndarray:
    return (r >> _U11).astype(float) * _TWO_M53


def uniforms(s: np.ndarray, n: int) -> np.ndarray:
    """n uniforms on [0, 1) from stream s (advanced)."""
    return _u53_np(_raw_np(s, n))


def normals(s: np.ndarray, shape) -> np.ndarray:
    """Standard normals of ``shape`` from stream s (advanced by ⌈n / 2⌉ draws): normal 2c from
    raw draw c's low 32 bits, 2c + 1 from its high 32 bits."""
    n = int(np.prod(shape))
    raw = _raw_np(s, (n + 1) // 2)
    w = np.stack([raw & _MASK32, raw >> _U32], -1).ravel()[:n]
    idx, x, ok = _attempt_np(w)
    bad = np.flatnonzero(~ok)  # the rejected (~1.3 %): as the kernel's _slow, all at once
    x[bad] = _slow_np(raw[bad >> 1], (bad & 1).astype(np.uint64), w[bad])
    return x.reshape(shape)


def _attempt_np(w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """_attempt on 32-bit words w (uint64): (layer, ±abscissa, accepted)."""
    idx = (w & _MASK8).astype(np.intp)
    rabs = (w >> _U9) & _MASK23
    x = rabs.astype(np.int64).astype(float) * _WI[idx]
    return idx, np.where(((w >> _U8) & _U1).astype(bool), -x, x), rabs < _KI[idx]


def _sub_np(key: np.ndarray, h: np.ndarray, t: np.ndarray) -> np.ndarray:
    return _mix_np(key + (t + t + h) * _G)


def _slow_np(key: np.ndarray, h: np.ndarray, w: np.ndarray) -> np.ndarray:
    """_slow for arrays of rejected words w, halves h of raw draws key, a round at a time
    for those still pending: the same sub-draws, the same tests."""
    out, t = np.empty(key.size), np.ones(key.size, np.uint64)
    idx, x, _ = _attempt_np(w)
    todo = np.arange(key.size)
    while todo.size:
        k, hh, ww, tt, ii, xx = key[todo], h[todo], w[todo], t[todo], idx[todo], x[todo]
        u1, r2 = _u53_np(_sub_np(k, hh, tt)), _sub_np(k, hh, tt + _U1)
        tt = tt + _U2
        tail = ii == 0
        with np.errstate(divide="ignore", invalid="ignore"):
            xt = -_INV_R * np.log1p(-u1)
            yt = -np.log1p(-_u53_np(r2))
        tail_ok = tail & (yt + yt > xt * xt)
        wedge_ok = ~tail & ((_FI[ii - 1] - _FI[ii]) * u1 + _FI[ii] < np.exp(-0.5 * xx * xx))
        xt = np.where(((ww >> _U8) & _U1).astype(bool), -(_R + xt), _R + xt)
        done = tail_ok | wedge_ok
        out[todo[done]] = np.where(tail_ok, xt, xx)[done]
        wn = r2 & _MASK32  # a new attempt where the wedge failed (a failed tail stays there)
        idn, xn, okn = _attempt_np(wn)
        retry = ~done & ~tail
        out[todo[retry & okn]] = xn[retry & okn]
        t[todo] = tt
        new = retry & ~okn
        w[todo[new]], idx[todo[new]], x[todo[new]] = wn[new], idn[new], xn[new]
        todo = todo[(tail & ~tail_ok) | new]
    return out


class Stream:
    """Stream s as the numpy reference draws from it: a numpy Generator's ``random`` and
    ``standard_normal``, so the reference's code reads as it would with one."""

    def __init__(self, state: np.ndarray):
        self.state = state

    def random(self, size: int | None = None):
        if size is None:
            return float(uniforms(self.state, 1)[0])
        return uniforms(self.state, int(size))

    def standard_normal(self, shape) -> np.ndarray:
        return normals(self.state, shape)
