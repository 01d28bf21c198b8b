"""The random numbers of the particle filters: a counter-based stream that a compiled loop draws
many of at once in SIMD, and that numpy draws identically, so the numba kernels and their numpy
reference see the same numbers (tests/test_splitmix.py: bit for bit).

Raw draws: SplitMix64 (Steele, Lea & Flood 2014, Java's SplittableRandom; passes BigCrush):
raw(c) = mix(key + (c + 1) γ), γ = 2⁶⁴/φ, for the stream's counter c, so draw c is a function
of c alone and N draws are N independent lanes of arithmetic. The state is (key, counter)
uint64 (2,); key is one raw draw of the filter's seeded numpy generator.

Uniforms: the top 53 bits of a raw draw, as numpy's next_double. Normals: numpy's 256-layer
ziggurat (Marsaglia & Tsang 2000, the 52-bit variant of numpy's distributions.c, with numpy's
tables as numba ships them) on one raw draw each; the ~1.3 % that the fast path rejects go on
with a sub-stream of their own, raw draws mix(r + j γ), j = 1, 2, … from the rejected draw r, two
per round (the wedge test's uniform and the next attempt, or the tail's two uniforms). Every
normal takes exactly one draw of the main stream, whatever its rejections.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numba.np.random import _constants as _zig  # numpy's ziggurat tables, as numba ships them

from armtrack_cli.filters.fast_exp import exp_le0

_KI, _WI, _FI = _zig.ki_double.copy(), _zig.wi_double.copy(), _zig.fi_double.copy()
_R, _INV_R = float(_zig.ziggurat_nor_r), float(_zig.ziggurat_nor_inv_r)
_G = np.uint64(0x9E3779B97F4A7C15)  # γ: the golden ratio's odd 64-bit fraction
_M1, _M2 = np.uint64(0xBF58476D1CE4E5B9), np.uint64(0x94D049BB133111EB)
_U1, _U2, _U8, _U11 = np.uint64(1), np.uint64(2), np.uint64(8), np.uint64(11)
_U27, _U30, _U31 = np.uint64(27), np.uint64(30), np.uint64(31)
_MASK52, _MASK8 = np.uint64(0x000FFFFFFFFFFFFF), np.uint64(0xFF)
_TWO_M53 = 1.0 / 9007199254740992.0


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
        out[i] = np.float64(_mix(z) >> _U11) * _TWO_M53
        z += _G
    s[1] += np.uint64(n)


@njit(cache=True, error_model="numpy")
def _slow(r, idx, x, j):
    """The ziggurat after its fast path rejected raw draw r (layer idx, abscissa x): the tail
    beyond R (idx = 0) or the wedge test, then new attempts, from r's own sub-stream, whose
    first j draws are spent."""
    while True:
        u1 = np.float64(_mix(r + (j + _U1) * _G) >> _U11) * _TWO_M53
        r2 = _mix(r + (j + _U2) * _G)
        j += _U2
        if idx == 0:  # the tail: Marsaglia's exponential pair
            xx = -_INV_R * np.log1p(-u1)
            yy = -np.log1p(-np.float64(r2 >> _U11) * _TWO_M53)
            if yy + yy > xx * xx:
                return -(_R + xx) if (r >> _U8) & _U1 else _R + xx
        elif (_FI[idx - 1] - _FI[idx]) * u1 + _FI[idx] < exp_le0(-0.5 * x * x):
            return x
        else:  # a new attempt on r2
            r, idx, x, ok = _attempt(r2)
            if ok:
                return x
            continue
        # the tail's pair failed: a new attempt on a fresh draw of the sub-stream
        r, idx, x, ok = _attempt(_mix(r + (j + _U1) * _G))
        j += _U1
        if ok:
            return x


@njit(cache=True, inline="always")
def _attempt(r):
    """The ziggurat's fast path on raw draw r: (r, layer, ±abscissa, accepted) — index from
    the low 8 bits, sign from the next, 52 bits of abscissa, as numpy's."""
    idx = np.intp(r & _MASK8)
    rs = r >> _U8
    rabs = (rs >> _U1) & _MASK52
    x = np.float64(np.int64(rabs)) * _WI[idx]
    return r, idx, -x if rs & _U1 else x, rabs < _KI[idx]


@njit(cache=True, error_model="numpy")
def fill_normals(s, out):
    """out (C-contiguous, any shape) ← standard normals in row-major order, as
    ``normals(s, out.shape)``: the fast path for all in SIMD, marking the rejected ones; then
    those (~1.3 %), listed, and their first round (the wedge test, or a new attempt) for all
    in one branch-free loop; the tail and the rare second rounds one at a time."""
    fill_normals_with(s, out, normals_work(out.size))


