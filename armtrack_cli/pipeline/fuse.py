"""`armtrack fuse`: IMU + detections through the chosen method -> trajectory and kinematics."""

from __future__ import annotations

import dataclasses
import difflib
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from armtrack_cli.core import quaternion as quat
from armtrack_cli.core.errors import ConfigError, DataError
from armtrack_cli.core.measures import MEASURES, measures
from armtrack_cli.fuse import models
from armtrack_cli.fuse.methods import Inputs, run
from armtrack_cli.fuse.settings import METHODS, SMOOTHERS, FuseSettings
from armtrack_cli.pipeline.common import out_dir, resolve_recipe
from armtrack_cli.session.camera_yaml import read_camera_yaml
from armtrack_cli.session.config import Session, load_session, require
from armtrack_cli.session.imu import read_imu
from armtrack_cli.session.outputs import write_table
from armtrack_cli.session.recipe import section
from armtrack_cli.session.tables import read_patch_detections


def imu_offset(session: Session) -> float:
    off = session.sync.imu_offset_s
    if isinstance(off, str):
        raise ConfigError(session.toml_path, '[sync] imu_offset_s = "auto" is not supported yet',
                          "write the offset in seconds (session time = IMU time + offset)")
    return off


def settings_for(recipe: str | None, sets: tuple[str, ...], method: str | None,
                 particles: int | None, seed: int | None) -> tuple[FuseSettings, str]:
    doc, where = resolve_recipe(recipe, sets)
    if sets:
        where = "--set" if where == "defaults" else f"{where} with --set"
    s = section(doc, "fuse", FuseSettings, where)
    over = {k: v for k, v in (("method", method), ("particles", particles), ("seed", seed))
            if v is not None}  # explicit flags win over the recipe
    s = dataclasses.replace(s, **over)
    if s.method not in METHODS:
        raise ConfigError(where, f"[fuse] method = {s.method!r} is not a method",
                          f"methods are {', '.join(METHODS)}")
    from armtrack_cli.filters.resampling import SCHEMES

    if s.resampling not in SCHEMES:
        close = difflib.get_close_matches(s.resampling, list(SCHEMES), n=1)
        raise ConfigError(where, f"[fuse] resampling = {s.resampling!r} is not a scheme",
                          (f"did you mean {close[0]!r}? " if close else "")
                          + f"schemes are {', '.join(SCHEMES)}")
    if s.smoother not in SMOOTHERS:
        raise ConfigError(where, f"[fuse] smoother = {s.smoother!r} is not a smoother",
                          f"smoothers are {', '.join(SMOOTHERS)}")
    if s.particles < 10:
        raise ConfigError(where, f"[fuse] particles = {s.particles} is too few", "use 10 or more")
    return s, where


def prepare(session: Session, dest: Path, s: FuseSettings):
    """Everything a method needs, from the session's files, on the session clock."""
    require(session, "imu")
    require(session, "camera")
    cam = read_camera_yaml(dest / "camera.yaml") if (dest / "camera.yaml").exists() else None
    if cam is None or cam.R_WC is None:
        raise DataError(dest / "camera.yaml", "not found or without R_WC/T_WC",
                        "run `armtrack calibrate SESSION` first")
    t_f, uv = read_patch_detections(dest / "detections.csv")
    imu = read_imu(session.imu.file, rate_hz=session.imu.rate_hz, topic=session.imu.topic)
    ok = np.isfinite(imu.acc).all(axis=1) & np.isfinite(imu.quat).all(axis=1)
    t_imu = imu.t[ok] + imu_offset(session)  # session time = stream time + offset
    q_imu = imu.quat[ok]
    a_w = models.accel_world(q_imu, imu.acc[ok])  # eq. 4
    # frames inside the IMU's span, starting at the first detection
    inside = (t_f >= t_imu[0]) & (t_f <= t_imu[-1])
    det = inside & np.isfinite(uv).all(axis=1)
    if not det.any():
        raise DataError(dest / "detections.csv", "no detection falls inside the IMU recording",
                        "check [sync] imu_offset_s and that the patch was found")
    first = int(np.flatnonzero(det)[0])
    last = int(np.flatnonzero(inside)[-1])
    frames = np.arange(first, last + 1)
    steps = models.composite_steps(t_imu, a_w, t_f[frames], accel_noise=s.accel_noise,
                                   imu_period=1.0 / imu.rate_hz)
    q_f = quat.interpolate(t_imu, q_imu, t_f[frames])
    proj = models.Projection(cam)
    arm = None
    if session.arm is not None:
        arm = models.Arm(shoulder=session.arm.shoulder_m, L1=session.arm.upper_arm_m,
                         L2=session.arm.forearm_m, forearm_B=session.imu.forearm_unit)
    return t_f, frames, Inputs(steps, uv[frames], q_f), proj, arm


