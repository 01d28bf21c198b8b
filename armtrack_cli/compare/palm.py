"""ukf-palm scored against Qualisys palm markers: the validation Cordella et al. left to
future work (V). The truth WRIST is the Qualisys WRIST marker; the truth hand frame comes from
the six markers through the same definition of H (core/wrist.py), and the truth forearm frame
F is that hand frame averaged over the first second of the estimate (the neutral start)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from armtrack_cli.compare.errors import COLUMNS, error_rows, table_one, truth_at
from armtrack_cli.core.wrist import ANGLES, hand_frame, wrist_angles_deg
from armtrack_cli.core.wrist_measures import angular_speeds, lowpass

if TYPE_CHECKING:
    import pandas as pd

NEUTRAL_S = 1.0


@dataclass(frozen=True)
class TruthPose:
    wrist: np.ndarray  # (K, 3) WRIST marker in W at the trajectory's times, NaN in gaps
    angles_deg: np.ndarray  # (K, 3) flexion, deviation, pronation of R_FH


@dataclass(frozen=True)
class PalmScore:
    position: pd.DataFrame  # errors.csv rows (cm)
    angles: pd.DataFrame  # per angle: mean, SD, RMSE, max |error| (deg), n
    speed_rows: list  # measures.csv rows: each angle's peak and mean speed, estimate and truth
    excluded: int  # estimated frames without ground truth
    text: str


def mean_rotation(R: np.ndarray) -> np.ndarray:
    """Chordal L2 mean of rotations (N, 3, 3): the projection of their average onto SO(3)."""
    U, _, Vt = np.linalg.svd(np.nanmean(R, axis=0))
    return U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt


def rotations_at(t: np.ndarray, t_q: np.ndarray, R: np.ndarray, rate_hz: float) -> np.ndarray:
    """(K, 3, 3) rotations R (N, 3, 3) at times t (K,): each column interpolated linearly as a
    marker is (truth_at: NaN in gaps), then projected onto SO(3) (the nearest rotation, by SVD)."""
    cols = np.stack([truth_at(t, t_q, R[:, :, j], rate_hz) for j in range(3)], -1)
    out = np.full(cols.shape, np.nan)
    ok = np.isfinite(cols).all(axis=(1, 2))
    if ok.any():
        U, _, Vt = np.linalg.svd(cols[ok])
        d = np.sign(np.linalg.det(U @ Vt))
        out[ok] = U @ (np.eye(3) * np.stack([np.ones_like(d), np.ones_like(d), d], -1)[:, None]) @ Vt
    return out


def pose(t: np.ndarray, wrist: np.ndarray, R_WH: np.ndarray, side: str, *,
         start_t: float) -> TruthPose:
    """Truth wrist and angles from R_WH (K, 3, 3) at times t: F is R_WH's chordal mean over the
    first second from ``start_t`` (the estimate's neutral start), R_FH = R_WFᵀ R_WH."""
    first = (t >= start_t) & (t < start_t + NEUTRAL_S) & np.isfinite(R_WH).all(axis=(1, 2))
    if not first.any():
        return TruthPose(wrist, np.full((t.size, 3), np.nan))
    R_WF = mean_rotation(R_WH[first])
    ok = np.isfinite(R_WH).all(axis=(1, 2))
    ang = np.full((t.size, 3), np.nan)
    ang[ok] = wrist_angles_deg(R_WF.T @ R_WH[ok], side)
    return TruthPose(wrist, ang)


def truth_pose(t: np.ndarray, t_q: np.ndarray, xyz: np.ndarray, rate_hz: float,
               names: tuple[str, ...], side: str, *, start_t: float) -> TruthPose:
    """Truth at times t (K,) from Qualisys markers xyz (N, M, 3) in W at session times t_q."""
    at = np.stack([truth_at(t, t_q, xyz[:, k], rate_hz) for k in range(xyz.shape[1])], 1)
    wrist, R_WH = hand_frame(at, tuple(names), side)
    return pose(t, wrist, R_WH, side, start_t=start_t)


def truth_pose_6dof(t: np.ndarray, t_q: np.ndarray, wrist: np.ndarray, R_WH: np.ndarray,
                    rate_hz: float, side: str, *, start_t: float) -> TruthPose:
    """Truth at times t (K,) from a QTM 6DOF hand body: its origin (N, 3) in W (the WRIST) and
    rotation R_WH (N, 3, 3) (its axes those of H), at session times t_q."""
    return pose(t, truth_at(t, t_q, wrist, rate_hz), rotations_at(t, t_q, R_WH, rate_hz), side,
                start_t=start_t)


def _rom(x: np.ndarray) -> tuple[float, float]:
    """(max − min, 95th − 5th percentile) of x, NaN when empty."""
    if not x.size:
        return np.nan, np.nan
    return float(np.ptp(x)), float(np.subtract(*np.percentile(x, [95, 5])))


def _angle_rows(method: str, t: np.ndarray, est: np.ndarray, truth: np.ndarray,
                measured: np.ndarray) -> list[dict]:
    """Per angle: the error's statistics over the frames where both exist, and the RoM of
    estimate and truth over those of them that were measured (not the filter's prediction
    while the markers were lost: kinematics-ukf-palm.csv's frames) (truth from the six
    markers, core/wrist.py), both low-passed at 6 Hz as the kinematic measures are (marker
    noise would otherwise widen the truth's max − min)."""
    rows = []
    for k, name in enumerate(ANGLES):
        ok = np.isfinite(est[:, k]) & np.isfinite(truth[:, k])
        e = est[ok, k] - truth[ok, k]
        n = int(e.size)
        m = ok & measured
        (re, pe) = _rom(lowpass(t, np.where(m, est[:, k], np.nan))[m])
        (rt, pt) = _rom(lowpass(t, np.where(m, truth[:, k], np.nan))[m])
        rows.append({"method": method, "angle": name,
                     "mean_deg": float(e.mean()) if n else np.nan,
                     "std_deg": float(e.std(ddof=1)) if n > 1 else np.nan,
                     "rmse_deg": float(np.sqrt(np.mean(e**2))) if n else np.nan,
                     "max_abs_deg": float(np.abs(e).max()) if n else np.nan,
                     "rom_deg": re, "rom_truth_deg": rt, "rom_error_deg": re - rt,
                     "rom_p5_p95_deg": pe, "rom_p5_p95_truth_deg": pt,
                     "rom_p5_p95_error_deg": pe - pt, "n": n})
    return rows


def score(method: str, traj: pd.DataFrame, truth: TruthPose,
          measured: np.ndarray | None = None) -> PalmScore:
    """Errors over every frame with both; RoM and angular speeds over the ``measured`` ones
    (default: all)."""
    import pandas as pd  # palm sessions only: arm compare never loads it

    t = traj["t"].to_numpy()
    measured = np.ones(t.size, bool) if measured is None else measured
    est_w = traj[["wrist_x", "wrist_y", "wrist_z"]].to_numpy()
    est_a = traj[[f"{a}_deg" for a in ANGLES]].to_numpy()
    pos = error_rows(method, "wrist", est_w, truth.wrist)
    ang = _angle_rows(method, t, est_a, truth.angles_deg, measured)
    ok = np.isfinite(est_w).all(1) & np.isfinite(truth.wrist).all(1) & np.isfinite(
        truth.angles_deg).all(1)
    excluded = int((np.isfinite(est_w).all(1) & ~ok).sum())
    ok_m = ok & measured
    mask = lambda a: np.where(ok_m[:, None], a, np.nan)  # noqa: E731  (the same frames for both)
    speeds = [{"method": method, "measure": e[0], "segment": "session", "unit": e[2],
               "estimate": e[1], "estimate_sd": np.nan, "truth": tr[1], "error": e[1] - tr[1],
               "error_pct": 100 * (e[1] - tr[1]) / abs(tr[1]) if tr[1] else np.nan}
              for e, tr in zip(angular_speeds(t, mask(est_a)), angular_speeds(t, mask(truth.angles_deg)))]
    lines = [table_one(pos, "wrist"), "", "wrist angle error (deg)   mean     SD   RMSE    max"]
    for r in ang:
        lines.append(f"  {r['angle']:<22} {r['mean_deg']:6.2f} {r['std_deg']:6.2f} "
                     f"{r['rmse_deg']:6.2f} {r['max_abs_deg']:6.2f}")
    lines.append("RoM, max − min (deg): " + ", ".join(
        f"{r['angle']} {r['rom_deg']:.1f} (truth {r['rom_truth_deg']:.1f})" for r in ang))
    return PalmScore(pd.DataFrame(pos, columns=list(COLUMNS)), pd.DataFrame(ang), speeds,
                     excluded, "\n".join(lines))


@dataclass(frozen=True)
class AssociationScore:
    """Marker-frames (frame, marker) from the start frame on: ``correct`` when the filter used
    the marker's own blob, or used none where no blob of its own was there (hidden, turned
    away, merged); ``wrong`` when it used another blob; ``missed`` when it used none although
    the marker's own blob was there. ``clutter_used``: clutter blobs associated with a marker."""

    marker_frames: int
    correct: int
    wrong: int
    missed: int
    clutter_used: int

    @property
    def accuracy(self) -> float:
        return self.correct / max(self.marker_frames, 1)


def association_score(blobs: list[np.ndarray], marker_of_blob: list[np.ndarray],
                      marker_px: np.ndarray, visible: np.ndarray, clutter_px: np.ndarray, *,
                      start: int = 0, tol_px: float = 2.5) -> AssociationScore:
    """Score associations against simulated truth: blobs (B_k, ≥2) per frame, the filter's
    marker of each blob (-1 none), true marker pixels (K, M, 2) and visibility (K, M), and
    clutter pixels (C, 2) (NaN rows = absent)."""
    n = good = wrong = missed = clut = 0
    for k in range(start, len(blobs)):
        b, mob = blobs[k][:, :2], marker_of_blob[k]
        M = marker_px.shape[1]
        own = np.full(M, -1)
        if len(b):
            d = np.linalg.norm(b[:, None] - marker_px[k][None], axis=-1)  # (B, M)
            near = np.argmin(d, axis=0)
            ok = visible[k] & (d[near, np.arange(M)] < tol_px)
            shared = np.bincount(near[visible[k]], minlength=len(b))[near] > 1  # merged blob
            own[ok & ~shared] = near[ok & ~shared]
            dc = np.linalg.norm(b[:, None] - clutter_px[None], axis=-1)
            clut += int(((np.nan_to_num(dc, nan=np.inf) < tol_px).any(axis=1) & (mob >= 0)).sum())
        for j in range(M):
            used = np.flatnonzero(mob == j)
            n += 1
            if used.size and used[0] == own[j]:
                good += 1
            elif used.size:
                wrong += 1
            elif own[j] >= 0:
                missed += 1
            else:
                good += 1
    return AssociationScore(n, good, wrong, missed, clut)
