"""How soon `detect` reports the patch again once it can be seen (issue 14), from the
simulator's truth: where the patch is, whether it is visible (facing the camera, in the image,
under neither the card nor the other arm), and how far the other arm's sleeve is from it in
the image. Used by validation/detect_distractor.py.

A frame is *clear* when the patch is visible and the other arm's sleeve and hand lie more than
CLEAR_PX from the patch's outline in the image (nearer, the two are one same-hue region or
about to be, and the patch cannot be told from the sleeve). After each stretch that is not
clear (a card, the other arm over or against the patch), the *lag* is the number of clear
frames before the first frame with ``ok = 1``.
"""

from __future__ import annotations

import cv2
import numpy as np

CLEAR_PX = 5.0
PATCH_SIDE_M = 0.035  # simulate/render.py Scene.patch_side_m
SLEEVE_R_M, HAND_M, HAND_R_M = 0.035, 0.085, 0.03  # simulate/distractors.py


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """v (k, 3) rotated by unit quaternion q (w, x, y, z)."""
    w, u = q[0], q[1:]
    t = 2 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def sleeve_gap_px(truth: dict) -> np.ndarray:
    """(n_frames,) px between the patch's outline and the other arm (sleeve or hand, each a
    cone of its radius about its axis) in the image; negative when they overlap, +inf without
    the other arm."""
    n = truth["frame_t"].size
    if "frame_other_elbow" not in truth:
        return np.full(n, np.inf)
    K, R, T = truth["K"], truth["R_WC"], truth["T_WC"]
    rvec = cv2.Rodrigues(R)[0]

    def proj(X):
        return (cv2.projectPoints(X, rvec, T, K, truth["dist"])[0].reshape(-1, 2),
                (X @ R.T + T)[:, 2])

    h = PATCH_SIDE_M / 2
    corners = np.array([[-h, -h, 0], [h, -h, 0], [h, h, 0], [-h, h, 0]])
    s = np.linspace(0, 1, 12)[:, None]
    out = np.empty(n)
    for i in range(n):
        pc = proj(truth["frame_wrist"][i] + _rotate(truth["frame_q_WB"][i], corners))[0]
        edge = np.concatenate([pc[k] + s * (pc[(k + 1) % 4] - pc[k]) for k in range(4)])
        e, w = truth["frame_other_elbow"][i], truth["frame_other_wrist"][i]
        d = (w - e) / np.linalg.norm(w - e)
        best = np.inf
        for a, b, r in ((e, w, SLEEVE_R_M), (w, w + HAND_M * d, HAND_R_M)):
            ab, z = proj(np.stack([a, b]))
            rp = K[0, 0] * r / z  # the radius in px at each end
            v = ab[1] - ab[0]
            t = np.clip((edge - ab[0]) @ v / max(float(v @ v), 1e-9), 0, 1)
            dist = np.linalg.norm(edge - (ab[0] + t[:, None] * v), axis=1)
            best = min(best, float((dist - (rp[0] + t * (rp[1] - rp[0]))).min()))
        out[i] = best
    return out


def lags(clear: np.ndarray, ok: np.ndarray, occluded: np.ndarray) -> list[tuple[int, str, int,
                                                                                int | None]]:
    """(first frame, cause, clear frames in the stretch, lag in frames or None if the patch is
    not reported in the stretch) for the first clear stretch (cause 'start') and every clear
    stretch after a frame that is not clear: cause 'card' when the card was over the patch the
    frame before, else 'arm' (the other arm over or against it, or the patch turned away)."""
    out = []
    i, n = 0, clear.size
    while i < n:
        if not (clear[i] and (i == 0 or not clear[i - 1])):
            i += 1
            continue
        end = i
        while end < n and clear[end]:
            end += 1
        hit = np.flatnonzero(ok[i:end])
        cause = "start" if not out and not clear[:i].any() else \
            "card" if occluded[i - 1] else "arm"
        out.append((i, cause, end - i,
                    int(hit[0]) if hit.size else None))
        i = end
    return out


def longest_run(flags: np.ndarray) -> int:
    """Length of the longest run of True."""
    best = run = 0
    for f in flags:
        run = run + 1 if f else 0
        best = max(best, run)
    return best