def fuse(path: str | Path, *, method: str | None = None, particles: int | None = None,
         seed: int | None = None, recipe: str | None = None, sets: tuple[str, ...] = (),
         out: str | Path | None = None) -> dict[str, Any]:
    session = load_session(path)
    s, where = settings_for(recipe, sets, method, particles, seed)
    if s.method == "pf-constraint" and session.arm is None:
        raise ConfigError(session.toml_path, "has no [arm] section, which pf-constraint needs",
                          "use inertial, ekf, ukf or pf, or add the arm model")
    dest = out_dir(session, out)
    t_f, frames, inp, proj, arm = prepare(session, dest, s)
    x0 = np.zeros(6)
    x0[:3], how = models.initial_wrist(proj, inp.z[0], arm=arm, q_WB=inp.q_WB[0],
                                       plane_height_m=s.init_plane_m)
    P0 = np.diag([s.init_pos_sigma_m**2] * 3 + [s.init_vel_sigma_m_s**2] * 3)
    start = time.perf_counter()
    est = run(s.method, inp, x0, P0, proj, s, arm)
    elapsed = time.perf_counter() - start
    table = trajectory_table(t_f, frames, est, inp, arm)
    name = f"trajectory-{s.method}.csv"
    settings = {"recipe": where, **dataclasses.asdict(s), "initialised_from": how}
    write_table(dest / name, table, command="fuse", settings=settings)
    kin = kinematics_table(table, session)
    write_table(dest / f"kinematics-{s.method}.csv", kin, command="fuse", settings=settings)
    return {"method": s.method, "trajectory": str(dest / name), "frames": int(frames.size),
            "detections_used": int(np.isfinite(inp.z).all(axis=1).sum()),
            "seconds": round(elapsed, 3), "frames_per_s": round(frames.size / max(elapsed, 1e-9), 1),
            "initial_wrist_m": [round(float(v), 4) for v in x0[:3]], "initialised_from": how}


def trajectory_table(t_f, frames, est, inp: Inputs, arm) -> pd.DataFrame:
    """Every video frame; rows before the filter starts or after the IMU ends are empty."""
    K = t_f.size
    full = lambda a: np.full((K,) + a.shape[1:], np.nan)  # noqa: E731
    mean, sd = full(est.mean), full(est.sd)
    mean[frames], sd[frames] = est.mean, est.sd
    cols = {"t": t_f}
    for k, a in enumerate("xyz"):
        cols[f"wrist_{a}"] = mean[:, k]
    if arm is not None:
        q = full(inp.q_WB)
        q[frames] = inp.q_WB
        elbow = arm.elbow(mean[:, :3], q)
        for k, a in enumerate("xyz"):
            cols[f"elbow_{a}"] = elbow[:, k]
    for k, a in enumerate("xyz"):
        cols[f"wrist_v{a}"] = mean[:, 3 + k]
    for k, a in enumerate("xyz"):
        cols[f"wrist_{a}_sd"] = sd[:, k]
    if arm is not None:  # the elbow is the wrist moved by a known vector: the same spread
        for k, a in enumerate("xyz"):
            cols[f"elbow_{a}_sd"] = sd[:, k]
    for k, a in enumerate("xyz"):
        cols[f"wrist_v{a}_sd"] = sd[:, 3 + k]
    if est.ess is not None:
        e = np.full(K, np.nan)
        e[frames] = est.ess
        cols["ess"] = e
    return pd.DataFrame(cols)


def kinematics_table(traj: pd.DataFrame, session: Session) -> pd.DataFrame:
    wrist = traj[["wrist_x", "wrist_y", "wrist_z"]].to_numpy()
    elbow = traj[["elbow_x", "elbow_y", "elbow_z"]].to_numpy() if "elbow_x" in traj else None
    shoulder = session.arm.shoulder_m if session.arm is not None else None
    m = measures(traj["t"].to_numpy(), wrist, elbow=elbow, shoulder=shoulder)
    return pd.DataFrame({"measure": list(m), "value": list(m.values()),
                         "unit": [MEASURES[k] for k in m]})
