"""`armtrack info`: what a session holds, read from its files, as a plain dict.

Streams, rates, durations, spans on the session clock, gaps and dropped packets, markers,
board, and what each method still needs. Reading every stream also validates it, so a
malformed file stops here with a clear error.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from armtrack_cli.core.errors import ConfigError, DataError
from armtrack_cli.core.methods import BUILT, NEEDS
from armtrack_cli.core.streams import ImuSamples, MarkerTrajectories, VideoStream, time_gaps
from armtrack_cli.session.arm_file import read_arm_estimate
from armtrack_cli.session.camera_yaml import read_camera_yaml
from armtrack_cli.session.config import Session, load_session
from armtrack_cli.session.depth import count_depth_frames
from armtrack_cli.session.groundtruth import read_markers
from armtrack_cli.session.images import IMAGE_EXT
from armtrack_cli.session.imu import missing_channels, read_imu
from armtrack_cli.session.qualisys import to_world
from armtrack_cli.session.video import probe_video

Check = Callable[[Session, MarkerTrajectories, MarkerTrajectories | None], list]


def _span(t: np.ndarray, offset: float | str) -> list[float] | str:
    """[first, last] sample on the session clock: session time = stream time + offset."""
    if isinstance(offset, str):
        return "unknown until synchronised (offset = \"auto\")"
    return [round(float(t[0]) + offset, 6), round(float(t[-1]) + offset, 6)]


def describe_imu(s: ImuSamples, offset: float | str) -> dict[str, Any]:
    gaps = time_gaps(s.t, 1.0 / s.rate_hz)
    empty = [f"{n}_{a}" for n, arr in (("acc", s.acc), ("gyr", s.gyr)) for a, col in
             zip("xyz", arr.T) if np.isnan(col).all()]
    return {
        "file": s.path, "format": s.fmt, "samples": s.n, "rate_hz": round(s.rate_hz, 4),
        "duration_s": round(s.duration_s, 4), "span_s": _span(s.t, offset),
        "dropped_samples": s.dropped, "gaps": int(gaps.size),
        "largest_gap_s": round(float(np.diff(s.t).max()), 4) if s.n > 1 else 0.0,
        "orientation": s.orientation_source, "magnetometer": s.mag is not None,
        "accelerometer": bool(np.isfinite(s.acc).any()),
        "gyroscope": bool(np.isfinite(s.gyr).any()),
        "missing_for_fusion": missing_channels(s),
        "empty_channels": empty, "notes": list(s.notes),
    }


def describe_video(v: VideoStream) -> dict[str, Any]:
    end = float(v.t[-1]) if v.n_frames else 0.0
    return {"file": v.path, "source": v.source, "frames": v.n_frames, "fps": round(v.fps, 4),
            "width": v.width, "height": v.height, "duration_s": round(end, 4),
            "span_s": [0.0, round(end, 6)], "times_from": v.timestamps_from}


def describe_markers(m: MarkerTrajectories, offset: float | str) -> dict[str, Any]:
    missing = np.isnan(m.xyz[..., 0])
    return {
        "file": m.path, ("bodies" if m.rotations is not None else "markers"): list(m.names),
        "rate_hz": m.rate_hz, "frames": int(m.t.size),
        "duration_s": round(float(m.t[-1] - m.t[0]), 4),
        "span_s": _span(m.t, offset),
        "missing_pct": {n: round(100.0 * float(missing[:, k].mean()), 2)
                        for k, n in enumerate(m.names)},
        "notes": list(m.notes),
    }


def check_reach(session: Session, traj: MarkerTrajectories, cols: dict[str, int]) -> dict | None:
    """Distances from the declared shoulder to the ground-truth wrist, against L1 + L2."""
    if session.arm is None or "wrist" not in cols:
        return None
    wrist = to_world(traj.xyz[:, cols["wrist"]], session.groundtruth.to_world)
    d = np.linalg.norm(wrist - session.arm.shoulder_m, axis=1)
    d = d[np.isfinite(d)]
    if d.size == 0:
        return None
    reach = session.arm.upper_arm_m + session.arm.forearm_m
    if d.min() > reach + 0.02:
        raise ConfigError(session.toml_path,
                          f"[arm] shoulder_m = {session.arm.shoulder_m.tolist()} is farther than "
                          f"L1 + L2 = {reach:.3f} m from every ground-truth wrist sample (nearest "
                          f"{d.min():.3f} m)",
                          "check shoulder_m is in W (metres, board frame, z up) and the lengths")
    return {"reach_m": round(reach, 4), "wrist_distance_m": [round(float(d.min()), 4),
                                                            round(float(d.max()), 4)],
            "beyond_reach_pct": round(100.0 * float((d > reach + 0.01).mean()), 2)}


def describe_groundtruth(session: Session, check: Check | None) -> dict[str, Any]:
    """The ground-truth file (and static trial), the names [groundtruth] gives, and ``check``'s
    one line for each name the files lack."""
    gt = session.groundtruth
    m = read_markers(gt.file)
    static = read_markers(gt.static) if gt.static is not None else None
    problems = check(session, m, static) if check is not None else []
    out = describe_markers(m, session.sync.groundtruth_offset_s)
    out["named"] = dict(gt.markers)
    out["problems"] = [str(p) for p in problems]
    if static is not None:
        out["static"] = describe_markers(static, 0.0)
    seen = {r: m.names.index(e) for r, e in gt.markers.items() if e in m.names and e not in
            gt.clusters and np.isfinite(m.marker(e)).all(axis=1).any()}
    reach = check_reach(session, m, seen)
    if reach:
        out["reach"] = reach
    return out


def describe(session: Session, *, imu_rate_hz: float | None = None,
             check: Check | None = None) -> dict[str, Any]:
    """``check(session, trial, static)``: the problems of the names [groundtruth] gives (the
    caller's, which knows how compare finds them)."""
    out: dict[str, Any] = {"session": {
        "folder": str(session.root), "id": session.meta.id, "subject": session.meta.subject,
        "task": session.meta.task, "side": session.meta.side, "kind": session.kind,
        "recorded": session.meta.recorded}}
    have: set[str] = set()
    if session.imu is not None:
        s = read_imu(session.imu.file, rate_hz=session.imu.rate_hz or imu_rate_hz,
                     topic=session.imu.topic, field=session.imu.field, complete=False)
        out["imu"] = describe_imu(s, session.sync.imu_offset_s)
        out["imu"]["forearm_axis"] = session.imu.forearm_axis
        out["imu"]["offset_s"] = imu_offset(session)
        if not out["imu"]["missing_for_fusion"]:
            have.add("imu")
    cam = session.camera
    if cam is not None and cam.video is not None:
        out["video"] = describe_video(probe_video(cam.video))
        have.add("video")
        n_depth = count_depth_frames(session.root)
        if n_depth is not None:
            out["depth"] = {"folder": str(session.root / "depth"), "frames": n_depth}
            have.add("depth")
    if cam is not None and cam.intrinsics is not None:
        if cam.intrinsics.is_dir():
            imgs = [p for p in cam.intrinsics.iterdir() if p.suffix.lower() in IMAGE_EXT]
            out["intrinsics"] = {"folder": str(cam.intrinsics), "board_images": len(imgs),
                                 "note": "calibrate computes intrinsics from these"}
        else:
            K = read_camera_yaml(cam.intrinsics)
            out["intrinsics"] = {"file": str(cam.intrinsics), "fx": K.K[0, 0], "fy": K.K[1, 1],
                                 "cx": K.K[0, 2], "cy": K.K[1, 2], "distortion": K.dist.tolist(),
                                 "size": [K.width, K.height]}
        have.add("intrinsics")
    if cam is not None and cam.board is not None:
        b = cam.board
        out["board"] = {"type": b.type, "squares": list(b.squares), "square_m": b.square_m,
                        "marker_m": b.marker_m, "dictionary": b.dictionary}
        have.add("board")
    if cam is not None and cam.patch is not None:
        out["patch"] = {"hsv_low": list(cam.patch.low), "hsv_high": list(cam.patch.high)}
        have.add("patch")
    if session.arm is not None:
        a = session.arm
        out["arm"] = {k: "auto" if k in a.auto else v for k, v in (
            ("upper_arm_m", a.upper_arm_m), ("forearm_m", a.forearm_m),
            ("shoulder_m", a.shoulder_m.tolist()))}
        if a.auto:  # fuse's estimate in the default work folder, when it has run
            out["arm"]["estimate"] = read_arm_estimate(session.root / "armtrack")
        have.add("arm")
    if session.palm is not None:
        out["palm"] = {"markers": list(session.palm.markers), "link_m": list(session.palm.link_m)}
        have.add("palm")
    if session.groundtruth is not None:
        out["groundtruth"] = describe_groundtruth(session, check)
        have.add("groundtruth")
    lacks = {"imu": "an IMU with " + " and ".join(out["imu"]["missing_for_fusion"])} \
        if "imu" in out and "imu" not in have else {}
    out["methods"] = readiness(session, have, lacks)
    missing = len(out.get("groundtruth", {}).get("problems", []))
    if missing:
        out["methods"]["compare"] = (f"needs the {missing} name(s) [groundtruth] gives that the "
                                     "files lack (listed above)")
    return out


def imu_offset(session: Session) -> float | str | dict:
    """[sync] imu_offset_s as declared; for "auto", the newest estimate a fuse wrote beside
    its trajectory in the default work folder (value, SD, file), else "auto: estimated at
    fuse". Reads the sidecars only: info runs no filter."""
    declared = session.sync.imu_offset_s
    if declared != "auto":
        return declared
    metas = sorted(session.out_dir.glob("trajectory-*.meta.json"),
                   key=lambda m: m.stat().st_mtime) if session.out_dir.is_dir() else []
    for meta in reversed(metas):
        try:
            est = json.loads(meta.read_text())["settings"]["imu_offset_s"]
        except (OSError, ValueError, KeyError, TypeError):
            continue
        if isinstance(est, dict) and est.get("from") == "auto":
            return {"value": est["value"], "sd": est["sd"], "from": "auto", "file": str(meta)}
    return "auto: estimated at fuse"


def readiness(session: Session, have: set[str], lacks: dict[str, str] | None = None
              ) -> dict[str, str]:
    """For each command/method: 'ready' or what the session still lacks (``lacks`` words a
    requirement that is present but incomplete, e.g. an IMU export without accelerometer)."""
    out = {}
    lacks = lacks or {}
    for name, req in {**NEEDS, "compare": ("groundtruth",)}.items():
        lack = [lacks.get(r, r) for r in req if r not in have]
        out[name] = "ready" if not lack else "needs " + ", ".join(lack)
        if name in NEEDS and name not in BUILT and not lack:
            out[name] = "data ready; the method is not in this version yet"
    return out


def _head(path: Path, n: int = 32) -> bytes:
    """The first bytes of a file (a Vicon CSV starts with 'Trajectories')."""
    with open(path, "rb") as f:
        return f.read(n)


VIDEO_EXT = (".mp4", ".avi", ".mkv", ".mov", ".m4v")


def describe_path(path: Path, *, imu_rate_hz: float | None = None,
                  check: Check | None = None) -> dict[str, Any]:
    """A session folder, or a lone recorded file: a Qualisys TSV, a video or an IMU export."""
    path = Path(path)
    if path.is_dir():
        return describe(load_session(path), imu_rate_hz=imu_rate_hz, check=check)
    if not path.is_file():
        raise DataError(path, "not found", "give a session folder or a recorded file")
    out: dict[str, Any] = {"session": {"folder": str(path.parent), "id": path.name, "subject": None,
                                       "task": None, "side": "right", "kind": "file",
                                       "recorded": None}, "methods": {}}
    suffix = path.suffix.lower()
    if suffix in (".tsv", ".c3d") or suffix == ".csv" and _head(path).lstrip(
            b"\xef\xbb\xbf").lower().startswith(b"trajectories"):
        out["groundtruth"] = describe_markers(read_markers(path), 0.0)
    elif suffix in VIDEO_EXT:
        out["video"] = describe_video(probe_video(path))
    else:
        out["imu"] = describe_imu(read_imu(path, rate_hz=imu_rate_hz, complete=False), 0.0)
        out["imu"]["forearm_axis"] = "+y"
    return out
