"""The user-specific palm model from the first frame (Cordella et al., sections II-C, III-D).

With the hand in the neutral pose, the six marker blobs are lifted to 3-D (depth frame, or the
plane of the back of the hand when there is no depth), labelled from anatomy and the measured
link lengths, and expressed in the hand frame H: origin WRIST, x towards MCP3, z out of the
back of the hand, y = z × x. The link lengths are kept as measured; the in-plane angles come
from the frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

# radial -> ulnar order of Cordella's markers around the wrist
ANATOMICAL_ORDER = ("CMC1", "MCP2", "MCP3", "MCP4", "MCP5")


@dataclass(frozen=True)
class PalmFit:
    names: tuple[str, ...]
    blob_index: np.ndarray  # (6,) which input blob is each named marker
    points_W: np.ndarray  # (6, 3) the labelled markers in W
    position_H: np.ndarray  # (6, 3) model: link length at the measured in-plane angle, in H
    angle_deg: np.ndarray  # (6,) in-plane angle from x_H
    link_residual_m: np.ndarray  # (6,) observed wrist distance minus the measured link
    R_WH: np.ndarray  # (3, 3) the hand frame in the first frame


def _normal(points: np.ndarray, towards: np.ndarray) -> np.ndarray:
    c = points.mean(axis=0)
    n = np.linalg.svd(points - c)[2][2]
    return n if n @ (towards - c) > 0 else -n


def _hand_frame(wrist, mcp3, n):
    x = mcp3 - wrist
    x = x - (x @ n) * n
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(n, x), n], -1)  # columns x_H, y_H, z_H in W


def label_palm(points_W: np.ndarray, names: tuple[str, ...], links: tuple[float, ...], *,
               side: str, camera_W: np.ndarray) -> PalmFit | None:
    """Pick 6 of the blobs and name them: the choice whose wrist distances best match the
    links and whose angular order around the wrist is the anatomical one."""
    names = tuple(names)
    k = points_W.shape[0]
    if k < len(names):
        return None
    w_idx = names.index("WRIST")
    others = [n for n in names if n != "WRIST"]
    order = [n for n in ANATOMICAL_ORDER if n in others]
    if side == "right":
        order = order[::-1]  # ascending angle about z_H runs ulnar -> radial for a right hand
    links = np.asarray(links, float)
    best = None
    for combo in combinations(range(k), len(names)):
        P = points_W[list(combo)]
        n = _normal(P, camera_W)
        for wi in range(len(combo)):
            rest = [j for j in range(len(combo)) if j != wi]
            v = P[rest] - P[wi]
            v -= np.outer(v @ n, n)
            ref = v.sum(axis=0)
            ref /= np.linalg.norm(ref)
            ang = np.arctan2((np.cross(ref, v) @ n), v @ ref)
            if np.ptp(ang) > np.deg2rad(150):
                continue
            sorted_rest = [rest[j] for j in np.argsort(ang)]
            assign = {"WRIST": wi}
            if len(order) == len(rest):
                assign.update({name: j for name, j in zip(order, sorted_rest)})
            else:  # unknown marker names: match by distance alone
                d = np.linalg.norm(P[rest] - P[wi], axis=1)
                for name in others:
                    j = rest[int(np.argmin(np.abs(d - links[names.index(name)])))]
                    assign[name] = j
            idx = np.array([assign[nm] for nm in names])
            d = np.linalg.norm(P[idx] - P[idx[w_idx]], axis=1)
            cost = float(np.sum((d - links) ** 2))
            if best is None or cost < best[0]:
                best = (cost, np.array(combo)[idx])
    if best is None:
        return None
    blob = best[1]
    P = points_W[blob]
    n = _normal(P, camera_W)
    R = _hand_frame(P[w_idx], P[names.index("MCP3")] if "MCP3" in names else P[
        [i for i in range(len(names)) if i != w_idx][0]], n)
    local = (P - P[w_idx]) @ R
    ang = np.arctan2(local[:, 1], local[:, 0])
    ang[w_idx] = 0.0
    position = np.stack([links * np.cos(ang), links * np.sin(ang), np.zeros_like(links)], -1)
    resid = np.linalg.norm(P - P[w_idx], axis=1) - links
    return PalmFit(names, blob, P, position, np.rad2deg(ang), resid, R)
