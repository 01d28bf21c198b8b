"""Quaternions (w, x, y, z), Hamilton convention, rotating B into W: v_W = q ⊗ v_B ⊗ q*.

All functions take time-first arrays: ``q`` of shape (..., 4), vectors of shape (..., 3),
rotation matrices of shape (..., 3, 3). Pure numpy, vectorised over leading axes.
"""

from __future__ import annotations

import numpy as np


def normalize(q: np.ndarray) -> np.ndarray:
    """Unit quaternions (..., 4); NaN rows stay NaN."""
    q = np.asarray(q, dtype=float)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def multiply(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product p ⊗ q for (..., 4) arrays."""
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    pw, px, py, pz = np.moveaxis(p, -1, 0)
    qw, qx, qy, qz = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
        ],
        axis=-1,
    )


def conjugate(q: np.ndarray) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def to_matrix(q: np.ndarray) -> np.ndarray:
    """R (..., 3, 3) with R @ v_B = v_W for unit q (w, x, y, z)."""
    w, x, y, z = np.moveaxis(normalize(q), -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=-2,
    )


def from_matrix(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (..., 4), w >= 0, from rotation matrices (..., 3, 3).

    Shepperd's method: pick the largest of 4w², 4x², 4y², 4z² for numerical stability.
    """
    R = np.asarray(R, dtype=float)
    m00, m11, m22 = R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]
    trace = m00 + m11 + m22
    cand = np.stack([1 + trace, 1 + m00 - m11 - m22, 1 - m00 + m11 - m22, 1 - m00 - m11 + m22], -1)
    k = np.argmax(np.nan_to_num(cand, nan=-np.inf), axis=-1)
    s = np.sqrt(np.maximum(np.take_along_axis(cand, k[..., None], -1)[..., 0], 1e-300)) * 2
    q = np.empty(R.shape[:-2] + (4,))
    d21, d02, d10 = R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]
    a01, a02, a12 = R[..., 0, 1] + R[..., 1, 0], R[..., 0, 2] + R[..., 2, 0], R[..., 1, 2] + R[..., 2, 1]
    rows = [
        np.stack([s / 4, d21 / s, d02 / s, d10 / s], -1),
        np.stack([d21 / s, s / 4, a01 / s, a02 / s], -1),
        np.stack([d02 / s, a01 / s, s / 4, a12 / s], -1),
        np.stack([d10 / s, a02 / s, a12 / s, s / 4], -1),
    ]
    for i, row in enumerate(rows):
        q = np.where((k == i)[..., None], row, q)
    q = np.where(q[..., :1] < 0, -q, q)
    return normalize(q)


ROWS_AT_ONCE = 16384  # rotate's rows a chunk at a time: its matrices (n, 3, 3) and their
#                      temporaries are ~150 bytes a row (a 60-minute session's: 17 MB)


def row_spans(n: int, size: int = ROWS_AT_ONCE):
    """(a, b): rows [0, n) ``size`` at a time, for work whose temporaries a row at a time
    would be session-long (each row's numbers its own)."""
    return ((a, min(a + size, n)) for a in range(0, n, size))


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """q ⊗ v ⊗ q*: vectors (..., 3) from B into W; (n, 4) rows ROWS_AT_ONCE at a time (the
    same numbers: every row's own)."""
    q, v = np.asarray(q, dtype=float), np.asarray(v, dtype=float)
    n = q.shape[0] if q.ndim == 2 else 0
    if n <= ROWS_AT_ONCE or v.ndim > 2 or (v.ndim == 2 and v.shape[0] != n):
        return np.einsum("...ij,...j->...i", to_matrix(q), v)
    out = np.empty((n, 3))
    for a, b in row_spans(n):
        out[a:b] = np.einsum("...ij,...j->...i", to_matrix(q[a:b]), v[a:b] if v.ndim == 2 else v)
    return out


def from_euler_zyx(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """Quaternion of R = Rz(yaw) · Ry(pitch) · Rx(roll), angles in radians (Xsens convention)."""
    cr, sr = np.cos(np.asarray(roll) / 2), np.sin(np.asarray(roll) / 2)
    cp, sp = np.cos(np.asarray(pitch) / 2), np.sin(np.asarray(pitch) / 2)
    cy, sy = np.cos(np.asarray(yaw) / 2), np.sin(np.asarray(yaw) / 2)
    return np.stack(
        [
            cr * cp * cy + sr * sp * sy,
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
        ],
        axis=-1,
    )


def from_axis_angle(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Quaternion of a rotation by ``angle`` (rad) about unit ``axis`` (..., 3)."""
    axis = np.asarray(axis, dtype=float)
    half = np.asarray(angle, dtype=float)[..., None] / 2
    return np.concatenate([np.cos(half), np.sin(half) * axis], axis=-1)


def from_rotvec(v: np.ndarray) -> np.ndarray:
    """Unit quaternions (..., 4) of rotation vectors v (..., 3), rad (the exponential map)."""
    v = np.asarray(v, dtype=float)
    ang = np.linalg.norm(v, axis=-1)
    return from_axis_angle(v / np.where(ang > 1e-15, ang, 1.0)[..., None], ang)


def to_rotvec(q: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., 3) of unit quaternions (..., 4), angle in [0, π] (the shorter way
    round; the logarithm map)."""
    q = np.asarray(q, dtype=float)
    q = q * np.where(q[..., :1] < 0, -1.0, 1.0)
    s = np.linalg.norm(q[..., 1:], axis=-1)
    return q[..., 1:] * (2 * np.arctan2(s, q[..., 0]) / np.where(s > 1e-15, s, 1.0))[..., None]


def angle_between(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Rotation angle (rad) of p* ⊗ q, in [0, π]."""
    d = np.abs(np.sum(normalize(p) * normalize(q), axis=-1))
    return 2 * np.arccos(np.clip(d, 0.0, 1.0))


def interpolate(t_src: np.ndarray, q: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Quaternions at times t by normalised linear interpolation between the neighbouring
    samples (after making consecutive samples the same hemisphere); NaN outside t_src."""
    q = np.array(q, dtype=float)
    flip = np.r_[False, np.sum(q[1:] * q[:-1], axis=1) < 0]
    sign = np.where(np.cumsum(flip) % 2 == 1, -1.0, 1.0)
    q *= sign[:, None]
    i = np.clip(np.searchsorted(t_src, t, side="right"), 1, t_src.size - 1)
    t0, t1 = t_src[i - 1], t_src[i]
    f = ((t - t0) / np.where(t1 > t0, t1 - t0, 1.0))[:, None]
    out = normalize(q[i - 1] * (1 - f) + q[i] * f)
    out[(t < t_src[0]) | (t > t_src[-1])] = np.nan
    return out
