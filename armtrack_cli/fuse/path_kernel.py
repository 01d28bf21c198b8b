"""The path a linear process steps a state through, compiled with numba: the IMU's path over
a window of the wrong-root repair (fuse/branch_repair.py), whose Python loop over frames
(F x + b, a 15 × 15 product a frame: ~4 µs each, 40,000 frames of windows on the 10-minute
bench session) was a tenth of the arm smoother's time (issue 15). tests/test_branch_repair.py
holds it to the numpy loop (F[j] @ x + b[j]) to 1e-12."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def affine_path(F, b, x, D, first):
    """x ← F[j] x + b[j] for each step j of F (m, d, d), b (m, d) in turn, x (d,) in place;
    D[first + j] ← x[:3], the position after step j."""
    d = x.size
    v = np.empty(d)
    for j in range(F.shape[0]):
        for i in range(d):
            acc = 0.0
            for k in range(d):
                acc += F[j, i, k] * x[k]
            v[i] = acc + b[j, i]
        for i in range(d):
            x[i] = v[i]
        for i in range(3):
            D[first + j, i] = x[i]
