"""`armtrack fuse`: IMU + detections through the chosen method -> trajectory and kinematics."""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from armtrack_cli.core import quaternion as quat
from armtrack_cli.core.errors import ConfigError, DataError
from armtrack_cli.core.limits import REACH_MARGIN_M
from armtrack_cli.core.methods import NEEDS, PALM_METHODS
from armtrack_cli.fuse import camera_pose, models, robust
from armtrack_cli.fuse.arm_smoother import ImuSamples
from armtrack_cli.fuse.gyro_orientation import gyro_anchored
from armtrack_cli.fuse.kernel_setup import load_kernels
from armtrack_cli.fuse.methods import Inputs, run
from armtrack_cli.fuse.settings import FuseSettings
from armtrack_cli.pipeline import fuse_checks as checks
from armtrack_cli.pipeline.common import (
    large_arrays_mapped,
    out_dir,
    release_memory,
    resolve_recipe,
    settings_for,
)
from armtrack_cli.pipeline.imu_offset import resolve_imu_offset
from armtrack_cli.session.arm_file import write_arm_estimate
from armtrack_cli.session.camera_yaml import read_calibrated_camera
from armtrack_cli.session.config import Session, load_session, require
from armtrack_cli.session.imu import read_imu
from armtrack_cli.session.video import probe_video


@dataclass(frozen=True)
class Prepared:
    """Everything a method needs, on the session clock."""

    t_frames: np.ndarray  # (n,) s, every video frame
    frames: np.ndarray  # (k,) indices of the frames the filter runs over
    inputs: Inputs  # per filtered frame: IMU step, detection, orientation
    projection: models.Projection
    arm: models.Arm | None
    imu_offset: Any  # [sync] imu_offset_s: its result() the value, its estimate and SD
    #                  (imu_offset.py; a declared value's check perhaps still running beside)
    q_anchored: np.ndarray | None  # (M, 4) inputs.imu's orientations with their wandering
    #                  error replaced by a constant one (fuse/gyro_orientation.py), for the
    #                  arm estimate ([arm] "auto"); None once that is done
    orientation: str = "file"  # the IMU's orientation_source: "file" or "estimated (…)"
    offset_s: float | None = None  # the IMU's clock offset used (a windowed fuse's; s)


def camera_and_detections(session: Session, dest: Path):
    """The calibrated camera (checked against the video's size) and the patch detections:
    (camera, t (n,) s of every frame, uv (n, 2) px, NaN where none)."""
    from armtrack_cli.session.tables import read_patch_detections

    cam = read_calibrated_camera(dest / "camera.yaml")
    video = probe_video(session.camera.video)
    if (video.width, video.height) != (cam.width, cam.height):
        raise DataError(dest / "camera.yaml", f"is for {cam.width}x{cam.height} images but the "
                        f"video is {video.width}x{video.height}", "rerun `armtrack calibrate`")
    t_f, uv = read_patch_detections(dest / "detections.csv", width=cam.width, height=cam.height,
                                    n_frames=video.n_frames)
    return cam, t_f, uv


