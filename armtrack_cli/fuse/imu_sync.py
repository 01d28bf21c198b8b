"""The IMU's clock offset, estimated from the data ([sync] imu_offset_s = "auto"): the δ, with
session time = IMU time + δ, that lines the IMU's accelerations up with the wrist patch's
image motion, and its standard deviation.

The patch's image acceleration ü_k (a Savitzky–Golay second derivative of the detections) is
compared with the IMU's world acceleration a_W (eq. 4) projected into the image,
A_k(δ) = J_k a_W(t_k − δ), J_k = ∂π/∂p (eq. 7) at the point of the detection's ray at the
first detection's range (on the arm's sphere, models.initial_wrist). Both sides are filtered
alike by zero-phase filters (the same smoothing window, then a high-pass that removes what
~1° of orientation error leaks of gravity, slowly varying), so the filters shift neither in
time. Cost: the residual ü − c A(δ) with the best scale c (the range is approximate), mean
over the frames both cover. A grid at one frame period over the search window finds the
basin, a bounded scalar search refines it; the SD is the Gauss–Newton one,
σ² / (c² Σ ‖∂A/∂δ‖²), inflated by (1 + ρ)/(1 − ρ) for the residuals' lag-1 autocorrelation ρ
(compare/sync.py does the same for the ground truth).

Missing detections are missing: a frame whose smoothing window lacks one has no image
acceleration and is left out; an IMU gap longer than GAP_S leaves the frames it covers out.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from armtrack_cli.fuse import models

WINDOW_S = 0.5  # Savitzky–Golay window (cubic): keeps motion below ~2 Hz
KNOT_S = 2.0  # spacing of the drift's piecewise-linear basis (s): dense enough for the orientation error's gravity leak (0.02–0.2 Hz), sparse enough to leave the motion's timing
GAP_S = 0.1  # an IMU gap longer than this is missing, not interpolated across
MIN_OVERLAP = 0.5  # share of the frames with an image acceleration that must be scored
MIN_FRAMES = 30


@dataclass(frozen=True)
class ImuOffset:
    estimate_s: float  # δ: session time = IMU time + δ
    sd_s: float
    frames: int  # frames scored at the estimate


@dataclass(frozen=True)
class SyncProblem:
    """The IMU on its own clock and the camera on the session clock."""

    t_imu: np.ndarray  # (M,) s, IMU clock, valid samples only
    a_W: np.ndarray  # (M, 3) m/s², gravity removed (eq. 4)
    q_WB: np.ndarray  # (M, 4), (w, x, y, z) B into W
    t_frames: np.ndarray  # (n,) s, session clock
    uv: np.ndarray  # (n, 2) px, NaN = no detection
    proj: models.Projection
    arm: models.Arm | None


def _savgol(x: np.ndarray, window: int, deriv: int, dt: float) -> np.ndarray:
    """Cubic Savitzky–Golay along axis 0 (odd ``window``); NaN wherever the window holds a NaN
    or runs off either end."""
    from scipy.signal import savgol_coeffs

    c = savgol_coeffs(window, 3, deriv=deriv, delta=dt, use="dot")
    h = window // 2
    out = np.full(x.shape, np.nan)
    if x.shape[0] < window:
        return out
    idx = np.arange(h, x.shape[0] - h)
    stack = np.stack([x[idx - h + j] for j in range(window)], axis=0)  # (window, m, d)
    out[idx] = np.tensordot(c, stack, axes=(0, 0))
    return out


@dataclass(frozen=True)
class _Prepared:
    vel_img: np.ndarray  # (n, 2) px/s, the detections' velocity (NaN = none)
    J: np.ndarray  # (n, 2, 3) px/m
    drift: np.ndarray  # (n, m) hat functions of time, knots KNOT_S apart
    v_imu: np.ndarray  # (M, 3) m/s, ∫ a_W dt on the IMU's clock (NaN after a long gap)
    dt: float  # frame period, s
    window: int


def _prepare(p: SyncProblem, delta: float) -> _Prepared:
    dt = float(np.median(np.diff(p.t_frames)))
    window = max(5, int(round(WINDOW_S / dt)) | 1)
    J = _jacobians(p.proj, _fill(wrist_on_rays(p, delta)))
    knots = np.arange(p.t_frames[0], p.t_frames[-1] + KNOT_S, KNOT_S)
    drift = np.clip(1 - np.abs(p.t_frames[:, None] - knots[None, :]) / KNOT_S, 0, None)
    v_imu = np.vstack([np.zeros((1, 3)), np.cumsum(0.5 * (p.a_W[1:] + p.a_W[:-1])
                                                   * np.diff(p.t_imu)[:, None], axis=0)])
    return _Prepared(_savgol(p.uv, window, 1, dt), J, drift, v_imu, dt, window)


def wrist_on_rays(p: SyncProblem, delta: float) -> np.ndarray:
    """(n, 3) m: each detection's ray where it meets the arm's sphere |p − (S + L2 R u)| = L1
    (eq. 15; the IMU's orientation at t − δ), the intersection nearer the previous frame's
    (the first: models.initial_wrist's), the ray's nearest point where it misses; without an
    arm, at the range of the first detection's start. NaN without a detection."""
    from armtrack_cli.core import quaternion as quat

    det = np.flatnonzero(np.isfinite(p.uv).all(axis=1))
    q = quat.interpolate(p.t_imu + delta, p.q_WB, p.t_frames[det])
    q[~np.isfinite(q).all(axis=1)] = p.q_WB[0]
    x0, _ = models.initial_wrist(p.proj, p.uv[det[0]], arm=p.arm, q_WB=q[0],
                                 plane_height_m=0.07)
    c = p.proj.eye
    n = cv2.undistortPoints(p.uv[det].reshape(-1, 1, 2), p.proj.K, p.proj.cam.dist).reshape(-1, 2)
    d = np.hstack([n, np.ones((n.shape[0], 1))]) @ p.proj.R  # R_WCᵀ (x, y, 1): rays in W
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    out = np.full((p.uv.shape[0], 3), np.nan)
    if p.arm is None:
        out[det] = c + np.linalg.norm(x0 - c) * d
        return out
    oc = c - p.arm.sphere_centres(q)
    bq = np.einsum("ij,ij->i", d, oc)
    disc = bq * bq - (np.einsum("ij,ij->i", oc, oc) - p.arm.L1**2)
    root = np.sqrt(np.maximum(disc, 0.0))
    near, far = -bq - root, -bq + root
    prev = np.linalg.norm(x0 - c)
    for i in range(det.size):
        s = near[i] if abs(near[i] - prev) <= abs(far[i] - prev) else far[i]
        out[det[i]] = c + s * d[i]
        prev = s
    return out


def _jacobians(proj: models.Projection, pts: np.ndarray, h: float = 1e-5) -> np.ndarray:
    """∂π/∂p (n, 2, 3) px/m at each point (eq. 7), by central differences."""
    J = np.empty((pts.shape[0], 2, 3))
    for a in range(3):
        e = np.zeros(3)
        e[a] = h
        J[:, :, a] = (proj(pts + e) - proj(pts - e)) / (2 * h)
    return J


def _fill(x: np.ndarray) -> np.ndarray:
    """Rows of NaN filled from the nearest row that has values (for the Jacobian only)."""
    idx = np.flatnonzero(np.isfinite(x).all(axis=1))
    near = idx[np.clip(np.searchsorted(idx, np.arange(x.shape[0])), 0, idx.size - 1)]
    return x[near]


def predicted(p: SyncProblem, pre: _Prepared, delta: float) -> np.ndarray:
    """V(δ) (n, 2) px/s: the IMU's integrated velocity at t_k − δ (linear between samples;
    NaN outside the recording or across a gap longer than GAP_S) projected by J_k (eq. 7's
    Jacobian: u̇ = J v exactly), smoothed as the image side is."""
    t = p.t_frames - delta
    j = np.clip(np.searchsorted(p.t_imu, t, side="right"), 1, p.t_imu.size - 1)
    t0, t1 = p.t_imu[j - 1], p.t_imu[j]
    f = ((t - t0) / (t1 - t0))[:, None]
    v = pre.v_imu[j - 1] * (1 - f) + pre.v_imu[j] * f
    v[(t < p.t_imu[0]) | (t > p.t_imu[-1]) | (t1 - t0 > GAP_S)] = np.nan
    return _savgol(np.einsum("kij,kj->ki", pre.J, v), pre.window, 0, pre.dt)


def _fit(p: SyncProblem, pre: _Prepared, delta: float):
    """Least squares u̇_k = c V_k(δ) + J_k Σ_m θ_m B_m(t_k) (the integrated IMU's drift, a
    piecewise-linear 3-D function of time): residuals (2 per frame used) and the frames."""
    V = predicted(p, pre, delta)
    ok = np.isfinite(V).all(axis=1) & np.isfinite(pre.vel_img).all(axis=1)
    B = pre.drift[ok]
    B = B[:, B.any(axis=0)]
    J = pre.J[ok]
    cols = [V[ok].reshape(-1, 1)] + [(J[:, :, a, None] * B[:, None, :]).reshape(-1, B.shape[1])
                                     for a in range(3)]
    X = np.hstack(cols)
    y = pre.vel_img[ok].reshape(-1)
    theta = np.linalg.solve(X.T @ X + 1e-9 * np.eye(X.shape[1]), X.T @ y)
    return (y - X @ theta).reshape(-1, 2), X.shape[1], ok


def cost(delta: float, p: SyncProblem, pre: _Prepared, n_img: int, cache: dict) -> float:
    """Mean squared residual of the fit (_fit); inf with too little overlap. The drift's
    normal equations are reused while the frames used stay the same (``cache``): with
    G = DᵀD, the residual sum is yᵀy − yᵀD G⁻¹ Dᵀy − b² / s, where s = VᵀV − VᵀD G⁻¹ DᵀV
    and b = Vᵀy − VᵀD G⁻¹ Dᵀy (the Schur complement of the scale's column)."""
    V = predicted(p, pre, delta)
    ok = np.isfinite(V).all(axis=1) & np.isfinite(pre.vel_img).all(axis=1)
    n = int(ok.sum())
    if n < max(MIN_OVERLAP * n_img, MIN_FRAMES):
        return np.inf
    if cache.get("ok") is None or not np.array_equal(cache["ok"], ok):
        B = pre.drift[ok]
        B = B[:, B.any(axis=0)]
        J = pre.J[ok]
        D = np.hstack([(J[:, :, a, None] * B[:, None, :]).reshape(-1, B.shape[1])
                       for a in range(3)])
        y = pre.vel_img[ok].reshape(-1)
        G = np.linalg.cholesky(D.T @ D + 1e-9 * np.eye(D.shape[1]))
        Dy = np.linalg.solve(G, D.T @ y)
        cache.update(ok=ok, D=D, G=G, y=y, Dy=Dy, base=float(y @ y - Dy @ Dy))
    v = V[ok].reshape(-1)
    DV = np.linalg.solve(cache["G"], cache["D"].T @ v)
    sv = float(v @ v - DV @ DV)
    b = float(v @ cache["y"] - DV @ cache["Dy"])
    return (cache["base"] - (b * b / sv if sv > 0 else 0.0)) / n


def estimate_imu_offset(p: SyncProblem, *, centre_s: float = 0.0, search_s: float = 3.0
                        ) -> ImuOffset | None:
    """δ minimising the cost in centre_s ± search_s, and its SD; None when no δ there gives
    enough frames with both an image and an IMU velocity."""
    from scipy.optimize import minimize_scalar

    if np.isfinite(p.uv).all(axis=1).sum() < MIN_FRAMES:
        return None
    pre = _prepare(p, centre_s)
    n_img = int(np.isfinite(pre.vel_img).all(axis=1).sum())
    if n_img < MIN_FRAMES:
        return None
    step = pre.dt
    grid = centre_s + np.arange(-search_s, search_s + step / 2, step)
    cache: dict = {}
    costs = np.array([cost(d, p, pre, n_img, cache) for d in grid])
    if not np.isfinite(costs).any():
        return None
    d0 = float(grid[int(np.argmin(costs))])
    pre = _prepare(p, d0)  # the rays' depths with the IMU's orientation at the basin
    res = minimize_scalar(cost, bounds=(d0 - step, d0 + step), method="bounded",
                          args=(p, pre, n_img, {}), options={"xatol": 1e-5})
    delta = float(res.x) if res.fun <= costs.min() else d0
    return ImuOffset(delta, _sd(p, pre, delta), int(_fit(p, pre, delta)[2].sum()))


def _sd(p: SyncProblem, pre: _Prepared, delta: float) -> float:
    """From the curvature of the residual sum of squares S(δ) (profiled over c and the
    drift): SD² = 2 σ² / S'', σ² = S / (2n − parameters), inflated by (1 + ρ)/(1 − ρ) for
    the residuals' lag-1 autocorrelation ρ."""
    r, n_par, ok = _fit(p, pre, delta)
    h = 0.5 * pre.dt

    def rss(d):
        rr, _, o = _fit(p, pre, d)
        return float(np.sum(rr**2)) if np.array_equal(o, ok) else np.nan

    curv = (rss(delta + h) - 2 * float(np.sum(r**2)) + rss(delta - h)) / h**2
    sigma2 = float(np.sum(r**2)) / max(r.size - n_par, 1)
    rho = float(np.mean([np.corrcoef(r[:-1, k], r[1:, k])[0, 1] for k in range(2)]))
    rho = min(max(rho, 0.0), 0.99)
    if not np.isfinite(curv) or curv <= 0:
        return float("nan")
    return float(np.sqrt(2 * sigma2 / curv * (1 + rho) / (1 - rho)))
