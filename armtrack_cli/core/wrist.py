"""The hand frame H and the clinical wrist angles (SESSION_FORMAT.md), for estimates and
ground truth alike.

H: origin at the WRIST marker, x towards MCP3 (in the palm plane), z out of the back of the
hand, y = z × x (the thumb side of a right hand). Wrist angles are those of R_FH, the hand
relative to the forearm frame F (H in the neutral pose):
R_FH = Rz(deviation) · Ry(flexion) · Rx(−pronation); a left hand negates deviation and pronation.
"""

from __future__ import annotations

import numpy as np

ANGLES = ("flexion", "deviation", "pronation")


def wrist_angles_deg(R_FH: np.ndarray, side: str = "right") -> np.ndarray:
    """(N, 3) flexion, deviation, pronation in degrees from R_FH (N, 3, 3).

    For R = Rz(a) Ry(b) Rx(c): R[2,0] = −sin b, R[1,0]/R[0,0] = tan a, R[2,1]/R[2,2] = tan c;
    flexion = b, deviation = a, pronation = −c (right hand)."""
    R = np.asarray(R_FH, float)
    flex = -np.arcsin(np.clip(R[..., 2, 0], -1.0, 1.0))
    dev = np.arctan2(R[..., 1, 0], R[..., 0, 0])
    pron = -np.arctan2(R[..., 2, 1], R[..., 2, 2])
    s = 1.0 if side == "right" else -1.0
    return np.degrees(np.stack([flex, s * dev, s * pron], -1))


def hand_frame(points: np.ndarray, names: tuple[str, ...], side: str = "right"
               ) -> tuple[np.ndarray, np.ndarray]:
    """The hand frame from the palm markers (N, M, 3) named ``names`` (NaN = missing):
    (origin (N, 3) = WRIST, R_WH (N, 3, 3) with columns x_H, y_H, z_H).

    z_H is the normal of the least-squares plane through the markers, turned so that the
    thumb-side markers (CMC1, MCP2) lie on +y_H for a right hand (−y_H for a left); x_H is
    WRIST -> MCP3 projected into the plane. NaN where WRIST, MCP3 or fewer than 4 markers
    are missing."""
    P = np.asarray(points, float)
    w, m3 = P[:, names.index("WRIST")], P[:, names.index("MCP3")]
    ok = np.isfinite(P).all(-1)
    c = np.nanmean(np.where(ok[..., None], P, np.nan), axis=1)
    D = np.where(ok[..., None], P - c[:, None], 0.0)
    n = np.linalg.svd(np.einsum("nki,nkj->nij", D, D))[0][..., 2]  # smallest-variance axis
    thumb = [names.index(k) for k in ("CMC1", "MCP2") if k in names]
    t = np.nanmean(P[:, thumb], axis=1) - w if thumb else np.zeros_like(w)
    x = m3 - w
    x = x - np.sum(x * n, -1, keepdims=True) * n
    x /= np.linalg.norm(x, axis=-1, keepdims=True)
    y = np.cross(n, x)
    flip = np.sum(y * t, -1) < 0 if side == "right" else np.sum(y * t, -1) > 0
    n = np.where(flip[:, None], -n, n)
    R = np.stack([x, np.cross(n, x), n], -1)
    bad = ~(np.isfinite(w).all(-1) & np.isfinite(m3).all(-1) & (ok.sum(1) >= 4))
    R[bad] = np.nan
    return np.where(bad[:, None], np.nan, w), R
