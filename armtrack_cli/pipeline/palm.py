"""ukf-palm orchestration (Cordella et al.): files in through session/, the pure stages
fuse/palm_* and compare/palm, files out. pipeline/fuse.py and pipeline/compare.py dispatch
palm sessions here."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from armtrack_cli.compare import palm as cmp
from armtrack_cli.compare.errors import truth_at
from armtrack_cli.compare.score import Truth, lowpassed
from armtrack_cli.core.errors import ConfigError, DataError
from armtrack_cli.core.wrist import ANGLES
from armtrack_cli.core.wrist_measures import angular_speeds
from armtrack_cli.fuse.palm_init import depth_at, initial_pose
from armtrack_cli.fuse.palm_models import PalmUkfSettings, Rig
from armtrack_cli.fuse.palm_run import marker_area, track, trajectory_table
from armtrack_cli.measures.base import DEFAULT
from armtrack_cli.pipeline.kinematics import (
    kinematics_table,
    measure_comparison,
    trajectory_inputs,
    truth_inputs,
    truth_pose_inputs,
)
from armtrack_cli.session.camera_yaml import read_calibrated_camera
from armtrack_cli.session.config import Session, require
from armtrack_cli.session.depth import count_depth_frames, depth_path, read_depth_frame
from armtrack_cli.session.groundtruth import body_rotation_W, read_markers
from armtrack_cli.session.outputs import output_set, write_table
from armtrack_cli.session.palm_io import read_palm_blobs, read_palm_toml
from armtrack_cli.session.plain_tables import kinematics_rows
from armtrack_cli.session.qualisys import read_qualisys, select_markers, to_world
from armtrack_cli.session.recipe import section
from armtrack_cli.session.tables import read_trajectory
from armtrack_cli.session.video import probe_video

METHOD = "ukf-palm"


def measured_only(traj: pd.DataFrame) -> pd.DataFrame:
    """The trajectory with its rows flagged ``predicted_only`` (no marker usable: the filter's
    prediction, up to max_coast_s) emptied: the measures are taken over measured frames. A
    prediction through 0.9 s of lost markers while the wrist flexed went on to 87.5° (truth:
    45.1°), and the flexion range read 132.5° for a true 90.2°."""
    if "predicted_only" not in traj or not (traj["predicted_only"] == 1).any():
        return traj
    out = traj.copy()
    cols = [c for c in out.columns if c not in ("t", "markers_used", "predicted_only")]
    out.loc[out["predicted_only"] == 1, cols] = np.nan
    return out


def palm_kinematics(traj: pd.DataFrame, session: Session) -> pd.DataFrame:
    """kinematics-ukf-palm.csv: the measures package's table (RoM of each angle as max − min
    and 5th-95th percentile, path length, peak and mean speed, …) and each angle's peak and
    mean angular speed (core/wrist_measures.py) in the same shape, over measured frames."""
    traj = measured_only(traj)
    kin = kinematics_table(traj, session)
    t = traj["t"].to_numpy()
    ok = np.isfinite(t) & traj["wrist_x"].notna().to_numpy()
    span = (float(t[ok][0]), float(t[ok][-1])) if ok.any() else (np.nan, np.nan)
    rows = [{"measure": m, "segment": "session", "unit": u, "sd": np.nan,
             "value": f"{v:.6f}" if np.isfinite(v) else  # "nan" broke the contract and the report
             "not computable: no run of 3 or more frames with this angle",
             "t_start": span[0], "t_end": span[1]}
            for m, v, u in angular_speeds(t, traj[[f"{a}_deg" for a in ANGLES]].to_numpy())]
    return pd.concat([kin, pd.DataFrame(rows, columns=kin.columns)], ignore_index=True)


def _blob_depths(session: Session, blobs: list[np.ndarray], use: bool,
                 size: tuple[int, int]) -> list[np.ndarray]:
    """Each frame's blobs with a 4th column: the depth under them (m), NaN without a frame."""
    if use:
        count_depth_frames(session.root)  # PNGs misnamed: an error, not a run without depth
    out = []
    for i, b in enumerate(blobs):
        z = depth_at(read_depth_frame(session.root, i, size), b[:, :2]) if use and len(b) \
            else None
        out.append(np.c_[b, np.full(len(b), np.nan) if z is None else z])
    return out


