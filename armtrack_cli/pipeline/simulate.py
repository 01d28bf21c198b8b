"""Simulated sessions written to disk: the session folder and its truth beside it."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from armtrack_cli.core.streams import CameraModel
from armtrack_cli.session.camera_yaml import write_camera_yaml
from armtrack_cli.session.depth import depth_path, write_depth_png
from armtrack_cli.session.export.imu_csv import write_imu_csv
from armtrack_cli.session.export.mcap import write_imu_mcap
from armtrack_cli.session.export.qualisys import write_qtm_tsv
from armtrack_cli.session.export.video import write_video
from armtrack_cli.session.export.xsens import write_mt_manager
from armtrack_cli.session.images import write_image
from armtrack_cli.session.outputs import staged_folder, write_npz, write_text
from armtrack_cli.simulate import palm_session
from armtrack_cli.simulate.arm_session import BOARD, ArmSimSettings, session_toml, simulate_arm
from armtrack_cli.simulate.calib_images import board_images
from armtrack_cli.vision.charuco import make_board

IMU_FILES = {"xsens": "imu.txt", "csv": "imu.csv", "mcap": "imu.mcap"}


def _write_intrinsics(folder: Path, cam: CameraModel, settings) -> None:
    """intrinsics.yaml with the true camera, or calib/ board images to compute it from."""
    if not settings.calib_images:
        write_camera_yaml(folder / "intrinsics.yaml", CameraModel(cam.K, cam.dist, cam.width,
                                                                  cam.height))
        return
    board = make_board(BOARD["squares"], BOARD["square_m"], BOARD["marker_m"],
                          BOARD["dictionary"])
    rng = np.random.default_rng([settings.seed, 23])
    for k, img in enumerate(board_images(cam, board, settings.calib_images, rng)):
        write_image(folder / "calib" / f"{k:03d}.png", img)


def simulate_command(name: str, settings: ArmSimSettings, imu_format: str) -> str:
    """The canonical command line that regenerates a simulated session (non-defaults only)."""
    default = ArmSimSettings()
    parts = [f"armtrack simulate {name}"]
    flags = {"task": "--task", "seed": "--seed", "duration_s": "--duration", "fps": "--fps",
             "imu_rate_hz": "--imu-rate", "imu_preset": "--imu-preset", "drop_rate": "--drop-rate",
             "gt_gaps": "--gt-gaps", "calibration_s": "--calibration-movement"}
    for key, flag in flags.items():
        if getattr(settings, key) != getattr(default, key):
            parts.append(f"{flag} {getattr(settings, key):g}" if isinstance(
                getattr(settings, key), float) else f"{flag} {getattr(settings, key)}")
    if imu_format != "xsens":
        parts.append(f"--imu-format {imu_format}")
    if settings.calib_images:
        parts.append(f"--calib-images {settings.calib_images}")
    if settings.recorded != default.recorded:
        parts.append(f"--recorded {settings.recorded}")
    if settings.qualisys_hz != default.qualisys_hz:
        parts.append(f"--qualisys-hz {settings.qualisys_hz:g}")
    for k, v in sorted(settings.imu_errors.items()):
        parts.append(f"--{'orientation-error' if k == 'orientation_rms_deg' else k.replace('_', '-')}"
                     f" {v:g}")
    parts += [f"--occlusion {a:g}:{b:g}" for a, b in settings.occlusions]
    parts += [flag for flag, on in (("--distractor", settings.distractor),
                                    ("--moving-distractor", settings.moving_distractor),
                                    ("--clutter", settings.clutter),
                                    ("--no-distortion", not settings.distortion),
                                    ("--undeclared-imu-offset", not settings.declare_imu_offset))
              if on]
    return " ".join(parts)


def simulate(out: str | Path, settings, *, imu_format: str = "xsens",
             force: bool = False, on_frame=None) -> dict[str, Any]:
    """Write a simulated session folder OUT and its exact truth beside it (OUT.truth.npz).

    ``settings`` is an ArmSimSettings (Tao & Hu arm sessions) or a PalmSimSettings (Cordella
    palm-marker sessions with depth)."""
    out = Path(out)
    if isinstance(settings, palm_session.PalmSimSettings):
        return _simulate_palm(out, settings, force=force, on_frame=on_frame)
    return write_arm_session(out, simulate_arm(settings), imu_format=imu_format,
                             command=simulate_command(out.name, settings, imu_format),
                             force=force, on_frame=on_frame)


def write_arm_session(out: Path, sim, *, imu_format: str, command: str, force: bool,
                      on_frame=None, side: str = "right") -> dict[str, Any]:
    """An arm session folder from a simulation (synthetic task or recorded motion)."""
    settings = sim.settings
    imu_file = IMU_FILES[imu_format]
    with staged_folder(out, force=force) as tmp:
        write_text(tmp / "session.toml", session_toml(settings, session_id=out.name,
                                                      imu_file=imu_file, command=command,
                                                      side=side))
        _write_intrinsics(tmp, sim.camera, settings)
        i = sim.imu
        if imu_format == "xsens":
            write_mt_manager(tmp / imu_file, i["t"], i["acc"], i["gyr"], i["quat"],
                             rate_hz=settings.imu_rate_hz, counter_start=int(settings.seed * 977) % 65536,
                             stf_start=(settings.seed * 1234567) % 2**32)
        elif imu_format == "csv":
            write_imu_csv(tmp / imu_file, i["t"], i["acc"], i["gyr"], i["quat"])
        else:
            write_imu_mcap(tmp / imu_file, i["t"], i["acc"], i["gyr"], i["quat"])
        q = sim.qualisys
        write_qtm_tsv(tmp / "qualisys.tsv", q["xyz"], q["names"], settings.qualisys_hz)
        n = write_video(tmp / "video.mp4", sim.frames(), fps=settings.fps,
                        size=(settings.width, settings.height), on_frame=on_frame)
        write_npz(out.parent / f"{out.name}.truth.npz", sim.truth)
    return {"session": str(out), "truth": str(out.parent / f"{out.name}.truth.npz"),
            "frames": n, "imu_samples": int(i["t"].size), "qualisys_frames": int(q["t"].size),
            "task": settings.task, "seed": settings.seed}


def _simulate_palm(out: Path, settings, *, force: bool, on_frame) -> dict[str, Any]:
    sim = palm_session.simulate_palm(settings)
    cmd = f"armtrack simulate {out.name} --task {settings.task} --seed {settings.seed}" + (
        f" --duration {settings.duration_s:g}" if settings.duration_s != 20.0 else "") + (
        f" --calib-images {settings.calib_images}" if settings.calib_images else "") + "".join(
        f" --hide {k}:{a:g}:{d:g}" for k, a, d in settings.hide) + (
        f" --clutter2 {settings.clutter2_s:g}" if settings.clutter2_s is not None else "")
    with staged_folder(out, force=force) as tmp:
        write_text(tmp / "session.toml", palm_session.session_toml(settings, session_id=out.name,
                                                                   command=cmd))
        _write_intrinsics(tmp, sim.camera, settings)
        q = sim.qualisys
        write_qtm_tsv(tmp / "qualisys.tsv", q["xyz"], q["names"], settings.qualisys_hz)

        def frames():
            for i, img, depth in sim.frames():
                write_depth_png(depth_path(tmp, i), depth)
                yield i, img

        n = write_video(tmp / "video.mp4", frames(), fps=settings.fps,
                        size=(settings.width, settings.height), on_frame=on_frame)
        write_npz(out.parent / f"{out.name}.truth.npz", sim.truth)
    return {"session": str(out), "truth": str(out.parent / f"{out.name}.truth.npz"),
            "frames": n, "depth_frames": n, "qualisys_frames": int(q["t"].size),
            "task": settings.task, "seed": settings.seed}
