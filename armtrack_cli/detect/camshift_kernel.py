"""CamShift (Bradski 1998) and the region under its centre, compiled with numba for the patch
tracker's frame (detect/patch_kernel.py): OpenCV's cv::meanShift and cv::CamShift on an 8-bit
mask, their roundings kept (tests/test_patch_kernel.py holds them equal to cv2.CamShift), and
the 8-connected region of a pixel as detect/regions.py and patch_check.look see it.
``cache=True``: the compile happens once per install and is loaded from __pycache__.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

TOLERANCE = 10  # cv::CamShift grows meanShift's window by this on every side


@njit(cache=True, nogil=True)
def _moments(mask, x, y, w, h):
    """Raw moments m00, m10, m01, m20, m11, m02 of mask[y:y+h, x:x+w] (window coordinates),
    exact integers as doubles (cv::moments on 8-bit)."""
    m00 = m10 = m01 = m20 = m11 = m02 = 0
    for r in range(h):
        s0 = s1 = s2 = 0
        for c in range(w):
            p = np.int64(mask[y + r, x + c])
            s0 += p
            s1 += p * c
            s2 += p * c * c
        m00 += s0
        m10 += s1
        m01 += s0 * r
        m20 += s2
        m11 += s1 * r
        m02 += s0 * r * r
    return float(m00), float(m10), float(m01), float(m20), float(m11), float(m02)


@njit(cache=True, nogil=True)
def _mean_shift(mask, H, W, x, y, w, h, niters):
    """cv::meanShift with eps 0 (cvRound(0.5²)): the window moved to its mass's centre."""
    for _ in range(niters):
        m00, m10, m01, _a, _b, _c = _moments(mask, x, y, w, h)
        if abs(m00) < 2.220446049250313e-16:
            break
        dx = int(np.rint(m10 / m00 - w * 0.5))
        dy = int(np.rint(m01 / m00 - h * 0.5))
        nx, ny = min(max(x + dx, 0), W - w), min(max(y + dy, 0), H - h)
        if nx == x and ny == y:
            break
        x, y = nx, ny
    return x, y


@njit(cache=True, nogil=True)
def camshift(mask, H, W, x, y, w, h, niters, res):
    """cv::CamShift on mask[:H, :W] from window (x, y, w, h) inside it: res[1:10] = centre,
    size (width, height), angle (deg), window (x, y, w, h); False when the window holds no
    mass (OpenCV's empty box)."""
    x, y = _mean_shift(mask, H, W, x, y, w, h, niters)
    x, y = max(x - TOLERANCE, 0), max(y - TOLERANCE, 0)
    w, h = min(w + 2 * TOLERANCE, W - x), min(h + 2 * TOLERANCE, H - y)
    m00, m10, m01, m20, m11, m02 = _moments(mask, x, y, w, h)
    if abs(m00) < 2.220446049250313e-16:
        return False
    box_of(m00, m10, m01, m20, m11, m02, x, y, w, h, H, W, res)
    return True


@njit(cache=True, nogil=True)
def box_of(m00, m10, m01, m20, m11, m02, x, y, w, h, H, W, res):
    """cv::CamShift's last step: its box from the raw moments (m00 > 0) of its final window
    (x, y, w, h) of an image H x W, into res[1:10] as camshift fills it. On a whole image
    that is one region's mask (W x H, from the window (0, 0, W, H)) meanShift cannot move the
    window and the grown window is the image again: CamShift is this step on its moments."""
    inv = 1.0 / m00
    cx, cy = m10 * inv, m01 * inv  # cv::moments' central moments
    mu20, mu11, mu02 = m20 - m10 * cx, m11 - m10 * cy, m02 - m01 * cy
    xc, yc = int(np.rint(m10 * inv + x)), int(np.rint(m01 * inv + y))
    a, b, c = mu20 * inv, mu11 * inv, mu02 * inv
    square = math.sqrt(4 * b * b + (a - c) * (a - c))
    theta = math.atan2(2 * b, a - c + square)
    cs, sn = math.cos(theta), math.sin(theta)
    rotate_a = max(0.0, cs * cs * mu20 + 2 * cs * sn * mu11 + sn * sn * mu02)
    rotate_c = max(0.0, sn * sn * mu20 - 2 * cs * sn * mu11 + cs * cs * mu02)
    length, width = math.sqrt(rotate_a * inv) * 4, math.sqrt(rotate_c * inv) * 4
    if length < width:
        length, width = width, length
        cs, sn = sn, cs
        theta = math.pi * 0.5 - theta
    t0 = max(int(np.rint(abs(length * cs))), int(np.rint(abs(width * sn)))) + 2
    w = min(t0, (W - xc) * 2)
    t0 = max(int(np.rint(abs(length * sn))), int(np.rint(abs(width * cs)))) + 2
    h = min(t0, (H - yc) * 2)
    x, y = max(0, xc - w // 2), max(0, yc - h // 2)
    w, h = min(W - x, w), min(H - y, h)
    ang = np.float32((math.pi * 0.5 + theta) * 180.0 / math.pi)
    while ang < 0:
        ang += np.float32(360)
    while ang >= 360:
        ang -= np.float32(360)
    if ang >= 180:
        ang -= np.float32(180)
    res[1] = np.float32(x) + np.float32(w) * np.float32(0.5)
    res[2] = np.float32(y) + np.float32(h) * np.float32(0.5)
    res[3], res[4], res[5] = np.float32(width), np.float32(length), ang
    res[6], res[7], res[8], res[9] = x, y, w, h


@njit(cache=True, nogil=True)
def region_at(mask, H, W, u, v, seen, stack, counts, hue, res, box):
    """The 8-connected region of mask[:H, :W] under pixel (u, v), as detect/regions.py and
    patch_check.look see it: res[10:14] = area, centroid (u, v) and whether its box touches
    the region's edge; counts[h] += its pixels of hue h. The centroid is computed as
    Regions computes it (on the box of the mask's pixels, from an even row and column);
    ``box`` (c0, r0, c1, r1) holds all of the mask's pixels."""
    bx, by = W, H  # the mask's box corner, made even (Regions.x0, y0)
    for r in range(box[1], box[3]):
        for c in range(box[0], box[2]):
            if mask[r, c] and c < bx:
                bx = c
            if mask[r, c] and r < by:
                by = r
    bx, by = bx & ~1, by & ~1
    n, top = 0, 0
    sx = sy = 0
    ux0, uy0, ux1, uy1 = W, H, -1, -1
    stack[0] = v * W + u
    seen[v, u] = 1
    top = 1
    while top > 0:
        top -= 1
        p = stack[top]
        r, c = p // W, p % W
        n += 1
        sx += c - bx
        sy += r - by
        ux0, uy0, ux1, uy1 = min(ux0, c), min(uy0, r), max(ux1, c), max(uy1, r)
        counts[hue[r, c]] += 1
        for rr in range(max(r - 1, 0), min(r + 2, H)):
            for cc in range(max(c - 1, 0), min(c + 2, W)):
                if mask[rr, cc] and not seen[rr, cc]:
                    seen[rr, cc] = 1
                    stack[top] = rr * W + cc
                    top += 1
    for r in range(uy0, uy1 + 1):  # the marks back to zero for the next call
        for c in range(ux0, ux1 + 1):
            seen[r, c] = 0
    res[10] = n
    res[11] = sx / n + bx
    res[12] = sy / n + by
    res[13] = 1.0 if (ux0 == 0 or uy0 == 0 or ux1 + 1 >= W or uy1 + 1 >= H) else 0.0
