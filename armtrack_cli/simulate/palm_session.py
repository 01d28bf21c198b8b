"""A whole simulated palm session (Cordella set-up): a right hand with six blue markers under
an RGB-D camera looking down from about 0.65 m, a blue clutter blob, depth frames, Qualisys on
the palm markers, and the exact truth (wrist pose, wrist angles, which blob is which marker)."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from armtrack_cli.core import quaternion as quat
from armtrack_cli.core.streams import CameraModel
from armtrack_cli.simulate import hand, render
from armtrack_cli.simulate.arm_session import BOARD
from armtrack_cli.simulate.camera import default_camera, project
from armtrack_cli.simulate.capture import (
    CameraNoise,
    CaptureSettings,
    qualisys_markers,
    to_world_toml,
)
from armtrack_cli.simulate.render_hand import draw_hand
from armtrack_cli.vision.charuco import make_board

CLUTTER_W = np.array([0.56, 0.02, 0.0])
COLOUR_HSV = ((100, 150, 60), (130, 255, 255))


@dataclass(frozen=True)
class PalmSimSettings(CaptureSettings):
    task: str = "wrist-rom"
    clutter: bool = True
    hide: tuple[tuple[int, float, float], ...] = ()  # (marker index, start s, duration s)


@dataclass(frozen=True)
class PalmSimulation:
    settings: PalmSimSettings
    camera: CameraModel
    qualisys: dict
    truth: dict
    scene: render.Scene
    palm_H: np.ndarray

    def frames(self) -> Iterator[tuple[int, np.ndarray, np.ndarray]]:
        """(index, BGR image, depth in m with NaN holes) for every frame, on demand."""
        s, tr = self.settings, self.truth
        noise = CameraNoise(s.seed, s.height, s.width)
        depth_rng = np.random.default_rng([s.seed, 11])
        for i, t in enumerate(tr["frame_t"]):
            gain, n = noise(t)
            hidden = tuple(k for k, a, d in s.hide if a <= t < a + d)
            img, _, depth = draw_hand(self.scene, wrist=tr["frame_wrist"][i], q_WH=tr["frame_q_WH"][i],
                                      q_WF=tr["q_WF"], palm_H=self.palm_H,
                                      clutter_W=CLUTTER_W if s.clutter else None, hidden=hidden,
                                      gain=gain, noise=n, rng=depth_rng)
            yield i, img, depth


def _omega_H(motion: hand.HandMotion, t: np.ndarray, h: float = 1e-3) -> np.ndarray:
    """Angular rate of H in H (rad/s): 2 vec(q* ⊗ q̇), q̇ by a 5-point central difference."""
    w = np.array([1, -8, 0, 8, -1]) / (12 * h)
    qs = np.stack([motion.q_WH(t + k * h) for k in range(-2, 3)])
    qdot = np.einsum("k,kni->ni", w, qs)
    return 2 * quat.multiply(quat.conjugate(qs[2]), qdot)[:, 1:]


def simulate_palm(s: PalmSimSettings) -> PalmSimulation:
    rng = np.random.default_rng(s.seed)
    motion = hand.default_motion(s.task, s.duration_s)
    cam = default_camera(width=s.width, height=s.height, k1=-0.08 if s.distortion else 0.0,
                         k2=0.02 if s.distortion else 0.0, eye=(0.34, -0.05, 0.66),
                         target=(0.34, 0.03, 0.0), focal_px=580.0)
    palm_H = hand.palm_model()
    frame_t = np.arange(int(round(s.duration_s * s.fps))) / s.fps
    wrist = motion.wrist(frame_t)
    q_WH = motion.q_WH(frame_t)
    markers_W = wrist[:, None, :] + np.einsum("nij,kj->nki", quat.to_matrix(q_WH), palm_H)
    px, _ = project(cam, markers_W.reshape(-1, 3))
    eye = cam.centre_W
    normal = quat.rotate(q_WH, [0.0, 0, 1])
    facing = np.einsum("ni,nki->nk", normal, eye - markers_W) > 0
    hidden = np.zeros_like(facing)
    for k, a, d in s.hide:
        hidden[(frame_t >= a) & (frame_t < a + d), k] = True
    n_q = int(np.floor((s.duration_s - s.groundtruth_offset_s + 0.5) * s.qualisys_hz))
    tq = np.arange(n_q) / s.qualisys_hz + s.groundtruth_offset_s
    mq = motion.wrist(tq)[:, None, :] + np.einsum("nij,kj->nki", quat.to_matrix(motion.q_WH(tq)),
                                                  palm_H)
    xyz_q = qualisys_markers(mq, s.marker_noise_m, s.gt_gaps, 0, s.qualisys_hz, rng)
    board = make_board(BOARD["squares"], BOARD["square_m"], BOARD["marker_m"],
                          BOARD["dictionary"])
    scene = render.build_scene(cam, board, BOARD["square_m"], (0, 0, 255), rng)
    dense_t = np.arange(int(round((s.duration_s + 0.5) * 200))) / 200.0
    ang = np.rad2deg(motion.angles(frame_t))
    truth = {
        "t": dense_t, "wrist": motion.wrist(dense_t), "q_WH": motion.q_WH(dense_t),
        "angles_deg": np.rad2deg(motion.angles(dense_t)), "omega_H": _omega_H(motion, dense_t),
        "frame_t": frame_t, "frame_wrist": wrist, "frame_q_WH": q_WH,
        "frame_angles_deg": ang, "frame_markers_W": markers_W,
        "frame_marker_px": px.reshape(-1, len(palm_H), 2),
        "frame_marker_visible": facing & ~hidden, "marker_names": np.array(hand.MARKERS),
        "clutter_px": project(cam, CLUTTER_W[None])[0][0] if s.clutter else np.full(2, np.nan),
        "palm_H": palm_H, "q_WF": motion.q_WF, "groundtruth_offset_s": s.groundtruth_offset_s,
        "K": cam.K, "dist": cam.dist, "R_WC": cam.R_WC, "T_WC": cam.T_WC,
    }
    return PalmSimulation(s, cam, {"t": tq - s.groundtruth_offset_s, "xyz": xyz_q,
                                   "names": list(hand.MARKERS)}, truth, scene, palm_H)


def session_toml(s: PalmSimSettings, *, session_id: str, command: str) -> str:
    lo, hi = COLOUR_HSV
    b = BOARD
    markers = ", ".join(f'"{m}"' for m in hand.MARKERS)
    named = ", ".join(f'{m} = "{m}"' for m in hand.MARKERS)
    return "\n".join([
        f"# simulated by: {command}",
        "[session]", f'id = "{session_id}"', 'subject = "SIM"', "recorded = 2026-11-20T10:15:00",
        f'task = "{s.task}"', 'side = "right"', "",
        "[camera]", 'video = "video.mp4"',
        'intrinsics = "calib/"' if s.calib_images else 'intrinsics = "intrinsics.yaml"',
        f'board = {{ type = "charuco", squares = [{b["squares"][0]}, {b["squares"][1]}], '
        f'square_m = {b["square_m"]:g}, marker_m = {b["marker_m"]:g}, '
        f'dictionary = "{b["dictionary"]}" }}', "",
        "[palm]", f"markers = [{markers}]",
        "link_m = [" + ", ".join(f"{v:g}" for v in hand.LINKS_M) + "]",
        f"colour = {{ hsv_low = [{lo[0]}, {lo[1]}, {lo[2]}], hsv_high = [{hi[0]}, {hi[1]}, {hi[2]}] }}",
        "", "[groundtruth]", 'file = "qualisys.tsv"', f"markers = {{ {named} }}",
        f"to_world = {to_world_toml()}", "",
        "[sync]", f"groundtruth_offset_s = {s.groundtruth_offset_s:g}", ""])
