"""Joint angles over time (degrees) and their range of motion."""

from __future__ import annotations

import numpy as np

from armtrack_cli.core import quaternion as quat
from armtrack_cli.measures.base import DEFAULT, NotComputable, Settings
from armtrack_cli.measures.vec3 import dot3, norm3


def elbow_flexion_deg(shoulder: np.ndarray, elbow: np.ndarray, wrist: np.ndarray) -> np.ndarray:
    """(N,) 0° = full extension: 180° minus the angle between elbow→shoulder and elbow→wrist."""
    a, b = shoulder - elbow, wrist - elbow
    c = dot3(a, b) / (norm3(a) * norm3(b))
    return 180.0 - np.degrees(np.arccos(np.clip(c, -1, 1)))


def thorax_from_world(u_W: np.ndarray, side: str) -> np.ndarray:
    """Directions in W -> the ISB thorax frame (Wu et al. 2005, J Biomech 38: 981), with the
    trunk assumed aligned with W and facing −y_W (the camera side of the table): X anterior =
    −y_W, Y up = +z_W, Z right = −x_W; for a left arm Z is mirrored to point left."""
    z = -u_W[..., 0] if side == "right" else u_W[..., 0]
    return np.stack([-u_W[..., 1], u_W[..., 2], z], -1)


def shoulder_angles_deg(shoulder: np.ndarray, elbow: np.ndarray, side: str,
                        s: Settings = DEFAULT) -> tuple[np.ndarray, np.ndarray]:
    """(elevation, plane of elevation), (N,) each: the humerus in the thorax by the ISB Y-X-Y
    sequence (Wu et al. 2005 §3.3: plane of elevation about Y, then elevation about the
    rotated X; the third, axial rotation, needs the humerus's own frame and is not given).
    Elevation 0° = arm hanging down; plane 0° = abduction in the frontal plane, 90° = forward
    flexion. Y-X-Y has its gimbal lock at 0° elevation, where the plane is undefined: it is
    NaN wherever elevation < s.plane_min_elevation_deg. Positions (..., N, 3) give (..., N):
    each trajectory (e.g. a posterior draw) unwrapped on its own."""
    u = elbow - shoulder
    u = thorax_from_world(u / norm3(u)[..., None], side)
    elev = np.degrees(np.arccos(np.clip(-u[..., 1], -1, 1)))
    plane = np.degrees(np.arctan2(u[..., 0], u[..., 2]))  # u = (sinθ sinα, −cosθ, sinθ cosα)
    ok = np.isfinite(plane) & (elev >= s.plane_min_elevation_deg)
    plane = np.where(ok, plane, np.nan)
    for i in np.ndindex(ok.shape[:-1]):  # one trajectory, or each of many
        row, o = plane[i], ok[i]  # continuous through ±180° where the plane is defined
        if o.any():
            row[o] = np.degrees(np.unwrap(np.radians(row[o])))
    return elev, plane


def neutral_quaternion(t: np.ndarray, q: np.ndarray, s: Settings) -> np.ndarray:
    """Mean orientation over the first s.neutral_s seconds of finite samples (sign-aligned
    quaternion average, normalised: exact for the small spread of a still pose)."""
    ok = np.isfinite(q).all(axis=1)
    if not ok.any():
        raise NotComputable("no orientation samples")
    first = ok & (t <= t[ok][0] + s.neutral_s)
    qs = q[first] * np.sign(q[first] @ q[first][0])[:, None]
    return quat.normalize(qs.mean(axis=0))