@njit(cache=True, error_model="numpy")
def normals_work(n):
    """The work arrays of fill_normals_with for n normals, made once for many calls."""
    m = 8 * ((n + 7) // 8)
    return (np.zeros(m, np.uint8), np.empty(m + 8, np.int64), np.empty(m // 8, np.int64),
            np.empty(m), np.empty(m, np.bool_), np.empty(m, np.uint64))


@njit(cache=True, error_model="numpy")
def fill_normals_with(s, out, work):
    """fill_normals with its work arrays given (normals_work(out.size))."""
    n = out.size
    base = s[0] + (s[1] + _U1) * _G
    rejected, pending, words, x, again, raw = work
    flat = out.reshape(n)
    _fast_path(base, flat, rejected[:n], raw[:n])
    m = _listed(rejected, pending, words)
    if m:
        _first_round(base, pending[:m], x[:m], again[:m])
        for t in range(m):
            i = pending[t]
            flat[i] = x[t]
            if again[t]:  # the tail (j = 0: from the start) or a second rejection (j = 2)
                r, idx, xi, ok = _attempt(_mix(base + np.uint64(i) * _G))
                j = np.uint64(0)
                if idx != 0:
                    r, idx, xi, ok = _attempt(_mix(r + _U2 * _G))
                    j = _U2
                flat[i] = _slow(r, idx, xi, j)
    s[1] += np.uint64(n)


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
    """_slow's first round for the rejected draws at ``pending``, all alike in SIMD: the wedge
    test on u1 = sub-draw 1, else a new attempt on sub-draw 2, into out; again where that
    does not settle it, or in the tail (layer 0), which _slow draws apart."""
    for t in range(pending.size):
        r, idx, x, _ = _attempt(_mix(base + np.uint64(pending[t]) * _G))
        u1 = np.float64(_mix(r + _U1 * _G) >> _U11) * _TWO_M53
        _, _, x2, ok2 = _attempt(_mix(r + _U2 * _G))
        lo = _FI[max(idx, 1) - 1]  # layer 0 (the tail) never takes the wedge
        wedge = (lo - _FI[idx]) * u1 + _FI[idx] < exp_le0(-0.5 * x * x)
        out[t] = x if wedge else x2
        again[t] = (idx == 0) | (not (wedge | ok2))


@njit(cache=True, error_model="numpy")
def _fast_path(base, flat, rejected, raw):
    """flat (n,) ← the fast path on raw draws base + iγ (1-D arrays of their own: LLVM does not
    vectorise a loop on a reshaped view), rejected[i] = 1 where it rejects; raw (n,) work. The
    raw draws in SIMD, z = base + iγ by induction (one 64-bit multiply fewer a draw); the
    tables' look-ups one at a time, which here beats LLVM's gathers by a sixth."""
    z = base
    for i in range(flat.size):
        raw[i] = _mix(z)
        z += _G
    for i in range(flat.size):
        r, idx, x, ok = _attempt(raw[i])
        if idx < 0:  # never: an exit that keeps LLVM from vectorising the look-ups
            break
        flat[i] = x
        rejected[i] = not ok


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


def uniforms(s: np.ndarray, n: int) -> np.ndarray:
    """n uniforms on [0, 1) from stream s (advanced)."""
    return (_raw_np(s, n) >> _U11).astype(float) * _TWO_M53


def normals(s: np.ndarray, shape) -> np.ndarray:
    """Standard normals of ``shape`` from stream s (advanced), one main draw each."""
    r = _raw_np(s, int(np.prod(shape)))
    x, ok, idx = _attempt_np(r)
    bad = np.flatnonzero(~ok)  # the rejected (~1.3 %): as the kernel's _slow, all at once
    x[bad] = _slow_np(r[bad], idx[bad], x[bad])
    return x.reshape(shape)


def _attempt_np(r: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """_attempt on raw draws r: (±abscissa, accepted, layer)."""
    idx = (r & _MASK8).astype(np.intp)
    rs = r >> _U8
    rabs = (rs >> _U1) & _MASK52
    x = rabs.astype(np.int64).astype(float) * _WI[idx]
    return np.where((rs & _U1).astype(bool), -x, x), rabs < _KI[idx], idx


def _slow_np(r: np.ndarray, idx: np.ndarray, x: np.ndarray) -> np.ndarray:
    """_slow for arrays of rejected draws, a round at a time for those still pending: the
    same draws from the same sub-streams, the same tests."""
    out, j = np.empty(r.size), np.zeros(r.size, np.uint64)
    todo = np.arange(r.size)
    while todo.size:
        rr, ii, xx, jj = r[todo], idx[todo], x[todo], j[todo]
        u1 = (_mix_np(rr + (jj + _U1) * _G) >> _U11).astype(float) * _TWO_M53
        r2 = _mix_np(rr + (jj + _U2) * _G)
        jj = jj + _U2
        tail = ii == 0
        with np.errstate(divide="ignore", invalid="ignore"):
            xt = -_INV_R * np.log1p(-u1)
            yt = -np.log1p(-(r2 >> _U11).astype(float) * _TWO_M53)
        tail_ok = tail & (yt + yt > xt * xt)
        wedge_ok = ~tail & ((_FI[ii - 1] - _FI[ii]) * u1 + _FI[ii] < np.exp(-0.5 * xx * xx))
        xt = np.where(((rr >> _U8) & _U1).astype(bool), -(_R + xt), _R + xt)
        done = tail_ok | wedge_ok
        out[todo[done]] = np.where(tail_ok, xt, xx)[done]
        retry = ~done  # a new attempt: the wedge's on r2, the tail's on a fresh draw
        rn = np.where(tail, _mix_np(rr + (jj + _U1) * _G), r2)[retry]
        jj = (jj + tail.astype(np.uint64))[retry]
        xn, okn, idn = _attempt_np(rn)
        out[todo[retry][okn]] = xn[okn]
        todo = todo[retry][~okn]
        r[todo], idx[todo], x[todo], j[todo] = rn[~okn], idn[~okn], xn[~okn], jj[~okn]
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
