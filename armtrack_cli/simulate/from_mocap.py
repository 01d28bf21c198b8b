"""A simulated arm session whose shoulder, elbow and wrist follow a real motion-capture
recording (`armtrack simulate OUT --from-mocap FILE`).

Pure: the pipeline reads the recording and hands over the joint centres and the forearm
cluster's rotation in the lab frame (``MocapMotion``); this module trims it to its longest
complete span, low-passes it (the recording's marker noise would otherwise dominate its
second derivative), places it on a table in front of a camera as a lab would, and senses it
like the synthetic tasks: the IMU on the forearm turns with the forearm cluster and feels
the wrist centre's acceleration (simulate/imu_model.py errors), the camera is rendered
(simulate/render.py), and the recording itself, mapped to W, is the Qualisys truth.

Clocks (SESSION_FORMAT.md): recording time τ; the IMU and Qualisys streams start with the
recording (stream time = τ) and the video ``lead_s`` later, so session time = τ − lead_s and
imu_offset_s = groundtruth_offset_s = −lead_s.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.interpolate import make_interp_spline
from scipy.signal import butter, sosfiltfilt

from armtrack_cli.core import quaternion as quat
from armtrack_cli.simulate import imu_model, kinematics, render
from armtrack_cli.simulate.arm_session import (
    BOARD,
    PATCH_BGR,
    QTM_NAMES,
    ArmSimSettings,
    ArmSimulation,
)
from armtrack_cli.simulate.camera import default_camera, project
from armtrack_cli.simulate.capture import QTM_TO_WORLD, qualisys_markers
from armtrack_cli.vision.charuco import make_board

WRIST_W_XY = (0.16, 0.30)  # the middle of the wrist's workspace in W, just past the board
WRIST_ABOVE_TABLE_M = 0.035  # the wrist centre's height when the forearm rests on the table
MIN_SPAN_S = 2.0


@dataclass(frozen=True)
class MocapMotion:
    """One arm of a recording, in the lab frame (z up), at the capture rate.

    t: (N,) s from the first frame; shoulder, elbow, wrist: (N, 3) m, NaN where unknown;
    R_forearm: (N, 3, 3) the forearm cluster's rotation from its static-trial shape (lab),
    NaN where fewer than 3 of its markers were seen; facing_L: (3,) the subject's forward
    direction in the lab (horizontal unit vector)."""

    t: np.ndarray
    shoulder: np.ndarray
    elbow: np.ndarray
    wrist: np.ndarray
    R_forearm: np.ndarray
    facing_L: np.ndarray
    rate_hz: float


@dataclass(frozen=True)
class MocapSimSettings(ArmSimSettings):
    source: str = ""  # the recording's file name (session.toml comment, command line)
    static: str = ""
    cutoff_hz: float = 6.0  # low-pass of the joint centres and the cluster rotation
    lead_s: float = 0.5  # the video starts this long after the recording
    imu_offset_s: float = -0.5
    groundtruth_offset_s: float = -0.5
    duration_s: float = 3600.0  # at most this much of the recording (its complete span)
    camera_elevation_deg: float = 65.0  # the camera's line of sight below the horizontal


def complete_span(m: MocapMotion) -> slice:
    """The longest run of frames where every joint centre and the rotation are known."""
    ok = (np.isfinite(m.shoulder).all(1) & np.isfinite(m.elbow).all(1)
          & np.isfinite(m.wrist).all(1) & np.isfinite(m.R_forearm).all((1, 2)))
    edges = np.diff(np.r_[0, ok.astype(int), 0])
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    if starts.size == 0:
        return slice(0, 0)
    k = int(np.argmax(ends - starts))
    return slice(int(starts[k]), int(ends[k]))


def lab_to_world(m: MocapMotion) -> np.ndarray:
    """4x4 T_WL: turn about z so the subject faces −y_W (across the table, towards the
    camera), the middle of the wrist's workspace over WRIST_W_XY, the table (lowest wrist less the
    wrist's height above it) at z_W = 0."""
    f = m.facing_L
    yaw = np.arctan2(-1.0, 0.0) - np.arctan2(f[1], f[0])
    c, s = np.cos(yaw), np.sin(yaw)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    w = m.wrist @ R.T
    mid = 0.5 * (np.nanmin(w, 0) + np.nanmax(w, 0))
    table_z = np.nanpercentile(m.wrist[:, 2], 1) - WRIST_ABOVE_TABLE_M
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = [WRIST_W_XY[0] - mid[0], WRIST_W_XY[1] - mid[1], -table_z]
    return T


