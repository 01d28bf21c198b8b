"""Guards of every camera update (issue 14): a detection that the filter cannot explain is not
used, and a particle filter that has lost the arm finds it again, from session data only.

**Gating.** A detection z with innovation ν and innovation covariance S is used only if
νᵀ S⁻¹ ν ≤ ``gate_chi2`` (a χ²(2) quantile: 13.8 keeps 99.9 % of the detections of a consistent
filter; Bar-Shalom, Li & Kirubarajan 2001, 5.4). EKF: ν = z − h(x⁻), S = H P⁻ Hᵀ + R; UKF:
ν = z − ẑ, S = P_zz; particle filters: ẑ = Σ wᵢ π(pᵢ), S = Σ wᵢ (π(pᵢ) − ẑ)(π(pᵢ) − ẑ)ᵀ + R, the
predicted cloud's weighted spread in the image plus the pixel noise. A gated detection is
treated exactly as a missing one.

**Re-acquiring.** Gating must not lock a filter out: a filter that drifted (a long occlusion)
gates every detection that follows. After ``reacquire_frames`` frames in a row without a used
detection (gated, or none at all: a gated detection counts exactly as a missing one, so a
card that hid the patch for that long counts too) the next detection is used whatever its
innovation: the Gaussian filters first add
``reacquire_sigma_m`` (position) and ``init_vel_sigma_m_s`` (velocity) to P's diagonal, so the
update moves them onto the detection; the particle filters add the same spread to every
particle (roughening) and pf-constraint also re-seeds (below). The next reacquire_frames
detections are used ungated while the filter settles. A wrong detection that is isolated or
short (≤ reacquire_frames frames in a row) therefore never changes the estimate while the
filter is following the patch; right after a stretch of reacquire_frames frames with nothing
used (a card, the patch lost), the first detection is trusted over the filter's drifted
prediction (measured in docs/validation-forward-filter.md: waiting for reacquire_frames more
gated detections there kept the forward filter 40 cm off for a third of a second).

**Re-seeding (pf-constraint).** The detection's camera ray meets the sphere on which the
wrist must lie (|p − (S + L2 R u)| = L1, Tao & Hu eq. 15) at up to two points. When the colour
layer collapses (ESS after the colour weights < ``reseed_ess`` · N: the cloud is off the ray),
the filter re-acquires, or a detection comes after reacquire_frames frames without one (a card:
the cloud drifted on the IMU alone), a share ``reseed_share`` of the particles is moved onto those two
points (± ``reseed_sigma_m``, velocities kept) before the colour weights are computed again,
and the paper's steps go on. The two points share the seeds in proportion to the predicted
cloud's density there (its Gaussian fit, SD widened by ``reseed_prior_m``), so the prior
picks the branch it is near, and the IMU-driven prediction of the following frames decides
between branches it cannot tell apart.
"""

from __future__ import annotations

import numpy as np

from armtrack_cli.core import quaternion as quat
from armtrack_cli.fuse import models

NONE, USED, GATED, REACQUIRED, RESEEDED = 0, 1, 2, 3, 4  # per-frame detection codes
CODE_NAMES = {USED: "used", GATED: "gated", REACQUIRED: "reacquired", RESEEDED: "reseeded"}


def gate(d2: float, gate_chi2: float, run: int, reacquire_frames: int) -> tuple[int, int]:
    """(code, run after this frame) for a detection of Mahalanobis² d2, after ``run`` gated
    detections in a row: USED, GATED, or REACQUIRED once the run is long enough; after that
    the next reacquire_frames detections are used ungated (run < 0 counts them down)."""
    if run < 0:  # the grace after a re-acquisition: the filter settles on the detections
        return USED, run + 1
    if gate_chi2 <= 0 or d2 <= gate_chi2:
        return USED, 0
    if run >= reacquire_frames:
        return REACQUIRED, -reacquire_frames
    return GATED, run + 1


def blind(run: int) -> int:
    """The gate's ``run`` after a frame without a detection: counted as a gated one (except in
    the grace after a re-acquisition, which only detections count down)."""
    return run + 1 if run >= 0 else run