def prepare(session: Session, dest: Path, s: FuseSettings, *, beside: bool = False
            ) -> Prepared:
    """The session's inputs on its clock; with ``beside``, a declared IMU offset's check is
    left to run on a second thread from ``imu_offset.start()``, beside the caller's work
    (pipeline/imu_offset.py); ``imu_offset.result()`` waits for it."""
    require(session, "imu")
    require(session, "camera")
    cam, t_f, uv = camera_and_detections(session, dest)
    imu = read_imu(session.imu.file, rate_hz=session.imu.rate_hz, topic=session.imu.topic,
                   field=session.imu.field)
    ok = np.isfinite(imu.acc).all(axis=1) & np.isfinite(imu.quat).all(axis=1)
    ok = slice(None) if ok.all() else ok  # every sample usable: views, not copies
    q_imu = imu.quat[ok]
    arm = None
    if session.arm is not None:
        arm = models.Arm(shoulder=session.arm.shoulder_m, L1=session.arm.upper_arm_m,
                         L2=session.arm.forearm_m, forearm_B=session.imu.forearm_unit)
    proj = models.Projection(cam)
    proj.pose_cov = camera_pose.board_prior(proj, session.camera.board)  # its own uncertainty
    known = arm if session.arm is None or not session.arm.auto else None  # "auto": not yet
    q_anch = gyro_anchored(imu.t[ok], q_imu, imu.gyr[ok])
    offset, how = resolve_imu_offset(session, session.imu.file, imu.t[ok], q_anch,
                                     models.accel_world(q_anch, imu.acc[ok]), t_f, uv, proj, known,
                                     beside=beside)
    t_imu = imu.t[ok] + offset  # session time = stream time + offset
    a_w = models.accel_world(q_imu, imu.acc[ok])  # Tao & Hu eq. 4; after the offset check,
    #                                               whose own arrays peak (issue 15)
    # frames inside the IMU's span, starting at the first detection
    inside = (t_f >= t_imu[0]) & (t_f <= t_imu[-1])
    det = inside & np.isfinite(uv).all(axis=1)
    if not det.any():
        raise DataError(dest / "detections.csv", "no detection falls inside the IMU recording",
                        "check [sync] imu_offset_s and that the patch was found")
    frames = np.arange(int(np.flatnonzero(det)[0]), int(np.flatnonzero(inside)[-1]) + 1)
    steps = models.composite_steps(t_imu, a_w, t_f[frames], accel_noise=s.accel_noise,
                                   imu_period=1.0 / imu.rate_hz)
    inputs = Inputs(steps, uv[frames], quat.interpolate(t_imu, q_imu, t_f[frames]),
                    t=t_f[frames], imu=ImuSamples(t_imu, q_imu, imu.acc[ok], imu.gyr[ok]))
    return Prepared(t_f, frames, inputs, proj, arm, how, q_anch, imu.orientation_source)


def _initial_state(session: Session, p: Prepared, s) -> tuple[np.ndarray, np.ndarray, str]:
    """The filter's first state and covariance from the first detection (and the arm, which
    must be able to explain it), and how the wrist was placed."""
    inp = p.inputs
    if p.arm is not None:
        miss = models.ray_misses_arm(p.projection, inp.z[0], p.arm, inp.q_WB[0])
        if miss > REACH_MARGIN_M:
            raise ConfigError(session.toml_path, f"[arm] cannot explain the first detection: its "
                              f"camera ray passes {miss * 100:.0f} cm outside the arm's reach "
                              f"from shoulder_m = {session.arm.shoulder_m.tolist()}",
                              "check shoulder_m (in W, metres) and the arm lengths"
                              + _estimated_heading(p.orientation))
    x0 = np.zeros(6)
    x0[:3], how = models.initial_wrist(p.projection, inp.z[0], arm=p.arm, q_WB=inp.q_WB[0],
                                       plane_height_m=s.init_plane_m)
    return x0, np.diag([s.init_pos_sigma_m**2] * 3 + [s.init_vel_sigma_m_s**2] * 3), how


def _estimated_heading(orientation: str) -> str:
    """The arm error's second suspect when the IMU file has no orientation: one estimated
    from gyro + accelerometer has no heading of its own but the sensor's at the start."""
    if not orientation.startswith("estimated") or "mag" in orientation:
        return ""
    return ("; or the IMU's orientation: the file has none, and one estimated from gyro + "
            "accelerometer takes the sensor's start as W's heading (SESSION_FORMAT.md), "
            "so the sensor must start with its axes along W's")


