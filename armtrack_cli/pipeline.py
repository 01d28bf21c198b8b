"""The data flow on one screen: session -> calibrate -> detect -> fuse -> compare -> report.

Each stage is a function of arrays; this module reads its inputs through ``session`` (the
I/O layer), calls the stage and writes its outputs atomically into SESSION/armtrack/ (or
--out). Stages exchange files, so each can be run alone.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from armtrack_cli.core.errors import DataError
from armtrack_cli.core.streams import CameraModel
from armtrack_cli.session import info as session_info
from armtrack_cli.session.camera_yaml import write_camera_yaml
from armtrack_cli.session.config import load_session
from armtrack_cli.session.depth import depth_path, write_depth_png
from armtrack_cli.session.export_imu_csv import write_imu_csv
from armtrack_cli.session.export_mcap import write_imu_mcap
from armtrack_cli.session.export_qualisys import write_qtm_tsv
from armtrack_cli.session.export_video import write_video
from armtrack_cli.session.export_xsens import write_mt_manager
from armtrack_cli.session.imu import read_imu
from armtrack_cli.session.outputs import staged_folder, write_json, write_npz, write_text
from armtrack_cli.session.qualisys import read_qualisys
from armtrack_cli.session.video import probe_video
from armtrack_cli.simulate import palm_session
from armtrack_cli.simulate.arm_session import ArmSimSettings, session_toml, simulate_arm

VIDEO_EXT = (".mp4", ".avi", ".mkv", ".mov", ".m4v")


def info(path: str | Path, *, imu_rate_hz: float | None = None,
         out_dir: str | Path | None = None) -> dict[str, Any]:
    """Stage 0: what a session folder (or a single recorded file) holds."""
    path = Path(path)
    if path.is_dir():
        result = session_info.describe(load_session(path), imu_rate_hz=imu_rate_hz)
    elif path.is_file():
        result = _info_file(path, imu_rate_hz)
    else:
        raise DataError(path, "not found", "give a session folder or a recorded file")
    if out_dir is not None:
        write_json(Path(out_dir) / "info.json", result)
    return result


def _info_file(path: Path, imu_rate_hz: float | None) -> dict[str, Any]:
    """A lone file: a Qualisys TSV, a video, or an IMU export (told apart by content)."""
    out: dict[str, Any] = {"session": {"folder": str(path.parent), "id": path.name, "subject": None,
                                       "task": None, "side": "right", "kind": "file",
                                       "recorded": None}, "methods": {}}
    suffix = path.suffix.lower()
    if suffix == ".tsv":
        out["groundtruth"] = session_info.describe_markers(read_qualisys(path), 0.0)
    elif suffix in VIDEO_EXT:
        v = probe_video(path)
        out["video"] = {"file": v.path, "source": v.source, "frames": v.n_frames, "fps": v.fps,
                        "width": v.width, "height": v.height,
                        "duration_s": round(float(v.t[-1]), 4), "span_s": [0.0, float(v.t[-1])],
                        "times_from": v.timestamps_from}
    else:
        s = read_imu(path, rate_hz=imu_rate_hz)
        out["imu"] = session_info.describe_imu(s, 0.0)
        out["imu"]["forearm_axis"] = "+y"
    return out


format_info = session_info.format_text


IMU_FILES = {"xsens": "imu.txt", "csv": "imu.csv", "mcap": "imu.mcap"}


def simulate_command(name: str, settings: ArmSimSettings, imu_format: str) -> str:
    """The canonical command line that regenerates a simulated session (non-defaults only)."""
    default = ArmSimSettings()
    parts = [f"armtrack simulate {name}"]
    flags = {"task": "--task", "seed": "--seed", "duration_s": "--duration", "fps": "--fps",
             "imu_rate_hz": "--imu-rate", "imu_preset": "--imu-preset", "drop_rate": "--drop-rate",
             "gt_gaps": "--gt-gaps"}
    for key, flag in flags.items():
        if getattr(settings, key) != getattr(default, key):
            parts.append(f"{flag} {getattr(settings, key):g}" if isinstance(
                getattr(settings, key), float) else f"{flag} {getattr(settings, key)}")
    if imu_format != "xsens":
        parts.append(f"--imu-format {imu_format}")
    if settings.qualisys_hz != default.qualisys_hz:
        parts.append(f"--qualisys-hz {settings.qualisys_hz:g}")
    for k, v in sorted(settings.imu_errors.items()):
        parts.append(f"--{'orientation-error' if k == 'orientation_rms_deg' else k.replace('_', '-')}"
                     f" {v:g}")
    parts += [f"--occlusion {a:g}:{b:g}" for a, b in settings.occlusions]
    parts += [flag for flag, on in (("--distractor", settings.distractor),
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
    sim = simulate_arm(settings)
    imu_file = IMU_FILES[imu_format]
    with staged_folder(out, force=force) as tmp:
        write_text(tmp / "session.toml", session_toml(settings, session_id=out.name,
                                                      imu_file=imu_file,
                                                      command=simulate_command(out.name, settings,
                                                                               imu_format)))
        cam = sim.camera
        write_camera_yaml(tmp / "intrinsics.yaml", CameraModel(cam.K, cam.dist, cam.width,
                                                               cam.height))
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
        f" --duration {settings.duration_s:g}" if settings.duration_s != 20.0 else "")
    with staged_folder(out, force=force) as tmp:
        write_text(tmp / "session.toml", palm_session.session_toml(settings, session_id=out.name,
                                                                   command=cmd))
        cam = sim.camera
        write_camera_yaml(tmp / "intrinsics.yaml", CameraModel(cam.K, cam.dist, cam.width,
                                                               cam.height))
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
