"""Anatomical landmarks carried by technical clusters: the calibrated anatomical system
technique (CAST; Cappozzo et al., Clin. Biomech. 10(4), 1995).

In a static trial each landmark (epicondyle, styloid, greater tubercle) is seen together
with the cluster of markers on its segment, which fixes the landmark in the cluster's frame.
In a movement trial, where the landmarks are not worn, each frame's least-squares rigid fit
of the cluster (Arun/Kabsch/Umeyama without scale) carries the landmark along.
"""

from __future__ import annotations

import re

import numpy as np


def cluster_names(names: tuple[str, ...], spec: tuple[str, ...]) -> list[str]:
    """A cluster's markers: the list given, or the ``names`` matching "PREFIX*" (PREFIX + digits)."""
    if len(spec) == 1 and spec[0].endswith("*"):
        pat = re.compile(re.escape(spec[0][:-1]) + r"\d+$")
        return [n for n in names if pat.match(n)]
    return list(spec)


def rigid_fit(ref: np.ndarray, cur: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """R (3, 3), t (3,) minimising Σ‖R·ref_k + t − cur_k‖² over markers k (both (K, 3), K ≥ 3).

    Umeyama 1991, eqs. 34-41 with c = 1: centre both sets, H = Σ (ref_k − r̄)(cur_k − c̄)ᵀ,
    H = U S Vᵀ, R = V diag(1, 1, det(V Uᵀ)) Uᵀ (the sign guards against a reflection),
    t = c̄ − R r̄.
    """
    r0, c0 = ref.mean(axis=0), cur.mean(axis=0)
    H = (ref - r0).T @ (cur - c0)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    return R, c0 - R @ r0


def calibrate(static_cluster: np.ndarray, static_landmark: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
    """The cluster's reference shape (K, 3) and the landmark (3,) beside it, both the static
    trial's means over frames (m, lab frame): together they fix the landmark in the cluster."""
    ref = np.nanmean(static_cluster, axis=0)
    point = np.nanmean(static_landmark, axis=0)
    return ref, point


def poses(ref: np.ndarray, cluster: np.ndarray, *, min_markers: int = 3
          ) -> tuple[np.ndarray, np.ndarray]:
    """(R (N, 3, 3), t (N, 3)): each frame's rigid fit of ``ref`` (K, 3) onto ``cluster``
    (N, K, 3), x_lab = R·x_ref + t (rigid_fit, all frames with every marker seen at once);
    NaN where fewer than ``min_markers`` are seen."""
    n = cluster.shape[0]
    R, t = np.full((n, 3, 3), np.nan), np.full((n, 3), np.nan)
    seen = np.isfinite(cluster).all(axis=2) & np.isfinite(ref).all(axis=1)
    full = seen.all(axis=1) & (seen.shape[1] >= min_markers)
    if full.any():  # Umeyama 1991, eqs. 34-41 (c = 1), batched over frames
        r0, c0 = ref - ref.mean(axis=0), cluster[full]
        c_mean = c0.mean(axis=1)
        U, _, Vt = np.linalg.svd(np.einsum("ki,nkj->nij", r0, c0 - c_mean[:, None]))
        d = np.sign(np.linalg.det(np.swapaxes(Vt, 1, 2) @ np.swapaxes(U, 1, 2)))
        D = np.zeros((d.size, 3, 3))
        D[:, 0, 0], D[:, 1, 1], D[:, 2, 2] = 1.0, 1.0, np.where(d == 0, 1.0, d)
        R[full] = np.swapaxes(Vt, 1, 2) @ D @ np.swapaxes(U, 1, 2)
        t[full] = c_mean - R[full] @ ref.mean(axis=0)
    for i in np.flatnonzero(~full & (seen.sum(axis=1) >= min_markers)):
        k = seen[i]
        R[i], t[i] = rigid_fit(ref[k], cluster[i, k])
    return R, t


def carry(ref: np.ndarray, point: np.ndarray, cluster: np.ndarray, *,
          min_markers: int = 3) -> np.ndarray:
    """(N, 3) landmark positions: ``point`` carried by the rigid fit of ``ref`` (K, 3) onto
    each frame's ``cluster`` (N, K, 3); NaN where fewer than ``min_markers`` are seen."""
    R, t = poses(ref, cluster, min_markers=min_markers)
    return R @ point + t


def carry_landmark(static, trial, landmark: str, cluster: list[str]) -> np.ndarray:
    """(N, 3) ``landmark`` of the static trial carried through ``trial`` by ``cluster``
    (MarkerTrajectories both; the caller has checked the names exist)."""
    ref, point = calibrate(np.stack([static.marker(n) for n in cluster], axis=1),
                           static.marker(landmark))
    return carry(ref, point, np.stack([trial.marker(n) for n in cluster], axis=1))


def three_point_angle_deg(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(N,) the angle at b between b→a and b→c, degrees (180 = straight)."""
    u, v = a - b, c - b
    cosang = np.sum(u * v, axis=1) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))
    return np.degrees(np.arccos(np.clip(cosang, -1.0, 1.0)))