def _lowpass(x: np.ndarray, cutoff_hz: float, rate_hz: float) -> np.ndarray:
    """4th-order Butterworth, forward-backward (zero lag), along axis 0."""
    if cutoff_hz >= 0.45 * rate_hz or x.shape[0] < 30:
        return x
    sos = butter(4, cutoff_hz, fs=rate_hz, output="sos")
    return sosfiltfilt(sos, x, axis=0)


@dataclass(frozen=True)
class Recording:
    """The trimmed, low-passed recording in W as quintic splines of recording time τ."""

    t0: float
    t1: float
    joints: object  # spline of (N, 9): shoulder, elbow, wrist
    q: object  # spline of (N, 4): sensor orientation R_WB (normalised on evaluation)
    samples_t: np.ndarray  # the recording's own sample times (τ) in the span
    samples: np.ndarray  # (N, 3, 3) the low-passed joint centres there, W


def recording(m: MocapMotion, T_WL: np.ndarray, cutoff_hz: float, forearm_axis: str
              ) -> Recording:
    span = complete_span(m)
    n = span.stop - span.start
    if n < MIN_SPAN_S * m.rate_hz:
        raise ValueError(f"its longest span with every joint centre and the forearm cluster "
                         f"seen is {n / m.rate_hz:.2f} s; at least {MIN_SPAN_S:g} s is needed")
    R, T = T_WL[:3, :3], T_WL[:3, 3]
    t = m.t[span]
    pos = np.stack([m.shoulder[span], m.elbow[span], m.wrist[span]], 1) @ R.T + T
    pos = _lowpass(pos.reshape(n, 9), cutoff_hz, m.rate_hz).reshape(n, 3, 3)
    # the sensor: at the first frame its forearm axis runs elbow -> wrist, z_B out of the back
    # of the wrist; afterwards it turns with the forearm cluster (R_W(t) R_W(0)ᵀ in W)
    Rc = np.einsum("ij,njk,kl->nil", R, m.R_forearm[span], R.T)
    q0 = kinematics.sensor_orientation(pos[:1, 1], pos[:1, 2], np.zeros(1), forearm_axis)[0]
    q_rel = quat.from_matrix(np.einsum("nij,kj->nik", Rc, Rc[0]))
    q = quat.multiply(q_rel, np.broadcast_to(q0, q_rel.shape))
    q *= np.where(np.cumsum(np.r_[0, np.sign(np.sum(q[1:] * q[:-1], 1)) < 0]) % 2 == 1,
                  -1.0, 1.0)[:, None]  # one hemisphere throughout, so the components are smooth
    q = quat.normalize(_lowpass(q, cutoff_hz, m.rate_hz))
    return Recording(float(t[0]), float(t[-1]), make_interp_spline(t, pos.reshape(n, 9), k=5),
                     make_interp_spline(t, q, k=5), t, pos)


def arm_state(rec: Recording, tau: np.ndarray) -> kinematics.ArmState:
    """The recorded arm at recording times τ (clipped to the span), derivatives from the splines."""
    tau = np.clip(np.asarray(tau, float), rec.t0, rec.t1)
    p = rec.joints(tau).reshape(-1, 3, 3)
    v = rec.joints(tau, 1).reshape(-1, 3, 3)
    a = rec.joints(tau, 2).reshape(-1, 3, 3)
    qr = rec.q(tau)
    norm = np.linalg.norm(qr, axis=1, keepdims=True)
    q = qr / norm
    qdot = rec.q(tau, 1) / norm - qr * (np.sum(qr * rec.q(tau, 1), 1, keepdims=True) / norm**3)
    omega = 2 * quat.multiply(quat.conjugate(q), qdot)[:, 1:]  # ω_B = 2 vec(q* ⊗ q̇)
    c = np.ascontiguousarray
    return kinematics.ArmState(tau, c(p[:, 0]), c(p[:, 1]), c(p[:, 2]), c(v[:, 2]), c(a[:, 2]),
                               c(v[:, 1]), q, omega)


