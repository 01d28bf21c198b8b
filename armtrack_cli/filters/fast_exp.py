"""exp(x) for x ≤ 0 in SIMD, compiled (numba), for the particle kernels' weights and the
ziggurat's wedge test (filters/splitmix.py): within 1 ulp of np.exp (tests/test_pf_kernel.py),
where libm's exp, one call per value, keeps a loop from vectorising and is 3× slower.

x = n ln2 + r, |r| ≤ ln2 / 2 (Cody & Waite's two-part ln2), e^r by its Taylor series to r¹³
(truncation < 5e-18), then × 2ⁿ, n ∈ [−1075, 0], made from its bits: two factors 2^⌈n/2⌉ and
2^⌊n/2⌋, each a normal double (exponent field n/2 + 1023), so that a subnormal result is
rounded once, as np.exp rounds it, and no table is gathered.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["exp_le0", "exp_nonpositive"]

# error_model="numpy": x / 0 is inf as in numpy (no Python exception check in the loop)

_LN2_HI, _LN2_LO, _LOG2E = 6.93147180369123816490e-01, 1.90821492927058770002e-10, 1 / np.log(2)
_EXP_C = tuple(1.0 / np.cumprod(np.r_[1.0, np.arange(1.0, 14.0)]))  # 1 / j!, j = 0 … 13
_C0, _C1, _C2, _C3, _C4, _C5, _C6, _C7, _C8, _C9, _C10, _C11, _C12, _C13 = _EXP_C
_BIAS, _SHIFT = np.int64(1023), np.int64(52)


@njit(cache=True, inline="always")
def _pow2(n):
    """2ⁿ for an integral float n ∈ [−1022, 0], from its bits."""
    return np.int64((np.int64(n) + _BIAS) << _SHIFT).view(np.float64)


@njit(cache=True, inline="always", error_model="numpy")
def exp_le0(v):
    """exp(v) for v ≤ 0 (−inf: 0; NaN stays NaN)."""
    w = max(v, -760.0) if v == v else v  # exp(−760) rounds to 0 as exp(v) does
    n = np.rint(w * _LOG2E)
    r = (w - n * _LN2_HI) - n * _LN2_LO
    p = _C13 * r + _C12
    p = p * r + _C11
    p = p * r + _C10
    p = p * r + _C9
    p = p * r + _C8
    p = p * r + _C7
    p = p * r + _C6
    p = p * r + _C5
    p = p * r + _C4
    p = p * r + _C3
    p = p * r + _C2
    p = p * r + _C1
    p = p * r + _C0
    h = np.floor(0.5 * n) if w == w else 0.0  # n = h + (n − h), both ≥ −538
    return p * _pow2(n - h) * _pow2(h) if w == w else w


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def exp_nonpositive(x, m, out):
    """out = exp(x − m) for x (n,) ≤ m; out must not be x (the loop is vectorised only for
    distinct arrays)."""
    for i in range(x.size):
        out[i] = exp_le0(x[i] - m)
