"""The IMU clock-offset check's image side (fuse/imu_sync.py): where each detection's camera
ray meets the arm's sphere at a trial offset δ (Tao & Hu eq. 15), and the projection's
Jacobian there (eq. 7), CHUNK frames at a time: the temporaries (orientations, rays, the two
intersections, the projections either side) do not grow with the session (issue 15)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from armtrack_cli.core import quaternion as quat
from armtrack_cli.fuse import models
from armtrack_cli.fuse.drift_ls import CHUNK
from armtrack_cli.fuse.sync_signal import stretches

if TYPE_CHECKING:
    from armtrack_cli.fuse.imu_sync import SyncProblem

GRAZE_M = 0.15  # m: intersections closer than this along the ray are a grazing ray's (with 0.5 px
#                of noise a grazing ray's two part by 10 cm from one frame to the next)


def _orientations(p: SyncProblem, delta: float, t: np.ndarray) -> np.ndarray:
    """q_WB (k, 4) at session times t (sorted), the IMU's clock shifted by δ: quat.interpolate
    over the samples about t only (up to the sign, which no rotation sees: the same rotation
    to the bit), the first sample's where t is outside the recording."""
    lo, hi = np.searchsorted(p.t_imu, [t[0] - delta, t[-1] - delta])
    s = slice(max(lo - 2, 0), hi + 2)
    q = quat.interpolate(p.t_imu[s] + delta, p.q_WB[s], t)
    q[~np.isfinite(q).all(axis=1)] = p.q_WB[0]
    return q


def wrist_on_rays(p: SyncProblem, delta: float) -> np.ndarray:
    """(n, 3) m: each detection's ray where it meets the arm's sphere |p − (S + L2 R u)| = L1
    (eq. 15; the IMU's orientation at t − δ), the intersection nearer the previous frame's
    (the first: models.initial_wrist's), where the two are within GRAZE_M of each other the
    one nearer the table as models.initial_wrist takes it (a grazing ray's choice by nearness
    bounced onto the other sheet for seconds from a sub-frame change of δ), the ray's nearest
    point where it misses; without an arm, at the range of the first detection's start. NaN
    without a detection. A stretch of the problem (SyncProblem.frame_cuts: a check's window)
    starts its own chain, as the session's first detection does."""
    out = np.full((p.uv.shape[0], 3), np.nan)
    for start, end in stretches(p.frame_cuts, p.uv.shape[0]):  # each its own chain
        _chain(p, delta, start + np.flatnonzero(np.isfinite(p.uv[start:end]).all(axis=1)),
               out)
    return out


def _chain(p: SyncProblem, delta: float, det: np.ndarray, out: np.ndarray) -> None:
    """wrist_on_rays for the detections ``det`` (frames in order, one stretch), into ``out``."""
    c = p.proj.eye
    prev = None
    for a in range(0, det.size, CHUNK):
        k = det[a:a + CHUNK]
        q = _orientations(p, delta, p.t_frames[k])
        if prev is None:
            x0, _ = models.initial_wrist(p.proj, p.uv[k[0]], arm=p.arm, q_WB=q[0],
                                         plane_height_m=0.07)
            prev = np.linalg.norm(x0 - c)
        d = p.proj.rays(p.uv[k])
        if p.arm is None:
            out[k] = c + prev * d
            continue
        near, far, _ = models.ray_sphere(c, d, p.arm.sphere_centres(q), p.arm.L1)
        lower = np.where(near * d[:, 2] <= far * d[:, 2], near, far)  # nearer the table
        s = np.empty(k.size)
        for i, (a, b, low) in enumerate(zip(near.tolist(), far.tolist(), lower.tolist())):
            if b - a < GRAZE_M:  # a grazing ray: which one is ambiguous; the table's
                prev = low
            else:
                prev = a if abs(a - prev) <= abs(b - prev) else b
            s[i] = prev  # (Python floats: the chain's choice is sequential)
        out[k] = c + s[:, None] * d


def _jacobians(proj: models.Projection, pts: np.ndarray, h: float = 1e-5) -> np.ndarray:
    """∂π/∂p (n, 2, 3) px/m at each point (eq. 7), by central differences."""
    J = np.empty((pts.shape[0], 2, 3))
    for a in range(3):
        e = np.zeros(3)
        e[a] = h
        J[:, :, a] = (proj(pts + e) - proj(pts - e)) / (2 * h)
    return J


def ray_jacobians(p: SyncProblem, delta: float) -> np.ndarray:
    """(n, 2, 3) px/m: eq. 7's Jacobian at each frame's wrist_on_rays point, a frame without a
    detection taking the nearest one's (for the Jacobian only)."""
    x = wrist_on_rays(p, delta)
    idx = np.flatnonzero(np.isfinite(x).all(axis=1))
    J = np.empty((x.shape[0], 2, 3))
    for a, b in quat.row_spans(x.shape[0], CHUNK):
        near = idx[np.clip(np.searchsorted(idx, np.arange(a, b)), 0, idx.size - 1)]
        J[a:b] = _jacobians(p.proj, x[near])
    return J
