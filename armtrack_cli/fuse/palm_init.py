"""The camera-to-W0 pose from the first frame (Cordella et al. III-D, eq. 13-20).

With the hand neutral and the six markers labelled by the palm model, g_{W0C}(θ) is the
least-squares fit of the markers' projections and depths (eq. 13-15):
    min_θ Σ ‖(π(g_{W0C}(θ) T_wi) − y_i) / σ_px‖² + ((e₃ᵀ g_{W0C}(θ) T_wi − z_i) / σ_z)².
The paper takes one linearisation (eq. 16-20); we iterate the same Gauss-Newton step,
θ ← θ + H_θ† (ȳ − h̄(θ)) (eq. 19-20), to convergence. θ = (φ, δT) perturbs the current pose,
R ← exp(φ^) R, T ← T + δT. Without depth the cost keeps the projections alone: with the
markers at their measured link lengths (palm.toml) the planar pose is still determined.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from armtrack_cli.filters.manifold_ukf import exp_so3
from armtrack_cli.fuse.palm_models import distort_project

MAX_ITER = 100
STEP_TOL = 1e-10  # rad or m: a step this small changes nothing that matters


@dataclass(frozen=True)
class InitialPose:
    R_CW0: np.ndarray  # (3, 3)
    T_CW0: np.ndarray  # (3,) m
    rms_px: float  # reprojection residual
    rms_depth_mm: float  # depth residual (NaN without depth)
    used_depth: bool
    iterations: int


def _residual(R, T, markers_H, y, z, K, dist, sigma_px, sigma_z):
    X = markers_H @ R.T + T  # g_{W0C}(θ) T_wi
    r = [((distort_project(K, dist, X) - y) / sigma_px).ravel()]  # h_y, eq. 13
    if z is not None:
        ok = np.isfinite(z)
        r.append((X[ok, 2] - z[ok]) / sigma_z)  # h_z = e₃ᵀ(…), eq. 13
    return np.concatenate(r)


def _start(markers_H, y, z, K, dist):
    """A first pose: Kabsch on the depth-lifted markers, else planar PnP (IPPE)."""
    if z is not None and np.isfinite(z).sum() >= 3:
        n = cv2.undistortPoints(y.reshape(-1, 1, 2).astype(np.float64), K, dist).reshape(-1, 2)
        ok = np.isfinite(z)
        X = np.c_[n, np.ones(len(n))][ok] * z[ok, None]
        A = markers_H[ok]
        ca, cx = A.mean(0), X.mean(0)
        U, _, Vt = np.linalg.svd((X - cx).T @ (A - ca))
        D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
        R = U @ D @ Vt
        return R, cx - R @ ca
    ok, rvec, tvec = cv2.solvePnP(markers_H.astype(np.float64), y.astype(np.float64), K, dist,
                                  flags=cv2.SOLVEPNP_IPPE)
    if not ok:
        ok, rvec, tvec = cv2.solvePnP(markers_H.astype(np.float64), y.astype(np.float64), K, dist)
    return cv2.Rodrigues(rvec)[0], tvec.ravel()


def initial_pose(markers_H: np.ndarray, y: np.ndarray, z: np.ndarray | None, *, K: np.ndarray,
                 dist: np.ndarray, sigma_px: float = 1.0, sigma_z: float = 0.004,
                 start: tuple[np.ndarray, np.ndarray] | None = None) -> InitialPose:
    """g_{W0C} from the labelled first-frame pixels y (M, 2) and depths z (M,) (m, NaN = no
    reading; None = no depth frame), markers_H (M, 3) the palm model."""
    use_z = z is not None and bool(np.isfinite(z).any())
    z = z if use_z else None
    R, T = start if start is not None else _start(markers_H, y, z, K, dist)
    args = (markers_H, y, z, K, dist, sigma_px, sigma_z)
    h, iterations = 1e-7, 0
    while iterations < MAX_ITER:
        iterations += 1
        r0 = _residual(R, T, *args)
        J = np.empty((r0.size, 6))
        for k in range(6):  # H_θ = ∂h̄/∂θ (eq. 17), central differences
            e = np.zeros(6)
            e[k] = h
            rp = _residual(exp_so3(e[:3]) @ R, T + e[3:], *args)
            rm = _residual(exp_so3(-e[:3]) @ R, T - e[3:], *args)
            J[:, k] = (rp - rm) / (2 * h)
        step = -np.linalg.lstsq(J, r0, rcond=None)[0]  # H_θ† (ȳ − h̄(θ)), eq. 19-20
        R, T = exp_so3(step[:3]) @ R, T + step[3:]
        if np.abs(step).max() < STEP_TOL:
            break
    X = markers_H @ R.T + T
    e_px = np.linalg.norm(distort_project(K, dist, X) - y, axis=1)
    e_z = (X[:, 2] - z)[np.isfinite(z)] if use_z else np.array([np.nan])
    return InitialPose(R, T, float(np.sqrt(np.mean(e_px**2))),
                       float(np.sqrt(np.mean(e_z**2)) * 1000.0), use_z, iterations)


def depth_at(depth: np.ndarray | None, px: np.ndarray) -> np.ndarray | None:
    """(M,) depth (m) under each pixel: the median of a 5×5 window (NaN = no reading)."""
    if depth is None:
        return None
    out = np.full(len(px), np.nan)
    for i, (u, v) in enumerate(px):
        y0, x0 = int(round(v)), int(round(u))
        win = depth[max(0, y0 - 2):y0 + 3, max(0, x0 - 2):x0 + 3]
        if np.isfinite(win).any():
            out[i] = np.nanmedian(win)
    return out
