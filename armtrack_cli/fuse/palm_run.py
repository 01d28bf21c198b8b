"""The ukf-palm loop (Cordella et al. III): predict (eq. 5), associate blobs with markers
(eq. 6-12), update with the associated markers only (V(t)), and the output table.

Pure: arrays in, arrays and a table out; pipeline/palm.py reads and writes the files.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from armtrack_cli.core import quaternion as quat
from armtrack_cli.core.wrist import ANGLES, wrist_angles_deg
from armtrack_cli.filters import manifold_ukf as mu
from armtrack_cli.filters.gaussian import SigmaPoints
from armtrack_cli.fuse.association import associate
from armtrack_cli.fuse.palm_models import PalmUkfSettings, Rig, facing, measure, noise_cov, process
from armtrack_cli.fuse.palm_reacquire import reacquire

STATE_DIM = 12  # error state: φ (3), T (3), v (3), ω (3)
NOISE_DIM = 6  # augmented noise: a (3), α (3)


@dataclass(frozen=True)
class PalmTrack:
    """Per frame k of t (K,): posterior R (K,3,3) = R_{W0 H}, x (K,9), P (K,12,12); markers
    used (K,); seconds since the last update (K,); marker_of_blob: per frame, (B_k,) the
    marker of each blob (-1 clutter or gated out). NaN before the start frame."""

    R: np.ndarray
    x: np.ndarray
    P: np.ndarray
    used: np.ndarray
    coast_s: np.ndarray
    marker_of_blob: list


def initial_state(s: PalmUkfSettings, R: np.ndarray | None = None,
                  T: np.ndarray | None = None) -> mu.ManifoldState:
    """W0 is H at the start: R = I, T = 0, at rest; P0 from the initialisation's spread. After
    a re-acquisition: the fitted R, T, at rest, the same spread."""
    sd = np.r_[[np.deg2rad(s.init_sigma_deg)] * 3, [s.init_sigma_m] * 3, [0.02] * 3, [0.2] * 3]
    x = np.zeros(9)
    if T is not None:
        x[:3] = T
    return mu.ManifoldState(np.eye(3) if R is None else R, x, np.diag(sd**2))


def marker_area(blobs: np.ndarray, pixels: np.ndarray) -> float:
    """A single marker's blob area (px²): the median area of the blobs nearest the labelled
    markers of the initialisation frame."""
    if len(blobs) == 0:
        return np.inf
    d = np.linalg.norm(blobs[None, :, :2] - pixels[:, None], axis=-1)
    return float(np.median(blobs[np.argmin(d, axis=1), 2]))


class _NumpySteps:
    """The reference: filters/manifold_ukf.py with palm_models.process and measure."""

    def __init__(self, rig: Rig, s: PalmUkfSettings, rvar: np.ndarray, image_area: float):
        self.rig, self.s, self.R_meas, self.image_area = rig, s, np.diag(rvar), image_area
        self.sp = SigmaPoints(STATE_DIM + NOISE_DIM, alpha=s.alpha, beta=s.beta, kappa=s.kappa)

    def prior(self, st: mu.ManifoldState, dt: float):
        f = lambda R, x, w: process(R, x, w, dt)  # noqa: E731  (eq. 5)
        pr = mu.predict(st, f, noise_cov(self.s, dt), self.sp)
        Z = measure(self.rig, pr.Rs, pr.xs)  # eq. 9: every marker, every sigma point
        return (pr, *mu.predicted_measurement(pr, Z, self.R_meas))  # eq. 10-11

    def correct(self, pr, rows, z, zm, Pzz, Pxz) -> mu.ManifoldState:
        return mu.correct(pr, z, zm[rows], Pzz[rows[:, None], rows], Pxz[:, rows])

    def associate(self, y, zm, S, usable) -> tuple[np.ndarray, np.ndarray]:
        s = self.s
        a = associate(y, zm, S, usable, prior_marker=s.prior_marker,
                      prior_clutter=s.prior_clutter, image_area=self.image_area, gate=s.gate,
                      merge_px=s.merge_px)
        return a.marker_of_blob, a.blob_of_marker


class _KernelSteps:
    """The same steps compiled (fuse/palm_kernel.py), into work arrays allocated once."""

    def __init__(self, rig: Rig, s: PalmUkfSettings, rvar: np.ndarray, image_area: float):
        from armtrack_cli.fuse import palm_kernel as pk

        self.pk, self.s, self.rvar, self.image_area = pk, s, rvar, image_area
        sp = SigmaPoints(STATE_DIM + NOISE_DIM, alpha=s.alpha, beta=s.beta, kappa=s.kappa)
        self.c, (self.Wm, self.Wc) = sp.n + sp.lam, sp.weights()
        S, k = 2 * sp.n + 1, rvar.size
        d = np.zeros(5)
        d[:min(5, rig.dist.size)] = rig.dist[:5]
        self.geo = (np.ascontiguousarray(rig.markers_H, float), rig.R_CW0.copy(),
                    np.asarray(rig.T_CW0, float).copy(),
                    np.array([rig.K[0, 0], rig.K[0, 1], rig.K[0, 2], rig.K[1, 1], rig.K[1, 2]]), d)
        self.work = (np.empty((S, 3, 3)), np.empty((S, STATE_DIM - 3)), np.empty((S, STATE_DIM)),
                     np.empty((S, k)))

    def prior(self, st: mu.ManifoldState, dt: float):
        R, x, P = np.empty((3, 3)), np.empty(9), np.empty((STATE_DIM, STATE_DIM))
        k = self.rvar.size
        zm, Pzz, Pxz = np.empty(k), np.empty((k, k)), np.empty((STATE_DIM, k))
        self.pk.prior(st.R, st.x, st.P, self.s.accel_density, self.s.ang_accel_density, dt,
                      self.c, self.Wm, self.Wc, *self.geo, self.rvar, *self.work, R, x, P, zm,
                      Pzz, Pxz)
        return mu.Prior(R, x, P, *self.work[:3], self.Wm, self.Wc), zm, Pzz, Pxz

    def correct(self, pr, rows, z, zm, Pzz, Pxz) -> mu.ManifoldState:
        R, x, P = np.empty((3, 3)), np.empty(9), np.empty((STATE_DIM, STATE_DIM))
        self.pk.correct(pr.R, pr.x, pr.P, rows, z, zm, Pzz, Pxz, R, x, P)
        return mu.ManifoldState(R, x, P)

    def associate(self, y, zm, S, usable) -> tuple[np.ndarray, np.ndarray]:
        from armtrack_cli.fuse import association_kernel as ak

        s = self.s
        mob, bom = np.empty(len(y), np.int64), np.empty(len(zm), np.int64)
        ak.associate(np.ascontiguousarray(y), zm, S, usable, s.prior_marker, s.prior_clutter,
                     self.image_area, s.gate, s.merge_px, mob, bom)
        return mob, bom


def track(t: np.ndarray, blobs: list[np.ndarray], start: int, rig: Rig, s: PalmUkfSettings,
          image_area: float, area_px: float, *, compiled: bool = True) -> PalmTrack:
    """Run the filter from frame ``start`` (the initialisation frame, neutral pose) on the
    frame times t (K,) and each frame's blobs (B_k, 4): u, v (px), area (px²), depth (m, NaN
    without a reading). Blobs larger than s.merged_area × area_px (one marker's area) are
    merged markers, never used. ``compiled``: the numba steps, else the numpy reference."""
    K, M = t.size, rig.markers_H.shape[0]
    rvar = np.r_[np.full(2 * M, s.pixel_sigma**2), np.full(M, s.depth_sigma_m**2)]
    steps = (_KernelSteps if compiled else _NumpySteps)(rig, s, rvar, image_area)
    out_R, out_x = np.full((K, 3, 3), np.nan), np.full((K, 9), np.nan)
    out_P = np.full((K, STATE_DIM, STATE_DIM), np.nan)
    used, coast = np.zeros(K, int), np.full(K, np.nan)
    mob: list = [np.full(len(b), -1) for b in blobs]
    st, last = initial_state(s), t[start]
    two = 2 * np.arange(M)[:, None, None]
    rr, cc = two + np.array([0, 1])[:, None], two + np.array([0, 1])[None, :]  # 2×2 blocks
    for k in range(start, K):
        dt = t[k] - t[k - 1] if k > start else 1e-3  # from the frame times, not 0.03 s
        single = blobs[k][:, 2] <= s.merged_area * area_px
        y = blobs[k][single]
        if t[k] - last > s.max_coast_s:  # lost: only the palm model can pick the hand up
            got = reacquire(y, rig, sigma_px=s.pixel_sigma, sigma_z=s.depth_sigma_m)
            coast[k] = t[k] - last
            if got is None:
                continue  # the row stays empty
            st, last = initial_state(s, got[0], got[1]), t[k]
            mob[k][single] = got[2]
            out_R[k], out_x[k], out_P[k], used[k], coast[k] = st.R, st.x, st.P, M, 0.0
            continue
        pr, zm, Pzz, Pxz = steps.prior(st, dt)
        S = Pzz[rr, cc]  # (M, 2, 2): P_yy,j of each marker
        m_of_b, b_of_m = steps.associate(y[:, :2], zm[:2 * M].reshape(M, 2), S,
                                         facing(rig, pr.R, pr.x[:3]))  # eq. 6-12
        j = np.flatnonzero(b_of_m >= 0)
        if k > start and last < t[k - 1] and j.size < s.resume_min_markers:  # a pose needs 3
            m_of_b[:] = -1
            j = j[:0]
        mob[k][single] = m_of_b
        if j.size:
            b = y[b_of_m[j]]
            rows, z = (2 * j[:, None] + np.array([0, 1])).ravel(), b[:, :2].ravel()
            if s.depth_updates:
                zr = 2 * M + j
                ok = np.isfinite(b[:, 3]) & ((b[:, 3] - zm[zr]) ** 2 <= s.gate * Pzz[zr, zr])
                rows, z = np.concatenate([rows, zr[ok]]), np.concatenate([z, b[ok, 3]])
            st = steps.correct(pr, rows, z, zm, Pzz, Pxz)
            last = t[k]
        else:
            st = mu.no_update(pr)
        out_R[k], out_x[k], out_P[k], used[k], coast[k] = st.R, st.x, st.P, j.size, t[k] - last
    return PalmTrack(out_R, out_x, out_P, used, coast, mob)


def _angle_sd(R: np.ndarray, P_phi: np.ndarray, side: str) -> np.ndarray:
    """(K, 3) SD of the wrist angles: J P_φφ Jᵀ with J = ∂angles/∂φ by central differences."""
    h = 1e-6
    J = np.empty(R.shape[:1] + (3, 3))
    for k in range(3):
        e = np.zeros(3)
        e[k] = h
        J[:, :, k] = (wrist_angles_deg(R @ mu.exp_so3(e), side)
                      - wrist_angles_deg(R @ mu.exp_so3(-e), side)) / (2 * h)
    return np.sqrt(np.einsum("kij,kjl,kil->ki", J, P_phi, J))


def trajectory_table(t: np.ndarray, tr: PalmTrack, R_WW0: np.ndarray, T_WW0: np.ndarray,
                     side: str, max_coast_s: float) -> pd.DataFrame:
    """trajectory-ukf-palm.csv: the WRIST marker in W, R_WH, the wrist angles (R_FH = R, W0
    being H in the neutral start), velocities, posterior SDs, markers used and a flag for
    predicted-only frames. Rows more than max_coast_s after the last update are empty."""
    ok = np.isfinite(tr.x).all(axis=1) & (np.nan_to_num(tr.coast_s, nan=np.inf) <= max_coast_s)
    Rk = np.where(ok[:, None, None], tr.R, np.eye(3))
    R_WH = R_WW0 @ Rk
    wrist = tr.x[:, :3] @ R_WW0.T + T_WW0
    vel = tr.x[:, 3:6] @ R_WW0.T
    cov_T = R_WW0 @ tr.P[:, 3:6, 3:6] @ R_WW0.T
    cov_v = R_WW0 @ tr.P[:, 6:9, 6:9] @ R_WW0.T
    ang = wrist_angles_deg(Rk, side)
    ang_sd = _angle_sd(Rk, np.where(ok[:, None, None], tr.P[:, :3, :3], np.eye(3)), side)
    cols = {"t": t}
    for k, a in enumerate("xyz"):
        cols[f"wrist_{a}"] = wrist[:, k]
    for k, a in enumerate("xyz"):
        cols[f"wrist_v{a}"] = vel[:, k]
    q = quat.from_matrix(R_WH)
    for k, a in enumerate("wxyz"):
        cols[f"q{a}"] = q[:, k]
    for k, a in enumerate(ANGLES):
        cols[f"{a}_deg"] = ang[:, k]
    for k, a in enumerate("xyz"):
        cols[f"w{a}"] = tr.x[:, 6 + k]
    for k, a in enumerate("xyz"):
        cols[f"wrist_{a}_sd"] = np.sqrt(cov_T[:, k, k])
    for k, a in enumerate("xyz"):
        cols[f"wrist_v{a}_sd"] = np.sqrt(cov_v[:, k, k])
    for k, a in enumerate(ANGLES):
        cols[f"{a}_deg_sd"] = ang_sd[:, k]
    for k, a in enumerate("xyz"):
        cols[f"w{a}_sd"] = np.sqrt(tr.P[:, 9 + k, 9 + k])
    df = pd.DataFrame(cols)
    df.loc[~ok, df.columns[1:]] = np.nan
    df["markers_used"] = tr.used
    df["predicted_only"] = ((tr.used == 0) & np.isfinite(tr.coast_s)).astype(int)
    return df
