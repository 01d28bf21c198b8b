"""The process and measurement models, written once and shared by every method.

State (Tao & Hu eq. 3): x = (p, v), the wrist joint's position and velocity in W (m, m/s).
The elbow is not in the state: it follows from the IMU orientation and the forearm (eq. 2).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from armtrack_cli.core import quaternion as quat
from armtrack_cli.core.streams import CameraModel

GRAVITY_W = np.array([0.0, 0.0, -9.81])


def accel_world(q_WB: np.ndarray, f_B: np.ndarray) -> np.ndarray:
    """a_W = R_WB f_B + g_W: specific force rotated into W, gravity removed (eq. 4); q_WB
    (M, 4), f_B (M, 3) (quat.rotate bounds its temporaries however long the recording)."""
    a_W = quat.rotate(q_WB, f_B)
    a_W += GRAVITY_W
    return a_W


@dataclass(frozen=True)
class Steps:
    """The exact linear steps between consecutive camera frames k-1 -> k (eqs. 5, 6).

    With the acceleration held between IMU samples, p_k = p + v Δ + dp, v_k = v + dv, and
    continuous white acceleration noise of density q adds Q(Δ) = q [[Δ³/3, Δ²/2], [Δ²/2, Δ]].
    Folding every IMU sample between two frames into one step is exact for this linear model.
    """

    dt: np.ndarray  # (n_frames,) Δ, s (dt[0] = 0)
    dp: np.ndarray  # (n_frames, 3) m
    dv: np.ndarray  # (n_frames, 3) m/s
    q: float  # acceleration noise density, m²/s³

    def F(self, k: int) -> np.ndarray:
        F = np.eye(6)
        F[:3, 3:] = self.dt[k] * np.eye(3)
        return F

    def b(self, k: int) -> np.ndarray:
        return np.r_[self.dp[k], self.dv[k]]

    def Q(self, k: int) -> np.ndarray:
        d = self.dt[k]
        blk = self.q * np.array([[d**3 / 3, d**2 / 2], [d**2 / 2, d]])
        return np.kron(blk, np.eye(3))

    def stacked(self, lo: int = 0, hi: int | None = None) -> tuple[np.ndarray, np.ndarray,
                                                                   np.ndarray]:
        """F (n, 6, 6), b (n, 6), Q (n, 6, 6): F(k), b(k), Q(k) for frames k in [lo, hi) (all by
        default) at once (the same arithmetic, so the same numbers)."""
        d = self.dt[lo:hi]
        n_frames = d.size
        F = np.tile(np.eye(6), (n_frames, 1, 1))
        idx = np.arange(3)
        F[:, idx, 3 + idx] = d[:, None]
        b = np.hstack([self.dp[lo:hi], self.dv[lo:hi]])
        # Δ³ and Δ² by C's pow per element, as the scalar Δ**3 of Q(k) (numpy's array power
        # rounds differently)
        d3 = np.fromiter((v**3 for v in d.tolist()), float, n_frames)
        d2 = np.fromiter((v**2 for v in d.tolist()), float, n_frames)
        Q = np.zeros((n_frames, 6, 6))
        for (r, c), v in (((0, 0), self.q * (d3 / 3)), ((0, 3), self.q * (d2 / 2)),
                          ((3, 0), self.q * (d2 / 2)), ((3, 3), self.q * d)):
            Q[:, r + idx, c + idx] = v[:, None]
        return F, b, Q

    def noise_factors(self) -> np.ndarray:
        """(n_frames, 3) rows (a, c, e) with Q = L Lᵀ ⊗ I₃, L = [[a, 0], [c, e]]: the closed-form
        Cholesky factor of q [[Δ³/3, Δ²/2], [Δ²/2, Δ]], so position noise is a·ε₁ and velocity
        noise c·ε₁ + e·ε₂ (ε independent standard normals). For all frames at once."""
        d = self.dt
        a = np.sqrt(self.q * d**3 / 3)
        c = np.divide(self.q * d**2 / 2, a, out=np.zeros_like(d), where=a > 0)
        e = np.sqrt(np.maximum(self.q * d - c * c, 0.0))
        return np.stack([a, c, e], -1)

    def apply(self, k: int, X: np.ndarray) -> np.ndarray:
        """The deterministic part on states (..., 6)."""
        out = X.copy()
        out[..., :3] += X[..., 3:] * self.dt[k] + self.dp[k]
        out[..., 3:] += self.dv[k]
        return out


def composite_steps(t_imu: np.ndarray, a_W: np.ndarray, t_frames: np.ndarray, *,
                    accel_noise: float, imu_period: float) -> Steps:
    """Integrate the held accelerations a_W (M, 3) at t_imu over each frame interval.

    accel_noise (m/s², per IMU sample) becomes the density q = σ² · T_s.
    """
    brk = np.union1d(t_imu, t_frames)
    brk = brk[(brk >= t_frames[0]) & (brk <= t_frames[-1])]
    s0, s1 = brk[:-1], brk[1:]
    j = np.searchsorted(t_imu, s0, side="right") - 1  # the IMU sample held over [s0, s1)
    a = np.where((j >= 0)[:, None], a_W[np.clip(j, 0, len(t_imu) - 1)], 0.0)
    k = np.searchsorted(t_frames, s0, side="right")  # the frame interval ending at t_frames[k]
    T1 = t_frames[k]
    tau = s1 - s0
    n_frames = t_frames.size
    dv = np.zeros((n_frames, 3))
    dp = np.zeros((n_frames, 3))
    np.add.at(dv, k, a * tau[:, None])
    np.add.at(dp, k, a * (((T1 - s0) ** 2 - (T1 - s1) ** 2) / 2)[:, None])
    dt = np.r_[0.0, np.diff(t_frames)]
    return Steps(dt, dp, dv, accel_noise**2 * imu_period)


class Projection:
    """Pinhole projection with OpenCV's distortion k1 k2 p1 p2 k3 (Tao & Hu eq. 7 with the lens
    the camera really has), vectorised over points, with its analytic Jacobian. ``pose_cov``:
    the (6, 6) covariance of its pose's correction (fuse/camera_pose.py), where known."""

    def __init__(self, cam: CameraModel, pose_cov: np.ndarray | None = None):
        self.K, self.R, self.T = cam.K, cam.R_WC, cam.T_WC
        self.pose_cov = pose_cov
        d = np.zeros(5)
        d[: min(5, cam.dist.size)] = cam.dist[:5]
        self.k1, self.k2, self.p1, self.p2, self.k3 = d
        self.eye = -self.R.T @ self.T
        self.cam = cam
        self._f = np.array([cam.K[0, 0], cam.K[1, 1]])
        self._c = np.array([cam.K[0, 2], cam.K[1, 2]])

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Pixels (..., 2) of points (..., 3) in W (OpenCV's model, on stacked (x, y))."""
        X = points @ self.R.T + self.T
        n = X[..., :2] / X[..., 2:]  # normalised (x, y)
        sq = n * n
        r2 = sq[..., 0] + sq[..., 1]
        rad = 1 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3))
        d = n * rad[..., None]
        if self.p1 or self.p2:  # tangential terms (x: 2 p1 xy + p2 (r² + 2x²); y: mirrored)
            xy2 = 2 * n[..., 0] * n[..., 1]
            d[..., 0] += self.p1 * xy2 + self.p2 * (r2 + 2 * sq[..., 0])
            d[..., 1] += self.p2 * xy2 + self.p1 * (r2 + 2 * sq[..., 1])
        return d * self._f + self._c

    def jacobian(self, p: np.ndarray) -> np.ndarray:
        """∂(u, v)/∂p (2, 3) at one point p in W."""
        X = self.R @ p + self.T
        x, y, Z = X[0] / X[2], X[1] / X[2], X[2]
        r2 = x * x + y * y
        rad = 1 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3))
        D = self.k1 + 2 * self.k2 * r2 + 3 * self.k3 * r2 * r2  # ∂rad/∂r²
        Jd = np.array([
            [rad + 2 * x * x * D + 2 * self.p1 * y + 6 * self.p2 * x,
             2 * x * y * D + 2 * self.p1 * x + 2 * self.p2 * y],
            [2 * x * y * D + 2 * self.p1 * x + 2 * self.p2 * y,
             rad + 2 * y * y * D + 6 * self.p1 * y + 2 * self.p2 * x]])
        Jn = np.array([[1 / Z, 0, -X[0] / Z**2], [0, 1 / Z, -X[1] / Z**2]])
        return np.diag([self.K[0, 0], self.K[1, 1]]) @ Jd @ Jn @ self.R

    def ray(self, uv: np.ndarray) -> np.ndarray:
        """Unit direction in W of the ray through an observed pixel."""
        return self.rays(np.asarray(uv, float).reshape(1, 2))[0]

    def rays(self, uv: np.ndarray) -> np.ndarray:
        """(n, 3) unit directions in W of the rays through pixels uv (n, 2)."""
        n = cv2.undistortPoints(np.asarray(uv, float).reshape(-1, 1, 2), self.K,
                                self.cam.dist).reshape(-1, 2)
        d = np.hstack([n, np.ones((len(n), 1))]) @ self.R  # R_WCᵀ (x, y, 1)
        return d / np.linalg.norm(d, axis=1, keepdims=True)