def place_camera(wrist_W: np.ndarray, normal_W: np.ndarray, s: MocapSimSettings):
    """A camera across the table from the subject, above it, looking down at the middle of the
    wrist's workspace (docs/recording-guide.md: "in front of and above the table, looking down
    at the workspace"), as a lab would set it up for the task: of the bearings within ±45° of
    straight across, the one that sees the back of the wrist (the patch, ``normal_W``) on the
    most frames, at ``s.camera_elevation_deg`` above the table, moved back along its line of
    sight until the whole wrist path and the board are in view.

    The elevation matters to the arm constraint: the camera ray through the elbow meets the
    elbow's sphere about the shoulder at the angle between the ray and the upper arm, and an
    error δr in the sphere moves the estimate δr / cos(that angle) along the ray. Seated at a
    table the upper arm leans forward and down; from 30-37° above (where moving a 45° camera
    back and up to fit a reach had put it) the ray is nearly tangent to the sphere on the
    UE-ADL reaches (median cos 0.01-0.14), from 65° it is not (0.3-0.6;
    docs/validation-from-mocap.md)."""
    sq = BOARD["squares"]
    bw, bh = sq[0] * BOARD["square_m"], sq[1] * BOARD["square_m"]
    board = np.array([[0, 0, 0], [bw, 0, 0], [bw, -bh, 0], [0, -bh, 0.0]])
    pts = np.concatenate([wrist_W[:: max(1, wrist_W.shape[0] // 400)], board])
    target = 0.5 * (pts.min(0) + pts.max(0))
    el = np.deg2rad(s.camera_elevation_deg)
    best = (-1.0, None)
    for bearing in np.deg2rad([0, -15, 15, -30, 30, -45, 45]):
        u = np.array([np.sin(bearing) * np.cos(el), -np.cos(bearing) * np.cos(el), np.sin(el)])
        for dist in np.arange(0.6, 3.0, 0.05):  # from the target to the camera, m
            cam = default_camera(width=s.width, height=s.height,
                                 k1=-0.12 if s.distortion else 0.0,
                                 k2=0.03 if s.distortion else 0.0, eye=target + dist * u,
                                 target=target)
            px, z = project(cam, pts)
            m = np.array([0.05 * s.width, 0.05 * s.height])
            if (z > 0.1).all() and ((px > m) & (px < [s.width, s.height] - m)).all():
                break
        seen = float(np.mean(np.einsum("ni,ni->n", normal_W, cam.centre_W - wrist_W) > 0))
        if seen > best[0] + 0.02:  # prefer the straight-across bearing unless clearly better
            best = (seen, cam)
    return best[1]


def declared_arm(rec: Recording) -> tuple[np.ndarray, float, float]:
    """The arm a lab would declare: the shoulder at its mean, the lengths at their medians."""
    S, E, W = rec.samples[:, 0], rec.samples[:, 1], rec.samples[:, 2]
    return (S.mean(0), float(np.median(np.linalg.norm(E - S, axis=1))),
            float(np.median(np.linalg.norm(W - E, axis=1))))


def simulate_mocap(motion: MocapMotion, s: MocapSimSettings) -> ArmSimulation:
    """The whole session: the same parts as simulate_arm, from the recording."""
    rng = np.random.default_rng(s.seed)
    T_WL = lab_to_world(motion)
    rec = recording(motion, T_WL, s.cutoff_hz, s.forearm_axis)
    shoulder, L1, L2 = declared_arm(rec)
    duration = min(s.duration_s, rec.t1 - rec.t0 - s.lead_s)
    s = replace(s, shoulder=tuple(float(v) for v in shoulder), upper_arm_m=round(L1, 4),
                forearm_m=round(L2, 4), duration_s=duration, imu_offset_s=-s.lead_s,
                groundtruth_offset_s=-s.lead_s)
    tau0 = rec.t0 + s.lead_s  # recording time of session time 0
    frame_t = np.arange(int(np.floor(duration * s.fps)) + 1) / s.fps
    frame_t = frame_t[frame_t <= duration]
    fs = arm_state(rec, frame_t + tau0)
    cam = place_camera(fs.wrist, quat.rotate(fs.q_WB, [0.0, 0, 1]), s)
    # --- IMU from the recording's start: stream time = τ − t0, session = stream − lead
    errors = imu_model.ImuErrors.preset(s.imu_preset).override(**s.imu_errors)
    t_stream = np.arange(int(np.floor((rec.t1 - rec.t0) * s.imu_rate_hz)) + 1) / s.imu_rate_hz
    t_sess = t_stream + s.imu_offset_s
    st = arm_state(rec, t_sess + tau0 - errors.latency_s)
    meas = imu_model.measure(t_sess, st.q_WB, st.wrist_acc, st.omega_B, errors, s.imu_rate_hz, rng)
    imu = {"t": t_stream, "acc": meas["acc"], "gyr": meas["gyr"], "quat": meas["quat"]}
    # --- the recording as Qualisys truth, at its own samples, in the Qualisys frame
    tq = rec.samples_t - rec.t0
    xyz_q = qualisys_markers(rec.samples, 0.0, 0, 2, motion.rate_hz, rng)
    board = make_board(BOARD["squares"], BOARD["square_m"], BOARD["marker_m"],
                       BOARD["dictionary"])
    scene = render.build_scene(cam, board, BOARD["square_m"], PATCH_BGR, rng)
    dense_t = np.arange(int(np.floor(duration * 200)) + 1) / 200.0
    ds = arm_state(rec, dense_t + tau0)
    truth = _truth(cam, fs, ds, s, imu, st, meas, T_WL)
    occluded = np.zeros(frame_t.size, bool)
    return ArmSimulation(s, cam, imu, {"t": tq, "xyz": xyz_q, "names": QTM_NAMES}, truth, scene,
                         frame_t, occluded)


def _truth(cam, fs, ds, s: MocapSimSettings, imu, st, meas, T_WL) -> dict:
    wrist_px, _ = project(cam, fs.wrist)
    facing = np.einsum("ni,ni->n", quat.rotate(fs.q_WB, [0.0, 0, 1]), cam.centre_W - fs.wrist) > 0
    inside = (wrist_px[:, 0] >= 0) & (wrist_px[:, 0] < s.width) & (wrist_px[:, 1] >= 0) & (
        wrist_px[:, 1] < s.height)
    return {
        "t": ds.t - ds.t[0], "shoulder": ds.shoulder, "elbow": ds.elbow, "wrist": ds.wrist,
        "wrist_vel": ds.wrist_vel, "elbow_vel": ds.elbow_vel, "wrist_acc": ds.wrist_acc,
        "q_WB": ds.q_WB, "omega_B": ds.omega_B,
        "frame_t": fs.t - fs.t[0], "frame_wrist": fs.wrist, "frame_elbow": fs.elbow,
        "frame_shoulder": fs.shoulder, "frame_q_WB": fs.q_WB, "frame_wrist_px": wrist_px,
        "frame_patch_visible": facing & inside, "frame_occluded": np.zeros(fs.t.size, bool),
        "distractor_px": np.full(2, np.nan),
        "imu_t_session": imu["t"] + s.imu_offset_s, "imu_q_true": st.q_WB,
        "acc_bias": meas["acc_bias"], "gyro_bias": meas["gyro_bias"],
        "acc_scale": meas["acc_scale"],
        "imu_offset_s": s.imu_offset_s, "groundtruth_offset_s": s.groundtruth_offset_s,
        "to_world": QTM_TO_WORLD, "K": cam.K, "dist": cam.dist, "R_WC": cam.R_WC,
        "T_WC": cam.T_WC, "arm": np.r_[s.shoulder, s.upper_arm_m, s.forearm_m],
        "lab_to_world": T_WL,
    }
