"""The arm model from the session itself: `[arm] shoulder_m / upper_arm_m / forearm_m = "auto"`.

Tao & Hu's constraint (eq. 15) says the elbow E_k = p_k − L2·R_WB,k u (eq. 2) lies on the
sphere |E_k − S| = L1. One camera fixes the wrist p_k only up to its depth along the ray;
the IMU's accelerations fix how far it moves (eqs. 5, 6), and so its depth. This module
solves for everything at once, a batch least-squares over a stretch of the session:

    unknowns   p_k, v_k (wrist position, velocity) and δθ_k (the IMU's slowly wandering
               orientation error) per frame; β (the accelerometer bias, in B); and the free
               ones of S, L1, L2;
    residuals  (π(p_k) − z_k) / σ_px                 camera, eq. 7, frames with a detection
               Q_k^(−1/2) (x_k − F x_(k−1) − c_k)     IMU steps, eqs. 4-6, with the true
                     acceleration a − R_k β + δθ_k × (a − g) held over the step
               (δθ_k − δθ_(k−1)) / (σ_w √Δ), δθ_k / σ_θ, β / σ_β   the errors' walk and size
               (|E_k − S| − L1) / σ_c                 the arm constraint, eq. 15, with the
                     elbow E_k = p_k − L2 (f_k + δθ_k × f_k) (eq. 2, corrected axis)
               (L − L̄) / σ_L                          a weak anthropometric prior on L1, L2

solved by Levenberg-Marquardt with the analytic sparse Jacobian, from six starting shoulders.
The SDs of S, L1, L2 are the Gauss-Newton covariance at the solution, scaled by the residuals'
reduced χ² when that exceeds 1 (the model's noise levels are then too optimistic for the data).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.sparse.linalg import splu

from armtrack_cli.core import quaternion as quat
from armtrack_cli.fuse.models import GRAVITY_W, Projection, Steps, ray_sphere

PARAMS = ("shoulder_x", "shoulder_y", "shoulder_z", "upper_arm_m", "forearm_m")
# Adult segment lengths (shoulder-elbow, elbow-wrist centre): mean ± a wide SD, only to keep
# the solution from wandering where the data say little; the data dominate wherever they speak
# (a 1 cm-SD estimate is hardly moved by a 5 cm-SD prior).
PRIOR_L = (0.30, 0.26)
PRIOR_SD_M = 0.05
# W's z = 0 is the table top (SESSION_FORMAT.md), and a seated subject with a hand on the table
# has the shoulder joint ~0.2-0.35 m above it. An elbow path that is nearly flat leaves its
# sphere's centre on either side of it, a mirror pair the data hardly tell apart (UE-ADL's reach
# across: χ² 2.7 under the table, 3.8 at the shoulder); the mirror lies at or under the table.
# A solution lower than this is taken only when no start gives one above it. (A prior on the
# height would slide every estimate along the ridge the data leave flat instead:
# docs/validation-arm-auto.md.)
SHOULDER_MIN_Z_M = 0.10


@dataclass(frozen=True)
class AutoSettings:
    pixel_sigma: float = 2.0  # px, patch centre
    accel_sigma: float = 0.02  # m/s² per √Hz: white acceleration error density
    orientation_sd: float = 0.035  # rad, the IMU orientation error's size (MTw: ~1° RMS)
    orientation_walk: float = 0.01  # rad per √s, how fast it wanders
    bias_sd: float = 0.1  # m/s², the accelerometer bias (in B)'s size
    constraint_sigma_m: float = 0.01  # |E − S| − L1 (orientation error × L2, soft tissue)
    max_frames: int = 200  # the stretch used (the most varied one)
    stride: int = 3  # every stride-th video frame


@dataclass(frozen=True)
class ArmEstimate:
    shoulder: np.ndarray  # (3,) m in W
    upper_arm_m: float
    forearm_m: float
    sd: np.ndarray  # (5,) SDs of PARAMS (0 for a declared value)
    estimated: tuple[str, ...]  # which of shoulder_m, upper_arm_m, forearm_m came from the data
    t_span: tuple[float, float]  # session seconds used
    frames: int
    rms_px: float  # camera residual RMS at the solution
    rms_constraint_m: float
    wrist: np.ndarray  # (frames, 3) the batch's own wrist estimates, m in W
    sphere_fit: dict | None = None  # this batch's own estimate, when refined (arm_refine.py)
    refine_iterations: int = 0

    def as_dict(self) -> dict:
        return {"estimated": list(self.estimated),
                "shoulder_m": [round(float(v), 4) for v in self.shoulder],
                "shoulder_sd_m": [round(float(v), 4) for v in self.sd[:3]],
                "upper_arm_m": round(self.upper_arm_m, 4), "upper_arm_sd_m": round(float(self.sd[3]), 4),
                "forearm_m": round(self.forearm_m, 4), "forearm_sd_m": round(float(self.sd[4]), 4),
                "from_s": round(self.t_span[0], 3), "to_s": round(self.t_span[1], 3),
                "frames": self.frames, "rms_px": round(self.rms_px, 2),
                "rms_constraint_m": round(self.rms_constraint_m, 4),
                **({"refined_by": "arm smoother, arm as static states (fuse/arm_refine.py)",
                    "refine_iterations": self.refine_iterations,
                    "sphere_fit": {k: self.sphere_fit[k] for k in (
                        "shoulder_m", "shoulder_sd_m", "upper_arm_m", "upper_arm_sd_m",
                        "forearm_m", "forearm_sd_m")}} if self.sphere_fit else {})}


def varied_stretch(uv: np.ndarray, f_W: np.ndarray, n: int) -> slice:
    """The n consecutive frames (of those given) where the forearm turns and the patch moves
    most: the largest sum of forearm-direction spread and image-path spread."""
    if uv.shape[0] <= n:
        return slice(0, uv.shape[0])
    ok = np.isfinite(uv).all(1)
    best, at = -1.0, 0
    for k in range(0, uv.shape[0] - n + 1, max(1, n // 10)):
        w, o = slice(k, k + n), ok[k:k + n]
        if o.sum() < n // 2:
            continue
        score = np.trace(np.cov(f_W[w].T)) + np.trace(np.cov(uv[w][o].T)) / 1e5 * o.mean()
        if score > best:
            best, at = score, k
    return slice(at, at + n)


def _cross(a: np.ndarray) -> np.ndarray:
    """(..., 3, 3) [a]×, so that [a]× b = a × b."""
    z = np.zeros(a.shape[:-1])
    return np.stack([np.stack([z, -a[..., 2], a[..., 1]], -1),
                     np.stack([a[..., 2], z, -a[..., 0]], -1),
                     np.stack([-a[..., 1], a[..., 0], z], -1)], -2)


class _Problem:
    """Residuals of the batch and their Jacobian. x = [p, v, δθ per frame; β; free arm]."""

    def __init__(self, steps: Steps, uv, q_WB, forearm_B, proj: Projection, fixed: np.ndarray,
                 free: np.ndarray, s: AutoSettings):
        self.st, self.uv, self.proj, self.s = steps, uv, proj, s
        self.f = quat.rotate(q_WB, forearm_B)
        self.R = quat.to_matrix(q_WB)
        self.fixed, self.free = fixed, free
        self.n = uv.shape[0]
        self.det = np.flatnonzero(np.isfinite(uv).all(1))
        d = steps.dt[1:]
        q = s.accel_sigma**2
        self.La = np.sqrt(q * d**3 / 3)  # Cholesky of q [[Δ³/3, Δ²/2], [Δ²/2, Δ]] (eqs. 5-6)
        self.Lc = (q * d**2 / 2) / self.La
        self.Le = np.sqrt(np.maximum(q * d - self.Lc**2, 1e-18))
        self.ww = 1.0 / (s.orientation_walk * np.sqrt(d))
        self.sf = steps.dv[1:] / d[:, None] - GRAVITY_W  # mean specific force in W per step
        self.nx = 9 * self.n + 3 + int(free.sum())

    def unpack(self, x):
        n = self.n
        X = x[:9 * n].reshape(n, 9)
        theta = self.fixed.copy()
        theta[self.free] = x[9 * n + 3:]
        return X[:, :3], X[:, 3:6], X[:, 6:], x[9 * n:9 * n + 3], theta

    def forearm(self, dth):
        return self.f + np.cross(dth, self.f)  # R_WB corrected by δθ (small angle), eq. 2's axis

    def __call__(self, x):
        p, v, dth, beta, th = self.unpack(x)
        s, st = self.s, self.st
        cam = ((self.proj(p[self.det]) - self.uv[self.det]) / s.pixel_sigma).ravel()
        d = st.dt[1:, None]
        # the true acceleration: a_imu − R β + δθ × (a_imu − g), held over each step (eqs. 4-6)
        c = -np.einsum("nij,j->ni", self.R[1:], beta) + np.cross(dth[1:], self.sf)
        rp = p[1:] - (p[:-1] + v[:-1] * d + st.dp[1:] + 0.5 * c * d * d)
        rv = v[1:] - (v[:-1] + st.dv[1:] + c * d)
        e1 = rp / self.La[:, None]
        e2 = (rv - self.Lc[:, None] * e1) / self.Le[:, None]
        walk = (dth[1:] - dth[:-1]) * self.ww[:, None]
        E = p - th[4] * self.forearm(dth)  # eq. 2
        rc = (np.linalg.norm(E - th[:3], axis=1) - th[3]) / s.constraint_sigma_m  # eq. 15
        prior = (th[3:] - PRIOR_L) / PRIOR_SD_M
        return np.concatenate([cam, e1.ravel(), e2.ravel(), walk.ravel(),
                               (dth / s.orientation_sd).ravel(), beta / s.bias_sd, rc,
                               prior[self.free[3:]]])

    def jacobian(self, x) -> sparse.csr_matrix:
        """∂residuals/∂x, analytically, in the order __call__ stacks the residuals."""
        p, _, dth, _, th = self.unpack(x)
        n, nf, s, st = self.n, int(self.free.sum()), self.s, self.st
        R, C, V = [], [], []
        r0 = 0

        def put(rows, cols, vals):
            shape = np.broadcast(rows, cols, vals).shape
            for out, a in ((R, rows), (C, cols), (V, vals)):
                out.append(np.broadcast_to(a, shape).ravel())
        ax = np.arange(3)
        # camera: ∂π/∂p_k (2x3) per detected frame (eq. 7)
        Jc = np.array([self.proj.jacobian(p[k]) for k in self.det]) / s.pixel_sigma
        rows = r0 + 2 * np.arange(self.det.size)[:, None, None] + np.arange(2)[None, :, None]
        put(rows, 9 * self.det[:, None, None] + ax[None, None, :], Jc)
        r0 += 2 * self.det.size
        m, d = n - 1, st.dt[1:]
        k = np.arange(1, n)
        I3 = np.eye(3)
        dc_dth = -_cross(self.sf)  # ∂(δθ × s)/∂δθ = −[s]×
        dc_db = -self.R[1:]
        # ∂rp and ∂rv per block: (m, 3, 3) matrices for each column group
        blocks = {  # column offset -> (∂rp, ∂rv)
            "p": (I3 + 0 * dc_dth, 0 * dc_dth), "pm": (-I3 + 0 * dc_dth, 0 * dc_dth),
            "vm": (-d[:, None, None] * I3, -I3 + 0 * dc_dth), "v": (0 * dc_dth, I3 + 0 * dc_dth),
            "th": (-0.5 * (d * d)[:, None, None] * dc_dth, -d[:, None, None] * dc_dth),
            "b": (-0.5 * (d * d)[:, None, None] * dc_db, -d[:, None, None] * dc_db)}
        cols = {"p": 9 * k, "pm": 9 * (k - 1), "vm": 9 * (k - 1) + 3, "v": 9 * k + 3,
                "th": 9 * k + 6, "b": np.full(m, 9 * n)}
        e1_rows = r0 + 3 * (k - 1)[:, None, None] + ax[None, :, None]
        e2_rows = e1_rows + 3 * m
        for key, (drp, drv) in blocks.items():
            de1 = drp / self.La[:, None, None]
            de2 = (drv - self.Lc[:, None, None] * de1) / self.Le[:, None, None]
            cc = cols[key][:, None, None] + ax[None, None, :]
            put(e1_rows, cc, de1)
            put(e2_rows, cc, de2)
        r0 += 6 * m
        rows = r0 + 3 * (k - 1)[:, None] + ax  # the orientation error's walk
        put(rows, 9 * k[:, None] + 6 + ax, self.ww[:, None])
        put(rows, 9 * (k - 1)[:, None] + 6 + ax, -self.ww[:, None])
        r0 += 3 * m
        rows = r0 + 3 * np.arange(n)[:, None] + ax  # … and its size
        put(rows, 9 * np.arange(n)[:, None] + 6 + ax, np.full((n, 3), 1.0 / s.orientation_sd))
        r0 += 3 * n
        put(r0 + ax, 9 * n + ax, np.full(3, 1.0 / s.bias_sd))  # the bias's size
        r0 += 3
        # constraint (eq. 15, eq. 2): ∂/∂p = u, ∂/∂δθ = L2 uᵀ[f]×, ∂/∂S = −u, ∂/∂L1 = −1,
        # ∂/∂L2 = −u·f' (all over σ_c)
        fc = self.forearm(dth)
        D = p - th[4] * fc - th[:3]
        u = D / np.linalg.norm(D, axis=1, keepdims=True) / s.constraint_sigma_m
        rows = r0 + np.arange(n)
        put(rows[:, None], 9 * np.arange(n)[:, None] + ax, u)
        put(rows[:, None], 9 * np.arange(n)[:, None] + 6 + ax,
            th[4] * np.einsum("ni,nij->nj", u, _cross(self.f)))
        dth_arm = np.c_[-u, np.full(n, -1.0 / s.constraint_sigma_m), -np.sum(u * fc, 1)]
        put(rows[:, None], 9 * n + 3 + np.arange(nf)[None, :], dth_arm[:, self.free])
        r0 += n
        for i, j in enumerate(np.flatnonzero(self.free[3:])):
            put(np.array([r0 + i]), np.array([9 * n + 3 + int(self.free[:3 + j].sum())]),
                np.array([1.0 / PRIOR_SD_M]))
        r0 += int(self.free[3:].sum())
        return sparse.csr_matrix((np.concatenate(V), (np.concatenate(R), np.concatenate(C))),
                                 shape=(r0, self.nx))


def shoulder_guesses(proj: Projection, uv0: np.ndarray) -> np.ndarray:
    """(6, 3) starting shoulders: the subject sits across the table from the camera, so the
    shoulder is 20-35 cm beyond the first wrist (on the table) as seen from the camera,
    within 15 cm to either side, 30 cm above the table."""
    d = proj.ray(uv0)
    p0 = proj.eye + (0.05 - proj.eye[2]) / d[2] * d
    away = np.array([d[0], d[1], 0.0]) / np.hypot(d[0], d[1])
    side = np.array([-away[1], away[0], 0.0])
    return np.array([[p0[0], p0[1], 0.30] + a * away + b * side
                     for a in (0.2, 0.35) for b in (-0.15, 0.0, 0.15)])


def _initial(steps: Steps, uv, f_W, proj: Projection, theta: np.ndarray, free,
             continuous: bool = False) -> np.ndarray:
    """Start from an arm ``theta``: each wrist where its ray meets the sphere about
    S + L2·f_k (eq. 15), the meeting nearest the table (the ray's nearest point if it misses);
    ``continuous``: from the first frame on, the meeting nearest the previous frame's (a hand
    lifted off the table, as in the calibration movement, can have both well above it)."""
    n = uv.shape[0]
    idx = np.flatnonzero(np.isfinite(uv).all(1))
    uv_f = np.array([np.interp(np.arange(n), idx, uv[idx, j]) for j in range(2)]).T
    rays = proj.rays(uv_f)
    near, far, miss = ray_sphere(proj.eye, rays, theta[:3] + theta[4] * f_W, theta[3])
    lo = proj.eye[2] + near * rays[:, 2] < proj.eye[2] + far * rays[:, 2]
    depth = np.where(miss > 0, near, np.where(lo, near, far))  # missed: near = far
    for k in range(1, n if continuous else 1):
        depth[k] = near[k] if abs(near[k] - depth[k - 1]) <= abs(far[k] - depth[k - 1]) else far[k]
    p = proj.eye + depth[:, None] * rays
    v = np.gradient(p, np.cumsum(steps.dt), axis=0)
    return np.r_[np.hstack([p, v, np.zeros((n, 3))]).ravel(), np.zeros(3), theta[free]]


def levenberg_marquardt(fun, jac, x, *, iters: int = 200, tol: float = 1e-10):
    """Minimise ½|fun(x)|² by Levenberg-Marquardt (Marquardt's diagonal scaling) with a sparse
    LU solve of (JᵀJ + λ diag JᵀJ) δ = −Jᵀr; returns x, r, J at the solution."""
    r, J = fun(x), jac(x)
    cost, lam = 0.5 * float(r @ r), 1e-3
    for _ in range(iters):
        H = (J.T @ J).tocsc()
        g = J.T @ r
        d = H.diagonal() + 1e-12
        try:
            step = -splu((H + sparse.diags(lam * d)).tocsc()).solve(g)
        except RuntimeError:  # singular: more damping
            lam *= 10
            continue
        xn = x + step
        rn = fun(xn)
        cn = 0.5 * float(rn @ rn)
        if cn < cost:
            done = cost - cn < tol * max(cost, 1.0)
            x, r, cost, lam = xn, rn, cn, max(lam / 3, 1e-9)
            J = jac(x)
            if done:
                break
        else:
            lam *= 5
            if lam > 1e8:
                break
    return x, r, J


def estimate_arm(steps: Steps, uv: np.ndarray, q_WB: np.ndarray, t: np.ndarray,
                 proj: Projection, forearm_B: np.ndarray, declared: dict,
                 s: AutoSettings | None = None) -> ArmEstimate:
    """S, L1, L2 (those ``declared`` gives as None) from frames t (session s), their steps,
    detections uv (NaN: none) and IMU orientations."""
    s = s or AutoSettings()
    f_W = quat.rotate(q_WB, forearm_B)
    fixed = np.r_[declared["shoulder_m"] if declared["shoulder_m"] is not None else np.zeros(3),
                  declared["upper_arm_m"] or 0.0, declared["forearm_m"] or 0.0]
    free = np.r_[[declared["shoulder_m"] is None] * 3, declared["upper_arm_m"] is None,
                 declared["forearm_m"] is None]
    prob = _Problem(steps, uv, q_WB, forearm_B, proj, fixed, free, s)
    best = None
    first = uv[np.flatnonzero(np.isfinite(uv).all(1))[0]]
    starts = shoulder_guesses(proj, first) if free[0] else fixed[None, :3]
    tried = []

    def plausible(x) -> bool:
        return not free[2] or prob.unpack(x)[4][2] >= SHOULDER_MIN_Z_M
    for continuous in (False, True):
        for S0 in starts:
            theta = np.where(free, np.r_[S0, PRIOR_L], fixed)
            x0 = _initial(steps, uv, f_W, proj, theta, free, continuous)
            if continuous and any(np.array_equal(x0, x) for x in tried):
                continue  # the same start as a table one (the wrist on the table throughout)
            tried.append(x0)
            x, r, J = levenberg_marquardt(prob, prob.jacobian, x0)
            # a shoulder above the table beats one under it; else a continuous start's minimum
            # replaces one only when 1 more likely (2 in χ²)
            if best is None or plausible(x) > plausible(best[0]) or (
                    plausible(x) == plausible(best[0])
                    and r @ r < best[1] @ best[1] - (2.0 if continuous else 0.0)):
                best = (x, r, J)
    x, r, J = best
    p, _, dth, _, th = prob.unpack(x)
    dof = max(r.size - x.size, 1)
    scale = max(1.0, float(r @ r) / dof)
    sd = np.zeros(5)
    nf = int(free.sum())
    if nf:
        H = (J.T @ J).tocsc() + sparse.identity(J.shape[1], format="csc") * 1e-12
        lu = splu(H)
        rhs = np.zeros((J.shape[1], nf))
        rhs[-nf:, :] = np.eye(nf)
        cov = lu.solve(rhs)[-nf:, :] * scale
        sd[free] = np.sqrt(np.maximum(np.diag(cov), 0.0))
    E = p - th[4] * prob.forearm(dth)
    names = [k for k, on in (("shoulder_m", free[0]), ("upper_arm_m", free[3]),
                             ("forearm_m", free[4])) if on]
    cam = prob.proj(p[prob.det]) - uv[prob.det]
    return ArmEstimate(th[:3].copy(), float(th[3]), float(th[4]), sd, tuple(names),
                       (float(t[0]), float(t[-1])), int(uv.shape[0]),
                       float(np.sqrt(np.mean(np.sum(cam**2, 1)))),
                       float(np.sqrt(np.mean((np.linalg.norm(E - th[:3], axis=1) - th[3])**2))), p)


def coarsen(steps: Steps, stride: int, start: int, stop: int) -> Steps:
    """The steps between every stride-th frame of [start, stop): consecutive held-acceleration
    steps compose exactly (p' = p + vΔ₁ + dp₁ + (v + dv₁)Δ₂ + dp₂ = p + v(Δ₁+Δ₂) + dp, eqs. 5-6)."""
    keep = np.arange(start, stop, stride)
    dt, dp, dv = [0.0], [np.zeros(3)], [np.zeros(3)]
    for a, b in zip(keep[:-1], keep[1:]):
        T, P, V = 0.0, np.zeros(3), np.zeros(3)
        for k in range(a + 1, b + 1):
            P = P + V * steps.dt[k] + steps.dp[k]
            V = V + steps.dv[k]
            T += steps.dt[k]
        dt.append(T)
        dp.append(P)
        dv.append(V)
    return Steps(np.array(dt), np.array(dp), np.array(dv), steps.q)