def forearm_pronation_deg(t: np.ndarray, q_WB: np.ndarray, axis_B: np.ndarray, side: str,
                          s: Settings = DEFAULT, neutral: np.ndarray | None = None) -> np.ndarray:
    """(N,) pronation (+) / supination (−) of the forearm relative to its pose in the first
    second: the twist of q0* ⊗ q about the forearm axis in B (swing-twist decomposition).
    Pronation turns a right forearm clockwise seen from the elbow, i.e. negatively about the
    elbow→hand axis; a left one positively. ``neutral``: that pose, when t is not the
    session's start (a long session's later windows: measures/windowed.py)."""
    q0 = neutral_quaternion(t, q_WB, s) if neutral is None else neutral
    q_rel = quat.multiply(quat.conjugate(q0)[None], q_WB)
    twist = 2 * np.arctan2(q_rel[:, 1:] @ axis_B, q_rel[:, 0])
    twist = (twist + np.pi) % (2 * np.pi) - np.pi
    ok = np.isfinite(twist)
    twist[ok] = np.unwrap(twist[ok])
    return np.degrees(-twist if side == "right" else twist)


def hand_frames(wrist: np.ndarray, mcp3: np.ndarray, cmc1: np.ndarray, side: str) -> np.ndarray:
    """(N, 3, 3) R_WH from three palm markers (SESSION_FORMAT.md, H): x towards MCP3, y in
    the palm plane on the thumb side for a right hand (CMC1), z = x × y out of the back."""
    x = mcp3 - wrist
    x /= np.linalg.norm(x, axis=-1, keepdims=True)
    thumb = cmc1 - wrist
    y = thumb - np.sum(thumb * x, -1, keepdims=True) * x
    y /= np.linalg.norm(y, axis=-1, keepdims=True)
    y = y if side == "right" else -y
    return np.stack([x, y, np.cross(x, y)], -1)


def wrist_angles_deg(t: np.ndarray, R_WH: np.ndarray, side: str,
                     s: Settings = DEFAULT) -> np.ndarray:
    """(N, 3) flexion, deviation, pronation of R_FH = R_WFᵀ R_WH, F = H's mean over the first
    second, decomposed as Rz(deviation) · Ry(flexion) · Rx(−pronation) (SESSION_FORMAT.md;
    the left hand negates deviation and pronation)."""
    q = quat.from_matrix(R_WH)
    q_F = neutral_quaternion(t, q, s)
    R = quat.to_matrix(quat.multiply(quat.conjugate(q_F)[None], q))
    flex = -np.arcsin(np.clip(R[:, 2, 0], -1, 1))  # Z-Y-X Euler angles of R
    dev = np.arctan2(R[:, 1, 0], R[:, 0, 0])
    pron = -np.arctan2(R[:, 2, 1], R[:, 2, 2])
    sgn = 1.0 if side == "right" else -1.0
    return np.degrees(np.stack([flex, sgn * dev, sgn * pron], -1))


def rom(x: np.ndarray) -> dict[str, float]:
    """Range of motion of an angle over its finite samples: max − min, and the robust 5th-95th
    percentile range (less sensitive to a single wrong frame)."""
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    if x.size < 10:
        raise NotComputable(f"only {x.size} frames with this angle")
    p5, p95 = np.percentile(x, [5, 95])
    return {"min": float(x.min()), "max": float(x.max()), "rom": float(np.ptp(x)),
            "rom_p5_p95": float(p95 - p5)}


def rom_rows(x: np.ndarray) -> dict[str, np.ndarray]:
    """rom of each row of x (c, N) at once (the posterior draws of one angle): {min, max,
    rom, rom_p5_p95} -> (c,), NaN for a row with fewer than 10 finite samples. The rows
    without a missing sample share one percentile call (the same order statistics and the
    same interpolation as rom's, row by row); the others are rom's, one at a time."""
    x = np.asarray(x, float)
    fin = np.isfinite(x)
    out = {k: np.full(x.shape[0], np.nan) for k in ("min", "max", "rom", "rom_p5_p95")}
    full = fin.all(axis=1) & (x.shape[1] >= 10)
    if full.any():
        y = x[full]
        lo, hi = y.min(axis=1), y.max(axis=1)
        p5, p95 = np.percentile(y, [5, 95], axis=1)
        out["min"][full], out["max"][full], out["rom"][full] = lo, hi, hi - lo
        out["rom_p5_p95"][full] = p95 - p5
    for i in np.flatnonzero(~full & (fin.sum(axis=1) >= 10)).tolist():
        for k, v in rom(x[i]).items():
            out[k][i] = v
    return out
