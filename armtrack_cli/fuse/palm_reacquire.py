"""Picking the hand up again after the markers were lost for longer than max_coast_s.

With no prediction left to associate with, the blobs are labelled by the palm model alone,
then the pose is fitted as at the start (Cordella et al. III-D, eq. 13-20, fuse/palm_init.py):

1. Hypotheses: every choice of M blobs (M = the model's markers), every blob of it as the
   WRIST, the other blobs named in their angular order around it (the order of the model's
   markers around the WRIST, in either sense: the back of the hand may be seen from either
   side of its plane in the image). A fan wider than 150° is no palm and is dropped.
2. The markers are coplanar (z_H = 0), so the right labelling maps the model plane to the
   undistorted image by a homography: each hypothesis's homography by DLT (all at once,
   batched SVD) and its reprojection RMS in pixels; the smallest wins if below max_rms_px.
3. The pose g_{CH} by the iterated Gauss-Newton fit of palm_init.initial_pose on the labelled
   pixels and, where the blobs carry them, depths; accepted if its residual is below
   max_rms_px and every marker faces the camera. In W0: R_{W0H} = R_{CW0}ᵀ R_{CH},
   T = R_{CW0}ᵀ (T_{CH} − T_{CW0}).

Needs every marker seen at once (a hand coming back with a marker hidden waits for it).
"""

from __future__ import annotations

from itertools import combinations

import cv2
import numpy as np

from armtrack_cli.fuse.palm_init import initial_pose
from armtrack_cli.fuse.palm_models import Rig, facing

MAX_BLOBS = 10  # C(10, 6) = 210 choices × 6 WRIST × 2 senses: a few ms
MAX_FAN = np.deg2rad(150.0)


def _fan_order(p: np.ndarray, w: int, rest: list[int]) -> tuple[np.ndarray, float]:
    """The indices ``rest`` in ascending angle about point w (from their mean direction), and
    the angular spread; as calibrate/palm_model.label_palm orders them."""
    v = p[rest] - p[w]
    ref = v.sum(axis=0)
    ang = np.arctan2(ref[0] * v[:, 1] - ref[1] * v[:, 0], v @ ref)
    return np.asarray(rest)[np.argsort(ang)], float(np.ptp(ang))


def _hypotheses(xy: np.ndarray, model_xy: np.ndarray) -> np.ndarray:
    """(N, M) blob index of each model marker, for every labelling worth testing."""
    M = model_xy.shape[0]
    w_model = int(np.argmin(np.linalg.norm(model_xy, axis=1)))  # the WRIST: T_wi = 0
    order, _ = _fan_order(model_xy, w_model, [j for j in range(M) if j != w_model])
    out = []
    for combo in combinations(range(xy.shape[0]), M):
        for w in combo:
            seq, spread = _fan_order(xy, w, [b for b in combo if b != w])
            if spread > MAX_FAN:
                continue
            for sense in (seq, seq[::-1]):
                lab = np.empty(M, int)
                lab[w_model], lab[order] = w, sense
                out.append(lab)
    return np.array(out, int).reshape(-1, M)


def _homography_rms(model_xy: np.ndarray, img: np.ndarray) -> np.ndarray:
    """(N,) RMS (normalised image units) of the best homography model plane -> img (N, M, 2),
    by DLT on scaled coordinates (Hartley's normalisation), all hypotheses at once."""
    s_m = 1.0 / np.abs(model_xy).max()
    X, Y = model_xy[:, 0] * s_m, model_xy[:, 1] * s_m
    c = img.mean(axis=1, keepdims=True)
    s_i = 1.0 / np.maximum(np.abs(img - c).max(axis=(1, 2)), 1e-12)[:, None]
    x, y = (img[..., 0] - c[..., 0]) * s_i, (img[..., 1] - c[..., 1]) * s_i
    N, M = x.shape
    one, zero = np.ones((N, M)), np.zeros((N, M))
    Xn, Yn = np.broadcast_to(X, (N, M)), np.broadcast_to(Y, (N, M))
    r1 = np.stack([Xn, Yn, one, zero, zero, zero, -x * Xn, -x * Yn, -x], -1)
    r2 = np.stack([zero, zero, zero, Xn, Yn, one, -y * Xn, -y * Yn, -y], -1)
    A = np.concatenate([r1, r2], axis=1)  # (N, 2M, 9)
    h = np.linalg.svd(A)[2][:, -1].reshape(N, 3, 3)
    P = np.einsum("nij,mj->nmi", h, np.c_[X, Y, np.ones(M)])
    w = P[..., 2]
    ok = np.abs(w).min(axis=1) > 1e-12
    ex = P[..., 0] / np.where(ok[:, None], w, 1.0) - x
    ey = P[..., 1] / np.where(ok[:, None], w, 1.0) - y
    rms = np.sqrt(np.mean(ex**2 + ey**2, axis=1)) / s_i[:, 0]
    return np.where(ok, rms, np.inf)


def reacquire(blobs: np.ndarray, rig: Rig, *, sigma_px: float, sigma_z: float,
              max_rms_px: float = 3.0):
    """From one frame's blobs (B, 4): u, v (px), area, depth (m, NaN = none), the hand's
    pose in W0 and each blob's marker: (R_{W0H} (3, 3), T (3,), marker_of_blob (B,), -1 for
    the rest), or None when no labelling fits."""
    M = rig.markers_H.shape[0]
    B = blobs.shape[0]
    if not M <= B <= MAX_BLOBS:
        return None
    n = cv2.undistortPoints(blobs[:, None, :2].astype(np.float64), rig.K, rig.dist).reshape(-1, 2)
    model_xy = rig.markers_H[:, :2]
    labs = _hypotheses(n, model_xy)
    if labs.size == 0:
        return None
    rms = _homography_rms(model_xy, n[labs]) * rig.K[0, 0]  # normalised -> px
    best = int(np.argmin(rms))
    if not rms[best] < max_rms_px:
        return None
    lab = labs[best]
    z = blobs[lab, 3]
    fit = initial_pose(rig.markers_H, blobs[lab, :2], z if np.isfinite(z).any() else None,
                       K=rig.K, dist=rig.dist, sigma_px=sigma_px, sigma_z=sigma_z)
    R = rig.R_CW0.T @ fit.R_CW0  # the fit's "W0" is H now: R_CH, T_CH
    T = rig.R_CW0.T @ (fit.T_CW0 - rig.T_CW0)
    if not (fit.rms_px < max_rms_px and facing(rig, R, T).all()):
        return None
    mob = np.full(B, -1)
    mob[lab] = np.arange(M)
    return R, T, mob
