"""The camera rows' variance where detect's error is correlated from frame to frame.

The smoother takes each frame's detection as an independent measurement of π(p) with SD
``pixel_sigma``. Where the patch is still in the image that is not so: the video codec
(MPEG-4's motion-compensated blocks) carries a still patch's pixels, and with them the
centroid's error, from frame to frame. On simulated sessions (validation/detect_correlation.py,
docs/validation-from-mocap.md) detect's error has a lag-1 autocorrelation of 0.74-0.81 and an
integrated autocorrelation time τ of 12-16 frames (UE-ADL sessions; 5-25 on the validation
tasks) where the patch moves less than 0.5 px a frame, and 0.1-0.2 (τ 2-7) where it moves
faster; the error's size (RMS) is the same in both.
n frames of an error correlated over τ frames tell its mean as well as n / τ independent ones
(the variance of a correlated series' mean, e.g. Geyer 1992, "Practical Markov chain Monte
Carlo", Statist. Sci. 7(4)), so rows of the per-frame SD pin a still patch's position τ times
tighter than its frames know it. Here each still frame's row gets the variance σ² τ
(``pixel_still_tau``), as the rest rows' SD carries the resting hand's τ (fuse/rest.py).

Which frames are still is read from the detections themselves (never from a truth): the
patch's image speed by the central difference |z_{k+1} − z_{k−1}| / 2 below ``pixel_still_px``
px per frame. A frame whose neighbours were not both detected is taken as moving.
"""

from __future__ import annotations

import numpy as np


def still_patch(z: np.ndarray, px_per_frame: float) -> np.ndarray:
    """(n,) bool: frames whose detection z (n, 2) px (NaN: none) moves less than px_per_frame
    px a frame, by the central difference of the frames either side (both detected)."""
    n = z.shape[0]
    still = np.zeros(n, bool)
    if n >= 3:
        with np.errstate(invalid="ignore"):
            speed = np.linalg.norm(z[2:] - z[:-2], axis=1) / 2  # NaN where one is missing
            still[1:-1] = speed < px_per_frame
    return still


def row_scale(z: np.ndarray, tau: float, px_per_frame: float) -> np.ndarray | None:
    """(n,) the factor 1 / √κ of each frame's camera rows, κ = tau on still frames (still_patch)
    and 1 elsewhere: a row h, z of variance κ σ² is the row h / √κ, z / √κ of variance σ²,
    what the kernel takes (fuse/smoother_kernel.py); None when tau is 1 (rows as they are)."""
    if tau == 1.0:
        return None
    return np.where(still_patch(z, px_per_frame), 1.0 / np.sqrt(tau), 1.0)


def scaled(Hc: np.ndarray, zc: np.ndarray, scale: np.ndarray | None, lo: int = 0,
           hi: int | None = None) -> tuple:
    """The camera rows Hc (m, 2, d), zc (m, 2) of frames lo … hi − 1, each frame's scaled by
    its ``scale`` (the session's, row_scale; None: the rows as they are)."""
    if scale is None:
        return Hc, zc
    w = scale[lo:hi]
    return Hc * w[:, None, None], zc * w[:, None]
