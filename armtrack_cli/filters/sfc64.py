"""numpy's SFC64 generator and its ``standard_normal`` and ``random``, written for numba kernels
so that a compiled loop draws inline (no call through numpy's bit-generator pointer) and yet
draws exactly what ``np.random.Generator(np.random.SFC64(seed))`` draws: the numpy reference
of a kernel consumes the same numbers from numpy itself (tests/test_sfc64.py checks the
streams bit for bit).

The state is a uint64 array (a, b, c, counter), as numpy's ``bit_generator.state``;
``get_state`` and ``set_state`` move it between the two. SFC64: Doty-Humphrey's "small fast
chaotic" generator (PractRand). Normals: numpy's 256-layer ziggurat (Marsaglia & Tsang 2000, 52-bit variant of
numpy's distributions.c), with numpy's own tables as numba ships them.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numba.np.random import _constants as _zig  # numpy's ziggurat tables, as numba ships them

_KI, _WI, _FI = _zig.ki_double.copy(), _zig.wi_double.copy(), _zig.fi_double.copy()
_R, _INV_R = float(_zig.ziggurat_nor_r), float(_zig.ziggurat_nor_inv_r)
_U1, _U3, _U8, _U11, _U24, _U40 = (np.uint64(v) for v in (1, 3, 8, 11, 24, 40))
_MASK52 = np.uint64(0x000FFFFFFFFFFFFF)
_MASK8 = np.uint64(0xFF)
_TWO_M53 = 1.0 / 9007199254740992.0


def generator(seed: int) -> np.random.Generator:
    """The generator the particle filters draw from: numpy's SFC64, seeded like default_rng."""
    return np.random.Generator(np.random.SFC64(seed))


def get_state(rng: np.random.Generator) -> np.ndarray:
    """The state of an SFC64 ``rng`` as (a, b, c, counter) uint64 (4,)."""
    st = rng.bit_generator.state
    if st["bit_generator"] != "SFC64":
        raise TypeError(f"an SFC64 generator is needed, not {st['bit_generator']}")
    return np.array(st["state"]["state"], np.uint64)


def set_state(rng: np.random.Generator, state: np.ndarray) -> None:
    """Advance ``rng`` to ``state`` (what a kernel drew is then drawn)."""
    st = rng.bit_generator.state
    st["state"] = {"state": np.array(state, np.uint64)}
    rng.bit_generator.state = st


@njit(cache=True, inline="always")
def next_uint64(s):
    """One SFC64 step (numpy's sfc64.h): tmp = a + b + counter++, a = b ^ b>>11,
    b = c + c<<3, c = rotl(c, 24) + tmp."""
    a, b, c, n = s[0], s[1], s[2], s[3]
    tmp = a + b + n
    s[3] = n + _U1
    s[0] = b ^ (b >> _U11)
    s[1] = c + (c << _U3)
    s[2] = ((c << _U24) | (c >> _U40)) + tmp
    return tmp


@njit(cache=True, inline="always")
def random(s):
    """A uniform on [0, 1) as numpy's next_double: the top 53 bits."""
    return np.float64(next_uint64(s) >> _U11) * _TWO_M53


@njit(cache=True)
def _rejected(s, rabs, idx, x):
    """The ziggurat's rare path (about 1 % of draws): the tail beyond r for layer 0, else the
    wedge test; returns (accepted, value)."""
    if idx == 0:
        while True:
            xx = -_INV_R * np.log1p(-random(s))
            yy = -np.log1p(-random(s))
            if yy + yy > xx * xx:
                return True, -(_R + xx) if (rabs >> _U8) & _U1 else _R + xx
    if (_FI[idx - 1] - _FI[idx]) * random(s) + _FI[idx] < np.exp(-0.5 * x * x):
        return True, x
    return False, 0.0


@njit(cache=True)
def fill_normals(s, out):
    """out (n, m) ← standard normals in row-major order, as rng.standard_normal((n, m)),
    whatever out's memory layout (a kernel may pass the transpose of an (m, n) array): numpy's
    random_standard_normal (index from the low 8 bits, sign from the next, 52 bits of
    abscissa; accepted at once 99 % of the time), the generator's state held in locals."""
    a, b, c, n = s[0], s[1], s[2], s[3]
    for i in range(out.shape[0]):
        for j in range(out.shape[1]):
            while True:
                r = a + b + n  # next_uint64, inline
                n += _U1
                a = b ^ (b >> _U11)
                b = c + (c << _U3)
                c = ((c << _U24) | (c >> _U40)) + r
                idx = np.intp(r & _MASK8)
                r >>= _U8
                rabs = (r >> _U1) & _MASK52
                x = np.float64(np.int64(rabs)) * _WI[idx]
                if r & _U1:
                    x = -x
                if rabs < _KI[idx]:
                    out[i, j] = x
                    break
                s[0], s[1], s[2], s[3] = a, b, c, n
                ok, v = _rejected(s, rabs, idx, x)
                a, b, c, n = s[0], s[1], s[2], s[3]
                if ok:
                    out[i, j] = v
                    break
    s[0], s[1], s[2], s[3] = a, b, c, n


@njit(cache=True)
def fill_random(s, out):
    """out (n,) ← uniforms on [0, 1), as rng.random(n)."""
    for i in range(out.size):
        out[i] = random(s)