def ray_sphere(origin: np.ndarray, d: np.ndarray, centre: np.ndarray,
               radius: float | np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where rays origin + s·d (d (..., 3) unit) meet spheres |p − centre| = radius (eq. 15's
    sphere about S + L2·R u, radius L1), broadcast over the leading axes.

    Returns (near, far, miss), each (...,): the two depths s = −b ∓ √(b² − |o − c|² + r²),
    b = d·(o − c), near ≤ far (negative = behind the origin); where the ray misses the sphere
    (discriminant < 0) both are −b, the ray's point nearest to it, and miss is how far (m) the
    ray passes outside the sphere, √(|o − c|² − b²) − r (0 where it meets it)."""
    oc = np.asarray(origin, float) - centre
    b = np.sum(d * oc, axis=-1)
    oc2 = np.sum(oc * oc, axis=-1)
    disc = b * b - (oc2 - np.square(radius))
    root = np.sqrt(np.maximum(disc, 0.0))
    miss = np.maximum(np.sqrt(np.maximum(oc2 - b * b, 0.0)) - radius, 0.0)
    return -b - root, -b + root, np.where(disc < 0, miss, 0.0)


@dataclass(frozen=True, kw_only=True)
class Arm:
    """Tao & Hu's arm: fixed shoulder S, upper arm L1, forearm L2 along the IMU's forearm axis."""

    shoulder: np.ndarray
    L1: float
    L2: float
    forearm_B: np.ndarray  # unit vector in B from the elbow towards the hand

    def elbow(self, p: np.ndarray, q_WB: np.ndarray) -> np.ndarray:
        """Eq. 2 with the contract's axis: the elbow is L2 behind the wrist along the forearm."""
        return p - self.L2 * quat.rotate(q_WB, self.forearm_B)

    def sphere_centres(self, q_WB: np.ndarray) -> np.ndarray:
        """(n_frames, 3) S + L2 R_WB u per frame: |p − centre| = |E − S|, so the residual of eq. 15 is
        |p − centre| − L1 (computed once for all frames)."""
        return self.shoulder + self.L2 * quat.rotate(q_WB, self.forearm_B)


def initial_wrist(proj: Projection, uv: np.ndarray, *, arm: Arm | None, q_WB: np.ndarray,
                  plane_height_m: float) -> tuple[np.ndarray, str]:
    """The wrist on the first detection's ray, from session data only.

    With the arm model the ray meets the sphere |p − (S + L2·R u)| = L1 twice; the start is at
    rest on the table, so the intersection above the table and nearest to it is taken. Without
    an arm model the ray meets the plane z = plane_height_m.
    """
    c, d = proj.eye, proj.ray(uv)
    if arm is None:
        s = (plane_height_m - c[2]) / d[2]
        return c + s * d, f"ray and the plane z = {plane_height_m:.3f} m"
    near, far, miss = ray_sphere(c, d, arm.sphere_centres(q_WB[None])[0], arm.L1)
    if miss > 0:  # the ray misses the sphere: the ray's point nearest to it
        return c + near * d, "nearest point of the ray to the arm sphere (no intersection)"
    cands = [c + s * d for s in (near, far) if s > 0]
    above = [p for p in cands if p[2] >= -0.01] or cands
    return min(above, key=lambda p: p[2]), "ray and the arm sphere, the point nearest the table"


def ray_misses_arm(proj: Projection, uv: np.ndarray, arm: Arm, q_WB: np.ndarray) -> float:
    """How far (m) the camera ray of pixel uv passes outside the sphere of radius L1 about
    S + L2·R u on which the wrist must lie (Tao & Hu eq. 15); 0 when it meets it."""
    return float(ray_sphere(proj.eye, proj.ray(uv), arm.sphere_centres(q_WB[None])[0],
                            arm.L1)[2])
