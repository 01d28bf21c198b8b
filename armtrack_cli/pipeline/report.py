"""`armtrack report`: the clinician PDF of one session, or of several of one subject.

Reads what the earlier stages left in each work folder (trajectory, measures, errors, camera
and detections), the session's IMU and ground truth for the quality checks and the error
plots, hands plain data to ``armtrack_cli.report`` and writes report.pdf atomically."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from armtrack_cli.compare.errors import truth_at
from armtrack_cli.core.errors import ArmtrackError, ConfigError
from armtrack_cli.pipeline import arm_model
from armtrack_cli.pipeline.common import out_dir
from armtrack_cli.pipeline.coverage import tracked, video_frames
from armtrack_cli.report import Quality, SessionReport, render
from armtrack_cli.report.quality import coverage, verdict
from armtrack_cli.session.camera_yaml import read_camera_yaml
from armtrack_cli.session.config import Session, load_session
from armtrack_cli.session.imu import read_imu
from armtrack_cli.session.info import describe_imu
from armtrack_cli.session.outputs import write_bytes
from armtrack_cli.session.qualisys import read_qualisys, select_markers, to_world
from armtrack_cli.session.tables import read_csv_table, read_kinematics, read_measures, read_trajectory
from armtrack_cli.session.workfolder import WorkFolder

PREFERENCE = {"palm": ("ukf-palm",), "arm": ("arm-smoother", "pf-constraint", "pf", "ukf", "ekf", "inertial"),
              "object": ("pf", "ukf", "ekf", "inertial")}


def _method(work: WorkFolder, kind: str) -> str | None:
    return next(iter(work.trajectories(PREFERENCE[kind])), None)


def _quality(session: Session, work: WorkFolder, notes: list[str]) -> Quality:
    q: dict[str, Any] = {"imu_offset_s": None}
    q["tracked_pct"], q["frames"] = tracked(work, session.kind,
                                            video_frames(session) if session.kind == "palm" else 0)
    if work.has("camera.yaml"):
        err = read_camera_yaml(work / "camera.yaml").reprojection_error_px
        q["reprojection_px"] = float("nan") if err is None else err
    if session.imu is not None:
        try:
            d = describe_imu(read_imu(session.imu.file, rate_hz=session.imu.rate_hz,
                                      topic=session.imu.topic), session.sync.imu_offset_s)
            q.update(imu_dropped=d["dropped_samples"], imu_gaps=d["gaps"], imu_samples=d["samples"],
                     imu_longest_gap_s=d["largest_gap_s"])
        except ArmtrackError as exc:
            notes.append(f"the motion-sensor file could not be read ({exc.problem})")
        q["imu_offset_s"] = session.sync.imu_offset_s
    if session.groundtruth is not None:
        q["groundtruth_offset_s"] = session.sync.groundtruth_offset_s
    return Quality(**q)


def _truth(session: Session, traj: pd.DataFrame, notes: list[str]) -> np.ndarray | None:
    """The reference wrist (or WRIST palm marker) at the trajectory's frames, in W."""
    gt = session.groundtruth
    role = "WRIST" if session.kind == "palm" else "wrist"
    if gt is None or role not in gt.markers or isinstance(session.sync.groundtruth_offset_s, str):
        return None
    try:
        qtm = read_qualisys(gt.file)
        c = select_markers(qtm, {role: gt.markers[role]}, session.toml_path)[role]
    except ArmtrackError as exc:
        notes.append(f"the reference motion capture could not be read ({exc.problem})")
        return None
    xyz = to_world(qtm.xyz[:, c], gt.to_world)
    return truth_at(traj["t"].to_numpy(), qtm.t + session.sync.groundtruth_offset_s, xyz,
                    qtm.rate_hz)


def gather(path: str | Path, out: str | Path | None = None) -> SessionReport:
    """Everything one session's pages show, from its work folder."""
    session = load_session(path)
    work = WorkFolder(out_dir(session, out))
    session = arm_model.resolved(session, work.path)
    kind = session.kind
    method = _method(work, kind)
    notes: list[str] = []
    traj = kin = errors = measures = truth = None
    if method is None:
        notes.append("no wrist-pose estimate in this work folder" if kind == "palm"
                     else "no movement estimate in this work folder")
    else:
        traj = read_trajectory(work / f"trajectory-{method}.csv")
        if work.has(f"kinematics-{method}.csv"):
            kin = read_kinematics(work / f"kinematics-{method}.csv")
        truth = _truth(session, traj, notes)
    if work.has("errors.csv"):
        errors = read_csv_table(work / "errors.csv", ("method", "joint", "axis"), "")
    if method and work.has("measures.csv"):
        m = read_measures(work / "measures.csv")
        m = m[m["method"] == method]
        measures = m if len(m) else None
    meta = session.meta
    return SessionReport(
        session_id=meta.id, subject=meta.subject or "not stated", date=meta.recorded or "",
        task=meta.task or "", side=meta.side, kind=kind, method=method, trajectory=traj,
        kinematics=kin, quality=_quality(session, work, notes),
        shoulder=None if session.arm is None else np.asarray(session.arm.shoulder_m, float),
        truth_wrist=truth, errors=errors if method else None, measures=measures,
        notes=tuple(notes))


def report(sessions: list[tuple[str | Path, str | Path | None]], *,
           output: str | Path | None = None) -> dict[str, Any]:
    """sessions: (session folder, work folder or None) pairs. One subject only."""
    reports = [gather(p, o) for p, o in sessions]
    subjects = sorted({r.subject for r in reports})
    if len(subjects) > 1:
        raise ConfigError(sessions[0][0], f"the sessions are of different subjects "
                          f"({', '.join(subjects)})", "report one subject at a time")
    if output is None:
        last = max(range(len(reports)), key=lambda i: (reports[i].date, reports[i].session_id))
        output = out_dir(load_session(sessions[last][0]), sessions[last][1]) / "report.pdf"
    pdf = render(reports)
    write_bytes(output, pdf)
    return {"report": str(output), "sessions": [r.session_id for r in reports],
            "methods": {r.session_id: r.method for r in reports}, "bytes": len(pdf),
            "verdicts": {r.session_id: _verdict(r) for r in reports}}


def _verdict(r: SessionReport) -> dict[str, Any]:
    """Page 1's verdict for a script: "good" | "usable with care" | "not usable", its reasons,
    and the span the measures cover (s; null without measures)."""
    v, reasons = verdict(r)
    c = coverage(r)
    return {"verdict": v, "reasons": reasons,
            "measured_s": None if c is None else round(c[1] - c[0], 3),
            "recorded_s": None if c is None else round(c[2], 3)}
