"""fuse/association.associate compiled with numba: the same posterior (Cordella eq. 8-12),
gate, one-blob-per-marker assignment and merged-blob checks, in loops, with the assignment
solved exactly by the Hungarian method (shortest augmenting paths, Kuhn-Munkres as in
Jonker & Volgenant 1987) instead of scipy's linear_sum_assignment.

tests/test_palm_kernel.py holds it equal to the numpy reference on random scenes.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

FORBID = 1e9  # cost of an excluded pairing: far above any sum of finite costs (log-densities)


@njit(cache=True)
def _hungarian(cost, assign):
    """Minimum-cost assignment of every row of cost (n, m), n ≤ m, to a distinct column:
    assign[i] = column of row i."""
    n, m = cost.shape
    u, v = np.zeros(n + 1), np.zeros(m + 1)
    p, way = np.zeros(m + 1, np.int64), np.zeros(m + 1, np.int64)
    minv, used = np.empty(m + 1), np.empty(m + 1, np.bool_)
    for i in range(1, n + 1):
        p[0], j0 = i, 0
        minv[:] = np.inf
        used[:] = False
        while True:
            used[j0] = True
            i0, delta, j1 = p[j0], np.inf, 0
            for j in range(1, m + 1):
                if not used[j]:
                    cur = cost[i0 - 1, j - 1] - u[i0] - v[j]
                    if cur < minv[j]:
                        minv[j], way[j] = cur, j0
                    if minv[j] < delta:
                        delta, j1 = minv[j], j
            for j in range(m + 1):
                if used[j]:
                    u[p[j]] += delta
                    v[j] -= delta
                else:
                    minv[j] -= delta
            j0 = j1
            if p[j0] == 0:
                break
        while j0 != 0:
            j1 = way[j0]
            p[j0] = p[j1]
            j0 = j1
    for j in range(1, m + 1):
        if p[j] > 0:
            assign[p[j] - 1] = j - 1


@njit(cache=True)
def _gauss2(d0, d1, a, b, c):
    """log N(d; 0, [[a, b], [b, c]]) and the squared Mahalanobis distance."""
    det = a * c - b * b
    m2 = (c * d0 * d0 - 2 * b * d0 * d1 + a * d1 * d1) / det
    return -0.5 * m2 - math.log(2 * math.pi * math.sqrt(det)), m2


@njit(cache=True)
def associate(y, zm, S, usable, prior_marker, prior_clutter, image_area, gate, merge_px,
              marker_of_blob, blob_of_marker):
    """y (B, 2), zm (M, 2), S (M, 2, 2), usable (M,) -> marker_of_blob (B,),
    blob_of_marker (M,) filled (-1: clutter, gated out, unused)."""
    B, M = y.shape[0], zm.shape[0]
    marker_of_blob[:] = -1
    blob_of_marker[:] = -1
    if B == 0:
        return
    lpm, lpc = math.log(prior_marker / M), math.log(prior_clutter / image_area)
    own = np.empty((B, M))  # log N(y_i − ŷ_j, P_yy,j), eq. 12
    cost = np.full((B, M + B), FORBID)
    for i in range(B):
        for j in range(M):
            ll, m2 = _gauss2(y[i, 0] - zm[j, 0], y[i, 1] - zm[j, 1], S[j, 0, 0], S[j, 0, 1],
                             S[j, 1, 1])
            own[i, j] = ll
            if m2 <= gate and usable[j]:
                cost[i, j] = -(ll + lpm)
        cost[i, M + i] = -lpc  # clutter anywhere in the image
    assign = np.empty(B, np.int64)
    _hungarian(cost, assign)
    for i in range(B):
        if assign[i] < M and cost[i, assign[i]] < FORBID / 2:
            marker_of_blob[i] = assign[i]
    lim = merge_px * merge_px
    for i in range(B):  # markers predicted too close to tell apart: gated out
        j = marker_of_blob[i]
        if j < 0:
            continue
        for k in range(M):
            if k != j and usable[k] and _sep2(zm, j, k) < lim:
                marker_of_blob[i] = -1
                break
    for i in range(B):  # one blob over two merged markers explains it better: gated out
        j = marker_of_blob[i]
        if j < 0:
            continue
        for k in range(M):
            if k == j or not usable[k] or _sep2(zm, j, k) >= 9 * lim:
                continue
            ll2, _ = _gauss2(y[i, 0] - (zm[j, 0] + zm[k, 0]) / 2, y[i, 1] - (zm[j, 1] + zm[k, 1]) / 2,
                             (S[j, 0, 0] + S[k, 0, 0]) / 4, (S[j, 0, 1] + S[k, 0, 1]) / 4,
                             (S[j, 1, 1] + S[k, 1, 1]) / 4)
            if ll2 > own[i, j]:
                marker_of_blob[i] = -1
                break
    for i in range(B):
        if marker_of_blob[i] >= 0:
            blob_of_marker[marker_of_blob[i]] = i


@njit(cache=True)
def _sep2(zm, j, k):
    d0, d1 = zm[j, 0] - zm[k, 0], zm[j, 1] - zm[k, 1]
    return d0 * d0 + d1 * d1
