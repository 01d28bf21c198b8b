"""A whole simulated arm session (Tao & Hu set-up): kinematics, IMU, camera, Qualisys, truth.

Pure: returns arrays, the session.toml text and a frame generator; the pipeline writes them.
Clocks (SESSION_FORMAT.md): the session clock is the video's; the IMU starts before the
camera (imu_offset_s < 0) and Qualisys earlier still (groundtruth_offset_s < 0).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from armtrack_cli.core import quaternion as quat
from armtrack_cli.core.streams import CameraModel
from armtrack_cli.simulate import distractors, imu_model, kinematics, render
from armtrack_cli.simulate.camera import default_camera, project
from armtrack_cli.simulate.capture import (
    QTM_TO_WORLD,
    CameraNoise,
    CaptureSettings,
    qualisys_markers,
    to_world_toml,
)
from armtrack_cli.vision.charuco import make_board

BOARD = {"squares": (7, 5), "square_m": 0.04, "marker_m": 0.03, "dictionary": "DICT_4X4_50"}
PATCH_BGR = (25, 35, 225)  # saturated red-orange
PATCH_HSV = ((170, 140, 90), (10, 255, 255))  # wraps through red
DISTRACTOR_W = np.array([0.50, 0.30, 0.0])
QTM_NAMES = ["R_SHO", "R_ELB", "R_WRI"]


@dataclass(frozen=True)
class ArmSimSettings(CaptureSettings):
    task: str = "circle"
    imu_rate_hz: float = 100.0
    imu_preset: str = "mtw"
    imu_errors: dict = field(default_factory=dict)  # overrides of ImuErrors fields
    drop_rate: float = 0.0  # fraction of IMU packets dropped (in short bursts)
    forearm_axis: str = "+y"
    distractor: bool = False
    moving_distractor: bool = False  # the other arm in a sleeve of the patch's hue (distractors.py)
    clutter: bool = False  # objects of many colours on the table
    occlusions: tuple[tuple[float, float], ...] = ()  # (start s, duration s) of a card over the patch
    imu_offset_s: float = -1.0  # session time = IMU time + offset
    recorded: str = "2026-11-20T10:15:00"  # session.toml [session] recorded (local time)
    declare_imu_offset: bool = True  # False writes imu_offset_s = "auto" (truth keeps the value)
    shoulder: tuple[float, float, float] = (0.12, 0.58, 0.30)
    upper_arm_m: float = 0.31
    forearm_m: float = 0.27
    centre: tuple[float, float, float] = (0.26, 0.25, 0.07)
    size_m: float = 0.10
    calibration_s: float = 0.0  # the calibration movement after the first rest (0: none;
    #                             simulate/calibration_move.py), within duration_s


@dataclass(frozen=True)
class ArmSimulation:
    settings: ArmSimSettings
    camera: CameraModel
    imu: dict  # t (stream clock), acc, gyr, quat, and the error draws
    qualisys: dict  # t (QTM clock), xyz (N, 3 markers, 3) in the QTM frame, m, NaN gaps
    truth: dict
    scene: render.Scene
    frame_t: np.ndarray
    occluded: np.ndarray  # (n_frames,) bool

    def frames(self) -> Iterator[tuple[int, np.ndarray]]:
        """(index, BGR image) of every video frame, rendered on demand."""
        s, tr = self.settings, self.truth
        camera_noise = CameraNoise(s.seed, s.height, s.width)
        for i in range(self.frame_t.size):
            gain, noise = camera_noise(self.frame_t[i])
            img, _ = render.draw_frame(
                self.scene, shoulder=tr["frame_shoulder"][i], elbow=tr["frame_elbow"][i],
                wrist=tr["frame_wrist"][i], q_WB=tr["frame_q_WB"][i],
                forearm_unit_B=_axis_unit(s.forearm_axis),
                distractor_W=DISTRACTOR_W if s.distractor else None,
                occluder=bool(self.occluded[i]), gain=gain, noise=noise,
                other_arm=(tr["frame_other_elbow"][i], tr["frame_other_wrist"][i])
                if s.moving_distractor else None)
            yield i, img


def _axis_unit(axis: str) -> np.ndarray:
    v = np.zeros(3)
    v["xyz".index(axis[1])] = 1.0 if axis[0] == "+" else -1.0
    return v


def _other_arm(s: ArmSimSettings, scene: render.Scene, fs, frame_t: np.ndarray) -> dict:
    """Truth of the other arm (frame_other_*: elbow, wrist in W, wrist pixel) and the share of
    the patch it hides in each frame (frame_patch_covered); none without it."""
    if not s.moving_distractor:
        return {}
    elbow, wrist = distractors.other_arm(frame_t, np.array(s.centre),
                                         np.random.default_rng([s.seed, 37]))
    covered = np.array([render.patch_covered(scene, fs.wrist[i], fs.q_WB[i], (elbow[i], wrist[i]))
                        for i in range(frame_t.size)])
    return {"frame_other_elbow": elbow, "frame_other_wrist": wrist,
            "frame_other_wrist_px": project(scene.cam, wrist)[0], "frame_patch_covered": covered}


def _drops(n: int, rate: float, rng: np.random.Generator) -> np.ndarray:
    """Keep-mask with about ``rate`` of the samples lost in bursts of 1-5 packets."""
    keep = np.ones(n, bool)
    lost = 0
    while lost < rate * n:
        k, length = int(rng.integers(10, n - 10)), int(rng.integers(1, 6))
        keep[k:k + length] = False
        lost = int((~keep).sum())
    return keep


def simulate_arm(s: ArmSimSettings) -> ArmSimulation:
    rng = np.random.default_rng(s.seed)
    arm = kinematics.ArmGeometry(np.array(s.shoulder), s.upper_arm_m, s.forearm_m)
    if s.calibration_s and s.duration_s - s.calibration_s < 2 * kinematics.REST_S + 1.0:
        raise ValueError(f"a {s.duration_s:g} s session has no room for the task after a "
                         f"{s.calibration_s:g} s calibration movement")
    task = kinematics.Task(s.task, s.duration_s, np.array(s.centre), s.size_m,
                           calibration_s=s.calibration_s)
    cam = default_camera(width=s.width, height=s.height,
                         k1=-0.12 if s.distortion else 0.0, k2=0.03 if s.distortion else 0.0)
    # --- camera frames (the session clock)
    frame_t = np.arange(int(round(s.duration_s * s.fps))) / s.fps
    fs = kinematics.arm_state(arm, task, frame_t, s.forearm_axis)
    occluded = np.zeros(frame_t.size, bool)
    for start, dur in s.occlusions:
        occluded |= (frame_t >= start) & (frame_t < start + dur)
    # --- IMU on its own clock: session time = stream time + offset
    errors = imu_model.ImuErrors.preset(s.imu_preset).override(**s.imu_errors)
    n_imu = int(np.floor((s.duration_s - s.imu_offset_s + 0.5) * s.imu_rate_hz))
    t_stream = np.arange(n_imu) / s.imu_rate_hz
    t_sess = t_stream + s.imu_offset_s
    st = kinematics.arm_state(arm, task, t_sess - errors.latency_s, s.forearm_axis)
    meas = imu_model.measure(t_sess, st.q_WB, st.wrist_acc, st.omega_B, errors, s.imu_rate_hz, rng)
    keep = _drops(n_imu, s.drop_rate, rng) if s.drop_rate > 0 else np.ones(n_imu, bool)
    imu = {"t": t_stream[keep], "acc": meas["acc"][keep], "gyr": meas["gyr"][keep],
           "quat": meas["quat"][keep]}
    # --- Qualisys on its own clock, in its own frame, mm noise, optional gaps
    n_q = int(np.floor((s.duration_s - s.groundtruth_offset_s + 0.5) * s.qualisys_hz))
    tq = np.arange(n_q) / s.qualisys_hz
    qs = kinematics.arm_state(arm, task, tq + s.groundtruth_offset_s, s.forearm_axis)
    xyz_q = qualisys_markers(np.stack([qs.shoulder, qs.elbow, qs.wrist], 1), s.marker_noise_m,
                             s.gt_gaps, 2, s.qualisys_hz, rng)
    # --- scene and truth
    board = make_board(BOARD["squares"], BOARD["square_m"], BOARD["marker_m"],
                          BOARD["dictionary"])
    scene = render.build_scene(cam, board, BOARD["square_m"], PATCH_BGR, rng,
                               (*PATCH_HSV, np.random.default_rng([s.seed, 31]))
                               if s.clutter else None)
    other = _other_arm(s, scene, fs, frame_t)
    wrist_px, _ = project(cam, fs.wrist)
    eye = cam.centre_W
    facing = np.einsum("ni,ni->n", quat.rotate(fs.q_WB, [0.0, 0, 1]), eye - fs.wrist) > 0
    inside = (wrist_px[:, 0] >= 0) & (wrist_px[:, 0] < s.width) & (wrist_px[:, 1] >= 0) & (
        wrist_px[:, 1] < s.height)
    dense_t = np.arange(int(round((s.duration_s + 0.5) * 200))) / 200.0
    ds = kinematics.arm_state(arm, task, dense_t, s.forearm_axis)
    truth = {
        "t": dense_t, "shoulder": ds.shoulder, "elbow": ds.elbow, "wrist": ds.wrist,
        "wrist_vel": ds.wrist_vel, "elbow_vel": ds.elbow_vel, "wrist_acc": ds.wrist_acc,
        "q_WB": ds.q_WB, "omega_B": ds.omega_B,
        "frame_t": frame_t, "frame_wrist": fs.wrist, "frame_elbow": fs.elbow,
        "frame_shoulder": fs.shoulder, "frame_q_WB": fs.q_WB, "frame_wrist_px": wrist_px,
        "frame_patch_visible": facing & inside & ~occluded & (
            other.get("frame_patch_covered", np.zeros(frame_t.size)) == 0),
        "frame_occluded": occluded, **other,
        "distractor_px": project(cam, DISTRACTOR_W[None])[0][0] if s.distractor else
        np.full(2, np.nan),
        "imu_t_session": imu["t"] + s.imu_offset_s, "imu_q_true": st.q_WB[keep],
        "acc_bias": meas["acc_bias"], "gyro_bias": meas["gyro_bias"],
        "acc_scale": meas["acc_scale"],
        "imu_offset_s": s.imu_offset_s, "groundtruth_offset_s": s.groundtruth_offset_s,
        "to_world": QTM_TO_WORLD, "K": cam.K, "dist": cam.dist, "R_WC": cam.R_WC,
        "T_WC": cam.T_WC, "arm": np.r_[s.shoulder, s.upper_arm_m, s.forearm_m],
    }
    return ArmSimulation(s, cam, imu, {"t": tq, "xyz": xyz_q, "names": QTM_NAMES}, truth, scene,
                         frame_t, occluded)


def session_toml(s: ArmSimSettings, *, session_id: str, imu_file: str, command: str,
                 side: str = "right") -> str:
    """session.toml for a simulated arm session, in the contract's layout."""
    imu_off = f"{s.imu_offset_s:g}" if s.declare_imu_offset else '"auto"'
    lo, hi = PATCH_HSV
    b = BOARD
    return "\n".join([
        f"# simulated by: {command}",
        "[session]", f'id = "{session_id}"', 'subject = "SIM"', f"recorded = {s.recorded}",
        f'task = "{s.task}"', f'side = "{side}"', "",
        "[arm]", f"upper_arm_m = {s.upper_arm_m:g}", f"forearm_m = {s.forearm_m:g}",
        "shoulder_m = [" + ", ".join(f"{v:g}" for v in s.shoulder) + "]", "",
        "[camera]", 'video = "video.mp4"',
        'intrinsics = "calib/"' if s.calib_images else 'intrinsics = "intrinsics.yaml"',
        f'board = {{ type = "charuco", squares = [{b["squares"][0]}, {b["squares"][1]}], '
        f'square_m = {b["square_m"]:g}, marker_m = {b["marker_m"]:g}, '
        f'dictionary = "{b["dictionary"]}" }}',
        f"patch = {{ hsv_low = [{lo[0]}, {lo[1]}, {lo[2]}], hsv_high = [{hi[0]}, {hi[1]}, {hi[2]}] }}",
        "", "[imu]", f'file = "{imu_file}"', f'forearm_axis = "{s.forearm_axis}"', "",
        "[groundtruth]", 'file = "qualisys.tsv"',
        'markers = { shoulder = "R_SHO", elbow = "R_ELB", wrist = "R_WRI" }',
        f"to_world = {to_world_toml()}", "",
        "[sync]", f"imu_offset_s = {imu_off}", f"groundtruth_offset_s = {s.groundtruth_offset_s:g}",
        ""])