def fuse_palm(session: Session, dest: Path, doc: dict, where: str) -> dict[str, Any]:
    """`armtrack fuse SESSION --method ukf-palm` -> trajectory-, kinematics-,
    associations-ukf-palm.csv."""
    if session.palm is None:
        raise ConfigError(session.toml_path, "has no [palm] section, which ukf-palm needs",
                          "ukf-palm tracks the six palm markers of a Cordella session")
    require(session, "camera", "video")
    s = section(doc, "ukf_palm", PalmUkfSettings, where)
    cam = read_calibrated_camera(dest / "camera.yaml")
    palm = read_palm_toml(dest / "palm.toml")
    video = probe_video(session.camera.video)
    if not 0 <= palm.frame < video.n_frames:
        raise DataError(dest / "palm.toml", f"is from frame {palm.frame}, but the video has "
                        f"{video.n_frames} frames", "run `armtrack calibrate SESSION` again")
    size = (video.width, video.height)
    blobs = _blob_depths(session, read_palm_blobs(dest / "detections.csv", video.n_frames),
                         s.depth_updates, size)
    dpath = depth_path(session.root, palm.frame)
    z = depth_at(read_depth_frame(session.root, palm.frame, size), palm.pixels)
    init = initial_pose(palm.position_H, palm.pixels, z, K=cam.K, dist=cam.dist,
                        sigma_px=s.pixel_sigma, sigma_z=s.depth_sigma_m)  # eq. 13-20
    rig = Rig(cam.K, cam.dist, init.R_CW0, init.T_CW0, palm.position_H)
    run = lambda n: track(video.t[:n], blobs[:n], palm.frame, rig, s,  # noqa: E731
                          float(cam.width * cam.height), marker_area(blobs[palm.frame],
                                                                     palm.pixels))
    run(palm.frame + 2)  # loads the compiled steps (numba's cache) outside the timing
    start = time.perf_counter()
    tr = run(video.n_frames)
    elapsed = time.perf_counter() - start
    R_WW0 = cam.R_WC.T @ init.R_CW0  # X_W = R_WCᵀ (X_C − T_WC)
    T_WW0 = cam.R_WC.T @ (init.T_CW0 - cam.T_WC)
    table = trajectory_table(video.t, tr, R_WW0, T_WW0, palm.side, s.max_coast_s)
    how = {"depth": "projections and depths (eq. 13)" if init.used_depth else
           f"projections and link lengths only: no depth frame {dpath.name}",
           "residual_px": round(init.rms_px, 4), "residual_mm": round(init.rms_depth_mm, 4)
           if init.used_depth else None, "iterations": init.iterations}
    settings = {"recipe": where, "method": METHOD, **dataclasses.asdict(s), "initialisation": how}
    assoc = [(i, b, int(m)) for i, mob in enumerate(tr.marker_of_blob) for b, m in enumerate(mob)]
    names = np.array(("clutter",) + palm.markers)
    assoc_table = pd.DataFrame({"frame": [a[0] for a in assoc], "blob": [a[1] for a in assoc],
                                "marker": names[[a[2] + 1 for a in assoc]] if assoc else []})
    with output_set():
        write_table(dest / f"trajectory-{METHOD}.csv", table, command="fuse", settings=settings)
        write_table(dest / f"kinematics-{METHOD}.csv", palm_kinematics(table, session),
                    command="fuse", settings=settings)
        write_table(dest / f"associations-{METHOD}.csv", assoc_table, command="fuse",
                    settings={"method": METHOD})
    n = video.n_frames - palm.frame
    return {"method": METHOD, "trajectory": str(dest / f"trajectory-{METHOD}.csv"),
            "frames": n, "detections_used": int((tr.used > 0).sum()),
            "seconds": round(elapsed, 3), "frames_per_s": round(n / max(elapsed, 1e-9), 1),
            "initial_wrist_m": [round(float(v), 4) for v in T_WW0],
            "initialised_from": how["depth"], "init_residual_px": how["residual_px"],
            "init_residual_mm": how["residual_mm"], "depth_missing": not init.used_depth}


def _marker_truth(session: Session, t: np.ndarray, start_t: float
                  ) -> tuple[cmp.TruthPose, dict[str, np.ndarray]]:
    """The truth from the Qualisys palm markers: the hand frame from the six (core/wrist.py),
    and each marker at the trajectory's times (for the measures)."""
    gt = session.groundtruth
    missing = [m for m in session.palm.markers if m not in gt.markers]
    if missing:
        raise ConfigError(session.toml_path, f"[groundtruth] markers lacks {', '.join(missing)}",
                          "name the Qualisys marker of every palm marker, e.g. WRIST = \"WRIST\", "
                          "or a QTM 6DOF hand body as [groundtruth] hand")
    qtm = read_qualisys(gt.file)
    cols = select_markers(qtm, {m: gt.markers[m] for m in session.palm.markers}, session.toml_path)
    xyz = np.stack([to_world(qtm.xyz[:, cols[m]], gt.to_world) for m in session.palm.markers], 1)
    t_q = _overlapping(session, qtm.t, t)
    truth = cmp.truth_pose(t, t_q, xyz, qtm.rate_hz, session.palm.markers, session.meta.side,
                           start_t=start_t)
    smooth = lowpassed(Truth(t_q, {m: xyz[:, k] for k, m in enumerate(session.palm.markers)},
                             qtm.rate_hz), DEFAULT.lowpass_hz)  # as labs do, pipeline/compare
    return truth, {m: truth_at(t, t_q, x, qtm.rate_hz) for m, x in smooth.xyz.items()}