def fuse(path: str | Path, *, method: str | None = None, particles: int | None = None,
         seed: int | None = None, recipe: str | None = None, sets: tuple[str, ...] = (),
         out: str | Path | None = None) -> dict[str, Any]:
    session = load_session(path)
    s, where = settings_for(recipe, sets, method=method, particles=particles, seed=seed,
                            kind=session.kind)
    # what only some sessions or the last step need is imported there: a stage's peak memory
    # is its libraries' (~200 MB) and its data's at once (issue 15)
    if s.method in PALM_METHODS:  # Cordella et al.: pipeline/palm.py
        from armtrack_cli.pipeline.palm import fuse_palm

        return fuse_palm(session, out_dir(session, out), *resolve_recipe(recipe, sets))
    if "arm" in NEEDS[s.method] and session.arm is None:
        raise ConfigError(session.toml_path, f"has no [arm] section, which {s.method} needs",
                          "use inertial, ekf, ukf or pf, or add the arm model")
    dest = out_dir(session, out)
    large_arrays_mapped()  # session-long arrays returned when freed, not kept in the heap
    if _longer_than_a_window(session):  # a window at a time (pipeline/fuse_windows.py)
        from armtrack_cli.pipeline.fuse_windows import fuse_windowed

        done = fuse_windowed(session, dest, s, where)
        if done is not None:  # else its frames are one window after all: run whole
            return done
    p = prepare(session, dest, s, beside=True)  # the offset's check: started below
    auto = None
    if session.arm is not None and session.arm.auto:  # [arm] … = "auto": from the data first
        from armtrack_cli.pipeline import arm_model

        auto, p = arm_model.estimate_with_offset(session, p, lambda known: prepare(known, dest, s),
                                                 s)
        session = arm_model.with_arm(session, auto.shoulder, auto.upper_arm_m, auto.forearm_m)
        p = dataclasses.replace(p, arm=dataclasses.replace(
            p.arm, shoulder=auto.shoulder, L1=auto.upper_arm_m, L2=auto.forearm_m))
    # q_anchored: the arm estimate's alone, not held on; the IMU's samples: the arm smoother's
    # to let go once folded (methods.Inputs.take_imu)
    p = dataclasses.replace(p, q_anchored=None,
                            inputs=dataclasses.replace(p.inputs, release_imu=True))
    inp = p.inputs
    release_memory()  # reading freed more than it kept (the offset's check runs later, beside)
    x0, P0, how = _initial_state(session, p, s)
    start = time.perf_counter()
    load_kernels(s.method)  # numba's one-time set-up, timed apart: frames_per_s is the filter's
    setup = time.perf_counter() - start
    est, elapsed, cpu, offset = _timed_run(s, p, x0, P0)
    release_memory()  # the method's working arrays, before the trajectory and its measures
    from armtrack_cli.fuse.trajectory import blank, trajectory_table

    table = trajectory_table(p.t_frames, p.frames, est, inp, p.arm)
    name = f"trajectory-{s.method}.csv"
    if not np.isfinite(est.mean).all():
        k = int(np.flatnonzero(~np.isfinite(est.mean).all(axis=1))[0])
        raise checks.diverged(dest / name, s.method, p.t_frames[p.frames[k]], p.arm)
    far = checks.beyond_reach(table, p.arm)
    if far.all() or not np.isfinite(table["wrist_x"][~far]).any():
        raise checks.nowhere_in_reach(dest / name, s.method)
    if far.any():
        table = blank(table, far)
        checks.warn_blanked(dest / name, s.method, int(far.sum()), len(far))
    guards = detection_counts(est.codes)
    settings = {"recipe": where, **dataclasses.asdict(s), "initialised_from": how,
                "frames_beyond_reach": int(far.sum()), **guards, **(est.summary or {}),
                **({"arm_auto": auto.as_dict()} if auto else {}),
                "imu_offset_s": offset}
    q_WB = np.full((p.t_frames.size, 4), np.nan)  # the IMU at each row, for forearm rotation
    q_WB[p.frames] = inp.q_WB if est.q_WB is None else est.q_WB
    n, summary = int(p.frames.size), est.summary or {}
    used = int(np.isfinite(inp.z).all(axis=1).sum())
    del est, p, inp  # the filter's per-frame arrays, before the measures' draws
    release_memory()  # … and their pages
    _write(dest, s.method, table, session, q_WB, settings, auto)
    return {"method": s.method, "trajectory": str(dest / name), "frames": n,
            "detections_used": used,
            "seconds": round(elapsed, 3), "frames_per_s": round(n / max(elapsed, 1e-9), 1),
            "cpu_seconds": round(cpu, 3), "kernel_setup_s": round(setup, 3),
            "initial_wrist_m": [round(float(v), 4) for v in x0[:3]], "initialised_from": how,
            "frames_beyond_reach": int(far.sum()), **guards, **summary,
            **({"arm_auto": auto.as_dict()} if auto else {}),
            "imu_offset_s": offset}


