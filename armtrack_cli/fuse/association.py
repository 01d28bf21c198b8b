"""Which blob is which marker, or clutter (Cordella et al. III-C, eq. 6-12).

Each blob y_i gets a latent a_i ∈ {0 (clutter), 1..M} (eq. 6). For a_i = j the likelihood
is the UKF's predicted-measurement density N(y_i − ŷ_j, P_yy,j) (eq. 8-12, ŷ_j and P_yy,j
from the predicted sigma points); for clutter it is 1/RES, the image area in pixels (after
eq. 12). The priors (eq. 7) are p(a = 0) and p(a = j) = p_marker / M, as in [3].

The paper takes the most probable a_i for each blob on its own. We keep its posterior (eq. 12)
but choose the jointly most probable association in which each marker explains at most one
blob (an assignment problem, solved exactly), and a blob further than the gate from a marker
cannot be that marker. Blobs that merge would pull the estimate between two markers: a blob
that the merged hypothesis of two neighbouring markers j, k (centroid at (ŷ_j + ŷ_k)/2,
covariance (P_yy,j + P_yy,k)/4) explains better than its marker alone is gated out, and so is
one associated with markers predicted closer than ``merge_px`` (too close to tell apart).
The caller also gates out blobs whose area is that of two markers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

NO = -1e18  # log-probability of an excluded pairing


@dataclass(frozen=True)
class Association:
    marker_of_blob: np.ndarray  # (B,) marker index, or -1 for clutter / gated out
    blob_of_marker: np.ndarray  # (M,) blob index, or -1 when the marker is not used
    log_post: np.ndarray  # (B, M + 1) unnormalised log posterior (eq. 12), column 0 clutter


def log_posterior(y: np.ndarray, zm: np.ndarray, S: np.ndarray, *, prior_marker: float,
                  prior_clutter: float, image_area: float) -> tuple[np.ndarray, np.ndarray]:
    """(B, M + 1) log p(a_i = j | y_i, y_0:t-1) + const, column 0 clutter, 1..M the markers;
    and (B, M) the squared Mahalanobis distances.

    y (B, 2) blobs; zm (M, 2) predicted marker pixels (eq. 10); S (M, 2, 2) their innovation
    covariances P_yy,j (eq. 11)."""
    M = zm.shape[0]
    ll, m2 = _gauss2(y[:, None, :] - zm[None], S[None])  # log N(y_i − ŷ_j, P_yy,j), eq. 12
    out = np.empty((y.shape[0], M + 1))
    out[:, 0] = np.log(prior_clutter / image_area)  # clutter anywhere in the image
    out[:, 1:] = ll + np.log(prior_marker / M)
    return out, m2


def _gauss2(d: np.ndarray, S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """log N(d; 0, S) and the squared Mahalanobis distance for (..., 2) d, (..., 2, 2) S."""
    a, b, c = S[..., 0, 0], S[..., 0, 1], S[..., 1, 1]
    det = a * c - b * b
    m2 = (c * d[..., 0] ** 2 - 2 * b * d[..., 0] * d[..., 1] + a * d[..., 1] ** 2) / det
    return -0.5 * m2 - np.log(2 * np.pi * np.sqrt(det)), m2


def associate(y: np.ndarray, zm: np.ndarray, S: np.ndarray, usable: np.ndarray, *,
              prior_marker: float, prior_clutter: float, image_area: float, gate: float,
              merge_px: float) -> Association:
    """The most probable association with each marker used at most once.

    usable (M,): markers predicted visible (facing the camera); the others cannot be chosen."""
    B, M = y.shape[0], zm.shape[0]
    lp, m2 = log_posterior(y, zm, S, prior_marker=prior_marker, prior_clutter=prior_clutter,
                           image_area=image_area)
    if B == 0:
        return Association(np.zeros(0, int), np.full(M, -1), lp)
    score = lp[:, 1:].copy()
    score[(m2 > gate) | ~usable[None, :]] = NO
    cost = np.full((B, M + B), -NO)  # B × (M + B): markers, then a clutter column per blob
    cost[:, :M] = -score
    cost[np.arange(B), M + np.arange(B)] = -lp[:, 0]
    rows, cols = linear_sum_assignment(cost)
    marker_of_blob = np.full(B, -1)
    ok = (cols < M) & (score[rows, np.minimum(cols, M - 1)] > NO / 2)
    marker_of_blob[rows[ok]] = cols[ok]
    dd = zm[:, None] - zm[None]
    sep2 = np.einsum("jki,jki->jk", dd, dd) + np.eye(M) * 1e18  # squared separations, not self
    merged = ((sep2 < merge_px**2) & usable[None, :]).any(axis=1) & usable
    marker_of_blob[(marker_of_blob >= 0) & merged[marker_of_blob]] = -1  # gated out
    i = np.flatnonzero(marker_of_blob >= 0)
    j = marker_of_blob[i]
    near = usable[None, :] & (sep2[j] < 9 * merge_px**2)  # (n, M): j's neighbours k
    if near.any():  # one blob over two merged markers: N(y − (ŷ_j + ŷ_k)/2, (S_j + S_k)/4)
        ll2, _ = _gauss2(y[i, None] - (zm[j, None] + zm[None]) / 2, (S[j, None] + S[None]) / 4)
        own = lp[i, 1 + j] - np.log(prior_marker / M)
        marker_of_blob[i[(near & (ll2 > own[:, None])).any(axis=1)]] = -1  # gated out
    blob_of_marker = np.full(M, -1)
    used = marker_of_blob >= 0
    blob_of_marker[marker_of_blob[used]] = np.flatnonzero(used)
    return Association(marker_of_blob, blob_of_marker, lp)
