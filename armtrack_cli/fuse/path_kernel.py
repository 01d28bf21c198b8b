"""The path a linear process steps a state through, compiled with numba: the IMU's path over
each window of the wrong-root repair (fuse/branch_repair.py). As a Python loop (F x + b, a
15 × 15 product a frame) over the windows' 40,000 frames on the 10-minute bench session it
was 0.27 s of the arm smoother's 3.4 s in a profiled fuse (issue 15); compiled, ~0.02 s, and
~15 ms to load from the cache (fuse/kernel_setup.py loads it before the timed run).
tests/test_branch_repair.py holds it to numpy's loop (F[j] @ x + b[j]) to 1e-12."""

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
