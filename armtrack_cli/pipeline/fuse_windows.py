"""`armtrack fuse` on a session longer than one window (core/windows.py; issue 15): each
window's frames run by the method on that window's inputs alone, started from its first
detection as a whole session is from its first, its inner frames kept; the trajectory
written a window at a time, the measures' columns kept on disk (session/spill.py) and measured
from there. Peak memory: one window's, whatever the session's length. docs/fusion.md,
"Long sessions", says what differs from one run over the whole session and by how much."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from armtrack_cli.core.threads import Done
from armtrack_cli.core.windows import Window
from armtrack_cli.fuse import camera_pose, models
from armtrack_cli.fuse.estimates import Estimates
from armtrack_cli.fuse.gyro_orientation import gyro_anchored
from armtrack_cli.fuse.kernel_setup import load_kernels
from armtrack_cli.fuse.trajectory import blank, trajectory_table
from armtrack_cli.pipeline import fuse_checks as checks
from armtrack_cli.pipeline import fuse_span
from armtrack_cli.pipeline.common import release_memory
from armtrack_cli.pipeline.fuse import (
    Prepared,
    _initial_state,
    _timed_run,
    camera_and_detections,
    detection_counts,
)
from armtrack_cli.pipeline.fuse_summary import combined
from armtrack_cli.session.config import Session
from armtrack_cli.session.spill import Spill

MEASURED = ("t", "wrist_x", "wrist_y", "wrist_z", "elbow_x", "elbow_y", "elbow_z",
            "wrist_x_sd", "wrist_y_sd", "wrist_z_sd")  # what kinematics reads of a row


def sources(session: Session, dest: Path) -> fuse_span.Sources:
    """The camera, detections and IMU every window reads (prepare()'s checks, in its order)."""
    from armtrack_cli.pipeline.fuse_imu import SpilledImu
    from armtrack_cli.session.imu_stream import imu_chunks

    cam, t_f, uv = camera_and_detections(session, dest)
    # on disk as it is read, a chunk at a time (the formats that stream): each window reads
    # its own samples, and no reader holds the whole recording
    imu = SpilledImu(dest, imu_chunks(session.imu.file, rate_hz=session.imu.rate_hz,
                                      topic=session.imu.topic, field=session.imu.field))
    release_memory()
    proj = models.Projection(cam)
    proj.pose_cov = camera_pose.board_prior(proj, session.camera.board)
    try:
        spill = Spill(dest)  # the detections on disk too: each window reads its own
        spill.append({"uv": uv})
    except BaseException:
        imu.close()
        raise
    return fuse_span.Sources(dest, t_f, np.isfinite(uv).all(axis=1), spill, imu, proj)


def _arm(session: Session) -> models.Arm | None:
    a = session.arm
    return None if a is None else models.Arm(shoulder=a.shoulder_m, L1=a.upper_arm_m,
                                             L2=a.forearm_m, forearm_B=session.imu.forearm_unit)


def prepare_first(session: Session, src: fuse_span.Sources, s, *, beside: bool = False
                  ) -> tuple[Prepared, list[Window]]:
    """The first window prepared as prepare() prepares a session (the IMU's offset set on its
    span, fuse_span.first_offset; the gyro-anchored orientation of its IMU samples for an
    "auto" arm), and the session's windows at that offset."""
    arm = _arm(session)
    known = arm if session.arm is None or not session.arm.auto else None
    offset, how = fuse_span.first_offset(session, src, known, beside=beside)
    frames, wins = fuse_span.layout(src, offset)
    fr, inp = fuse_span.span_inputs(src, offset, fuse_span.window_frames(src, frames, wins[0]), s)
    inp = dataclasses.replace(inp, release_imu=False)  # the arm's estimate reads them again
    q_anch = gyro_anchored(inp.imu.t, inp.imu.q_WB, inp.imu.w_B)
    return Prepared(src.t_f, fr, inp, src.projection, arm, how, q_anch,
                    src.imu.orientation_source, offset), wins


def fuse_windowed(session: Session, dest: Path, s, where: str) -> dict[str, Any] | None:
    """fuse() on a session of several windows; None when its frames (inside the IMU's span,
    from the first detection) turn out to be one window: the caller runs it whole."""
    src = sources(session, dest)
    try:
        p0, wins = prepare_first(session, src, s, beside=True)
        if len(wins) == 1:
            return None
        auto = None
        if session.arm is not None and session.arm.auto:  # on the first window: docs/fusion.md
            from armtrack_cli.pipeline import arm_model

            auto, p0 = arm_model.estimate_with_offset(
                session, p0, lambda known: prepare_first(known, src, s)[0], s)
            session = arm_model.with_arm(session, auto.shoulder, auto.upper_arm_m,
                                         auto.forearm_m)
            p0 = dataclasses.replace(p0, arm=dataclasses.replace(
                p0.arm, shoulder=auto.shoulder, L1=auto.upper_arm_m, L2=auto.forearm_m))
        run = _Run(session, src, s, p0, wins)
        del p0
        release_memory()
        return run.write(where, auto)
    finally:
        src.close()


class _Run:
    """The windows run one after another, each block of rows made as the CSV asks for it."""

    def __init__(self, session: Session, src: fuse_span.Sources, s, p0: Prepared,
                 wins: list[Window]) -> None:
        self.session, self.src, self.s, self.wins = session, src, s, wins
        self.arm, self.offset, self.check = p0.arm, p0.offset_s, p0.imu_offset
        self.frames = fuse_span.session_frames(src, p0.offset_s)
        self.parts: list[tuple[dict, int]] = []
        self.far = self.rows = self.kept = self.n = self.used = 0
        self.elapsed = self.cpu = 0.0
        self.x0 = self.how = self.offset_info = None
        self.tail: tuple | None = None  # the last window's frames past its inner span
        self.name = f"trajectory-{s.method}.csv"

    def write(self, where: str, auto) -> dict[str, Any]:
        """The trajectory, its measures and the auto arm, all or none; fuse's --json."""
        from armtrack_cli.pipeline.kinematics import (
            KINEMATICS_COLUMNS,
            kinematics_cells_windowed,
        )
        from armtrack_cli.session.arm_file import write_arm_estimate
        from armtrack_cli.session.column_csv import write_column_blocks
        from armtrack_cli.session.outputs import output_set, write_rows

        dest, t_f = self.src.dest, self.src.t_f
        start = time.perf_counter()
        load_kernels(self.s.method)  # numba's one-time set-up, timed apart
        self.setup = time.perf_counter() - start
        with Spill(dest) as spill, output_set():
            write_column_blocks(dest / self.name, self._blocks(spill), command="fuse",
                                settings=lambda: self._settings(where, auto))

            def read(w: Window) -> dict:
                sl = w.read(t_f)
                return spill.read(sl.start, sl.stop)

            settings = self._settings(where, auto)
            kin = kinematics_cells_windowed(read, float(t_f[0]), float(t_f[-1]), self.session)
            write_rows(dest / f"kinematics-{self.s.method}.csv", kin, command="fuse",
                       settings=settings, columns=KINEMATICS_COLUMNS)
            if auto:
                write_arm_estimate(dest, auto.as_dict())
        summary = self._summary()
        return {"method": self.s.method, "trajectory": str(dest / self.name), "frames": self.n,
                "detections_used": self.used, "seconds": round(self.elapsed, 3),
                "frames_per_s": round(self.n / max(self.elapsed, 1e-9), 1),
                "cpu_seconds": round(self.cpu, 3), "kernel_setup_s": round(self.setup, 3),
                "initial_wrist_m": [round(float(v), 4) for v in self.x0[:3]],
                "initialised_from": self.how, "frames_beyond_reach": self.far, **summary,
                **({"arm_auto": auto.as_dict()} if auto else {}),
                "imu_offset_s": self.offset_info, "windows": self._windows()}

    def _windows(self) -> dict:
        from armtrack_cli.core.windows import MARGIN_S, WINDOW_S

        return {"count": len(self.wins), "window_s": WINDOW_S, "margin_s": MARGIN_S}

    def _summary(self) -> dict:
        return combined(self.parts)

    def _settings(self, where: str, auto) -> dict:
        return {"recipe": where, **dataclasses.asdict(self.s), "initialised_from": self.how,
                "frames_beyond_reach": self.far, **self._summary(),
                **({"arm_auto": auto.as_dict()} if auto else {}),
                "imu_offset_s": self.offset_info, "windows": self._windows()}

    def _blocks(self, spill: Spill) -> Iterator[dict[str, np.ndarray]]:
        """Each window's inner rows (every video frame in its inner span), checked and blanked
        as fuse() checks a whole trajectory, its measured columns appended to ``spill``."""
        names: list[str] = []
        for i, w in enumerate(self.wins):
            block, q_WB = self._window(i, w)
            names = names or list(block)  # a window without a detection lacks "ess"
            block = {c: block.get(c, np.full(q_WB.shape[0], np.nan)) for c in names}
            far = self._reach(block)
            if far.any():
                block = blank(block, far)
            spill.append({**{c: block[c] for c in MEASURED if c in block}, "q_WB": q_WB})
            yield block
            release_memory()
        if self.far == self.rows or not self.kept:
            raise checks.nowhere_in_reach(self.src.dest / self.name, self.s.method)
        if self.far:
            checks.warn_blanked(self.src.dest / self.name, self.s.method, self.far, self.rows)

    def _reach(self, block: dict) -> np.ndarray:
        """fuse_checks.beyond_reach of a block, counted toward the session's."""
        far = checks.beyond_reach(block, self.arm)
        self.far += int(far.sum())
        self.rows += far.size
        self.kept += int(np.isfinite(block["wrist_x"][~far]).any())
        return far

    def _window(self, i: int, w: Window) -> tuple[dict, np.ndarray]:
        """Window i's inner rows (the trajectory table's) and the IMU orientation at them:
        its own estimates from its first detection on, the rows before it (where it starts
        past its inner span's start) the previous window's, as far as that one ran."""
        tail, self.tail = self.tail, None
        own = self._own(i, w)
        rows = np.flatnonzero(w.inner(self.src.t_f))
        first = own[0][0] if own is not None else np.inf  # own: (frames, est, q, z)
        if tail is not None:
            tail = _cut(tail, tail[0] < first)
        if tail is not None and tail[0].size:
            _finite_rows(self, *tail[:2])
            self.n += tail[0].size
            self.used += int(np.isfinite(tail[3]).all(axis=1).sum())
            own = tail if own is None else tuple(
                _joined(x, y) if isinstance(x, Estimates) else np.concatenate([x, y])
                for x, y in zip(tail, own))
        if own is None:  # nothing estimated here: its rows empty (nothing to start from)
            return self._empty(rows)
        fr, est, q, _ = own
        local = fr - rows[0]
        table = trajectory_table(self.src.t_f[rows], local, est, _Orientations(q), self.arm)
        q_WB = np.full((rows.size, 4), np.nan)
        q_WB[local] = q if est.q_WB is None else est.q_WB
        return table, q_WB

    def _own(self, i: int, w: Window) -> tuple | None:
        """Window i's own estimates of its inner frames (frames, Estimates, IMU orientation,
        detections), its frames past the inner span kept in self.tail for the next window;
        None when it has none (no detection among its frames, or in its margins alone)."""
        t_f = self.src.t_f
        frames = fuse_span.window_frames(self.src, self.frames, w)
        if i > 0:  # from a detection the arm can explain (the first window: the session's)
            frames = fuse_span.explained_from(self.src, self.offset, frames, self.arm)
        got = fuse_span.span_inputs(self.src, self.offset, frames, self.s)
        if got is None:  # no detection in the window
            return None
        fr, inp = got
        p = Prepared(t_f, fr, inp, self.src.projection, self.arm,
                     self.check if i == 0 else Done(self.offset_info), None,
                     self.src.imu.orientation_source, self.offset)
        x0, P0, how = _initial_state(self.session, p, self.s)
        keep = np.flatnonzero(w.inner(t_f[fr]))
        if keep.size == 0:  # its detections all in its margins
            return None
        a, b = int(keep[0]), int(keep[-1]) + 1
        est, elapsed, cpu, info = _timed_run(self.s, p, x0, P0, summary_rows=slice(a, b))
        if i == 0:
            self.x0, self.how, self.offset_info = x0, how, info
        self.elapsed, self.cpu = self.elapsed + elapsed, self.cpu + cpu
        if b < fr.size:  # its frames past the inner span: the next window's until it starts
            self.tail = fr[b:], _rows(est, slice(b, None)), inp.q_WB[b:], inp.z[b:]
        est, q = _rows(est, slice(a, b)), inp.q_WB[a:b]
        _finite_rows(self, fr[a:b], est)
        self.parts.append(({**detection_counts(est.codes), **(est.summary or {})}, b - a))
        self.n += b - a
        self.used += int(np.isfinite(inp.z[a:b]).all(axis=1).sum())
        return fr[a:b], est, q, inp.z[a:b]

    def _empty(self, rows: np.ndarray) -> tuple[dict, np.ndarray]:
        """Rows no estimate reaches: their times, every other column empty."""
        empty = Estimates(np.empty((0, 6)), np.empty((0, 6, 6)), None)
        return (trajectory_table(self.src.t_f[rows], np.empty(0, int), empty, _NoInputs,
                                 self.arm), np.full((rows.size, 4), np.nan))


def _finite_rows(run: _Run, fr: np.ndarray, est: Estimates) -> None:
    """Nothing when every estimate of frames ``fr`` is finite; else fuse's refusal
    (fuse_checks.diverged) from the first frame that is not."""
    bad = ~np.isfinite(est.mean).all(axis=1)
    if bad.any():
        t_bad = run.src.t_f[fr[int(np.flatnonzero(bad)[0])]]
        raise checks.diverged(run.src.dest / run.name, run.s.method, t_bad, run.arm)


def _cut(part: tuple, keep: np.ndarray) -> tuple:
    """The rows ``keep`` (a mask) of (frames, Estimates, q, z)."""
    return tuple(_rows(x, keep) if isinstance(x, Estimates) else x[keep] for x in part)


def _joined(a: Estimates, b: Estimates) -> Estimates:
    """Two runs' estimates of consecutive frames as one (what trajectory_table reads)."""
    cat = lambda x, y: None if x is None or y is None else np.concatenate([x, y])  # noqa: E731
    return Estimates(np.concatenate([a.mean, b.mean]), None, cat(a.ess, b.ess), None,
                     cat(a.q_WB, b.q_WB), cat(a.elbow_var, b.elbow_var), None,
                     np.concatenate([a.sd, b.sd]) ** 2)


class _Orientations:
    """trajectory_table's inputs: the IMU's orientation at its rows alone."""

    def __init__(self, q_WB: np.ndarray) -> None:
        self.q_WB = q_WB


class _NoInputs:
    q_WB = np.empty((0, 4))


def _rows(est: Estimates, sl: slice) -> Estimates:
    """The estimates of the frames ``sl``."""
    cut = lambda a: None if a is None else a[sl]  # noqa: E731
    return Estimates(est.mean[sl], cut(est.cov), cut(est.ess), cut(est.codes), cut(est.q_WB),
                     cut(est.elbow_var), est.summary, cut(est.var))