def _longer_than_a_window(session: Session) -> bool:
    """Whether the video is longer than one window and its margins (core/windows.py): a
    shorter session runs whole, as before windows existed; one whose video cannot be read
    too, so that prepare() says what is wrong as it always has."""
    from armtrack_cli.core.windows import windows

    try:
        require(session, "imu")
        require(session, "camera")
        t = probe_video(session.camera.video).t
    except Exception:  # noqa: BLE001 - prepare() raises it, with its order of checks
        return False
    return t.size > 1 and len(windows(float(t[0]), float(t[-1]))) > 1


def _timed_run(s: FuseSettings, p: Prepared, x0: np.ndarray, P0: np.ndarray,
               summary_rows: slice | None = None) -> tuple[Any, float, float, dict]:
    """The method run on p's inputs, timed: (estimates, seconds, cpu_seconds, how the IMU's
    offset was set). A declared offset's check runs beside the compiled forward pass (no GIL
    held) and is waited for when that pass ends, before the smoothers, whose memory peaks
    (issue 15); the wait is not the filter's time. cpu_seconds: this thread's, not the
    check's (nor the arm smoother's model building, when a free core takes it:
    fuse/smoother_blocks.py)."""
    check, waited = p.imu_offset, []
    check.start()

    def forward_done() -> None:
        t = time.perf_counter()
        check.result()
        waited.append(time.perf_counter() - t)

    start, cpu = time.perf_counter(), time.thread_time()
    try:  # a diverging filter's 0/0s not printed one by one: fuse refuses its result whole
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            est = run(s.method, p.inputs, x0, P0, p.projection, s, p.arm,
                      forward_done=forward_done, summary_rows=summary_rows)
        elapsed, cpu = time.perf_counter() - start - sum(waited), time.thread_time() - cpu
    finally:  # the offset's check (and its warning) before any error of the filter's
        offset = check.result()
    return est, elapsed, cpu, offset


def _write(dest: Path, method: str, table, session: Session, q_WB: np.ndarray,
           settings: dict, auto) -> None:
    """The trajectory, its measures (kinematics-METHOD.csv) and the auto arm, all or none."""
    from armtrack_cli.pipeline.kinematics import KINEMATICS_COLUMNS, kinematics_cells
    from armtrack_cli.session.column_csv import write_columns
    from armtrack_cli.session.outputs import output_set, write_rows

    kin = kinematics_cells(table, session, q_WB=q_WB)
    with output_set():
        write_columns(dest / f"trajectory-{method}.csv", table, command="fuse", settings=settings)
        write_rows(dest / f"kinematics-{method}.csv", kin, command="fuse", settings=settings,
                   columns=KINEMATICS_COLUMNS)
        if auto:
            write_arm_estimate(dest, auto.as_dict())


def detection_counts(codes: np.ndarray | None) -> dict[str, int]:
    """How many detections the gate kept out, how often the filter re-acquired and how often
    pf-constraint re-seeded (fuse/robust.py); the inertial method uses none."""
    if codes is None:
        return {}
    n = {name: int(np.sum(codes == c)) for c, name in robust.CODE_NAMES.items()}
    return {"gated_frames": n["gated"], "reacquired": n["reacquired"], "reseeded": n["reseeded"]}