def _body_truth(session: Session, t: np.ndarray, start_t: float
                ) -> tuple[cmp.TruthPose, np.ndarray]:
    """The truth from the QTM 6DOF hand body [groundtruth] hand names: its origin is the WRIST
    (or the body [groundtruth] markers.WRIST names), its rotation R_WH (axes those of H); and
    the WRIST for the measures, low-passed at its own rate as labs do (pipeline/compare)."""
    gt = session.groundtruth
    body = read_markers(gt.file)
    R_WH = body_rotation_W(body, gt.hand, gt.to_world, session.toml_path)
    origin = gt.markers.get("WRIST", gt.hand)
    col = select_markers(body, {"WRIST": origin}, session.toml_path)["WRIST"]
    t_q = _overlapping(session, body.t, t)
    wrist = to_world(body.xyz[:, col], gt.to_world)
    smooth = lowpassed(Truth(t_q, {"WRIST": wrist}, body.rate_hz), DEFAULT.lowpass_hz)
    return (cmp.truth_pose_6dof(t, t_q, wrist, R_WH, body.rate_hz, session.meta.side,
                                start_t=start_t),
            truth_at(t, t_q, smooth.xyz["WRIST"], body.rate_hz))


def _overlapping(session: Session, t_stream: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The ground truth's times on the session clock; an error when they miss the trajectory."""
    t_q = t_stream + session.offset_s("groundtruth_offset_s")  # session = stream + offset
    if t_q[0] > np.nanmax(t) or t_q[-1] < np.nanmin(t):
        raise DataError(session.groundtruth.file, f"does not overlap trajectory-{METHOD}.csv in "
                        "time", "check [sync] groundtruth_offset_s")
    return t_q


def compare_palm(session: Session, dest: Path, methods: tuple[str, ...]) -> dict[str, Any]:
    """Palm sessions: ukf-palm against the Qualisys palm markers, or a QTM 6DOF hand body ->
    errors.csv (WRIST, cm), wrist-angle-errors.csv (deg) and measures.csv (estimate, truth,
    difference)."""
    methods = methods or (METHOD,)
    if methods != (METHOD,):
        raise ConfigError(session.toml_path, f"is a palm session; only {METHOD} scores here",
                          f"use --method {METHOD}")
    traj = read_trajectory(dest / f"trajectory-{METHOD}.csv")
    t = traj["t"].to_numpy()
    start_t = float(t[np.isfinite(traj["wrist_x"].to_numpy())][0])
    est = trajectory_inputs(measured_only(traj), session)  # the truth on the same frames
    if session.groundtruth.hand is not None:
        truth, wrist = _body_truth(session, t, start_t)
        tin = truth_pose_inputs(est, wrist, truth.angles_deg)
    else:
        truth, markers = _marker_truth(session, t, start_t)
        tin = truth_inputs(est, session, markers)
    res = cmp.score(METHOD, traj, truth, measured=traj["predicted_only"].to_numpy() != 1
                    if "predicted_only" in traj else None)
    mrows = measure_comparison(METHOD, kinematics_rows(dest / f"kinematics-{METHOD}.csv"), tin)
    speeds = {r["measure"] for r in res.speed_rows}
    mrows = [r for r in mrows if r["measure"] not in speeds] + res.speed_rows
    with output_set():
        for name, tab in (("errors.csv", res.position), ("wrist-angle-errors.csv", res.angles),
                          ("measures.csv", pd.DataFrame(mrows))):
            write_table(dest / name, tab, command="compare", settings={
                "methods": [METHOD], "truth": "6DOF hand body" if session.groundtruth.hand
                else "palm markers"})
    return {"errors": str(dest / "errors.csv"), "measures": str(dest / "measures.csv"),
            "angle_errors": str(dest / "wrist-angle-errors.csv"), "methods": [METHOD],
            "excluded_frames": {f"{METHOD}/wrist": res.excluded}, "table": res.text,
            "rows": res.position.to_dict("records")}