def pixel_mahalanobis2(px: np.ndarray, w: np.ndarray, z: np.ndarray, r2: float) -> float:
    """νᵀ S⁻¹ ν of detection z (2,) against particles' pixels px (N, 2) with weights w (N,):
    ẑ = Σ wᵢ pxᵢ, S = Σ wᵢ (pxᵢ − ẑ)(pxᵢ − ẑ)ᵀ + r2 I."""
    zhat = w @ px
    d = px - zhat
    S = (w[:, None] * d).T @ d + r2 * np.eye(2)
    nu = z - zhat
    return float(nu @ np.linalg.solve(S, nu))


def detection_rays(proj, z: np.ndarray) -> np.ndarray:
    """(n, 3) the unit rays (models.Projection.rays) of detections z (n, 2) px, NaN where there
    is none: what ray_sphere_points, and the compiled pf-constraint where it re-seeds, start
    from."""
    out = np.full((z.shape[0], 3), np.nan)
    seen = np.isfinite(z).all(axis=1)
    if seen.any():
        out[seen] = proj.rays(z[seen])
    return out


def ray_sphere_points(proj, arm, z: np.ndarray, q_WB, centres: np.ndarray | None = None
                      ) -> np.ndarray:
    """(n, 2, 3): per frame the two points where the camera ray of detection z (n, 2) px meets
    the wrist sphere |p − (S + L2 R_WB u)| = L1 (eq. 15), nearer the camera first; where the ray
    misses it, its point nearest to the sphere, twice; NaN where there is no detection.
    ``centres``: arm.sphere_centres(q_WB), where the caller has them already; q_WB (n, 4), or
    a function that makes it, called once the rays are made (their temporaries and it not
    held at once: issue 15)."""
    n = z.shape[0]
    seen = np.isfinite(z).all(axis=1)
    if not seen.any():
        return np.full((n, 2, 3), np.nan)
    rays = detection_rays(proj, z)  # (n, 3)
    q_WB = q_WB() if callable(q_WB) else q_WB
    out = np.full((n, 2, 3), np.nan)
    rows = np.flatnonzero(seen)
    for a, b in quat.row_spans(rows.size):  # the temporaries a chunk's (issue 15)
        r = rows[a:b]
        c = arm.sphere_centres(q_WB[r]) if centres is None else centres[r]
        d = rays[r]
        near, far, _ = models.ray_sphere(proj.eye, d, c, arm.L1)
        s = np.maximum(np.stack([near, far], 1), 0.0)  # never behind the camera
        out[r] = proj.eye + s[:, :, None] * d[:, None, :]
    return out


def branch_split(n_seed: int, points: np.ndarray, mean: np.ndarray, cov: np.ndarray,
                 prior_m: float) -> int:
    """How many of n_seed seeds go to points[0] (the rest to points[1]): n_seed times the
    probability of points[0] under N(mean, cov + prior_m² I) against points[1]."""
    C = cov + prior_m**2 * np.eye(3)
    q = [float((p - mean) @ np.linalg.solve(C, p - mean)) for p in points]
    p0 = 1.0 / (1.0 + np.exp(min(0.5 * (q[0] - q[1]), 700.0)))
    return int(np.floor(n_seed * p0 + 0.5))


def roughen(x: np.ndarray, sigma_m: float, sigma_m_s: float, eps: np.ndarray) -> None:
    """In place: every particle's position ± sigma_m, velocity ± sigma_m_s (eps (N, 6))."""
    x[:, :3] += sigma_m * eps[:, :3]
    x[:, 3:] += sigma_m_s * eps[:, 3:]


def reseed(x: np.ndarray, points: np.ndarray, n0: int, sigma: float, eps: np.ndarray) -> None:
    """In place: particles 0..n0−1 onto points[0], n0..len(eps)−1 onto points[1], each
    ± sigma·eps (eps (n_seed, 3) standard normals); velocities kept."""
    n_seed = eps.shape[0]
    x[:n0, :3] = points[0] + sigma * eps[:n0]
    x[n0:n_seed, :3] = points[1] + sigma * eps[n0:]
