"""`armtrack compare`: trajectories against Qualisys -> errors.csv and measures.csv."""

from __future__ import annotations

import warnings
from contextlib import ExitStack
from functools import partial
from pathlib import Path
from typing import Any

from armtrack_cli.compare.errors import COLUMNS, table_one
from armtrack_cli.compare.score import JOINTS, Truth, denoised, score, truth_markers
from armtrack_cli.compare.spilled import SpilledTable
from armtrack_cli.compare.sync import estimate_offset
from armtrack_cli.core.errors import ArmtrackError, DataError
from armtrack_cli.core.methods import METHODS
from armtrack_cli.core.threads import Deferred, Done, Then
from armtrack_cli.measures.base import DEFAULT
from armtrack_cli.pipeline.common import out_dir
from armtrack_cli.pipeline.compare_windows import bounded_offset, scored_windowed, session_windows
from armtrack_cli.pipeline.groundtruth import (  # any lab's export (issue 16)
    read_truth,
    truth_stream,
)
from armtrack_cli.pipeline.kinematics import (
    WRIST_ANGLES,
    XYZ,
    columns,
    measure_comparison,
    trajectory_inputs,
    truth_inputs,
)
from armtrack_cli.session.camera_yaml import read_calibrated_camera
from armtrack_cli.session.config import Session, load_session, require
from armtrack_cli.session.outputs import output_set, write_rows
from armtrack_cli.session.plain_tables import (
    NotPlain,
    kinematics_rows,
    trajectory_blocks,
    trajectory_columns,
)
from armtrack_cli.session.spill import Spill
from armtrack_cli.session.workfolder import WorkFolder

BESIDE_MAX_SAMPLES = 120_000  # 20 minutes at 100 Hz (below)
AUTO_SEARCH_S = 3.0  # "auto": offsets from −3 to +3 s are searched
CHECK_SEARCH_S = 1.0  # a declared offset is checked within ±1 s of itself


SYNC_PREFERENCE = ("arm-smoother", "pf-constraint", "ukf", "pf", "ekf", "inertial")  # best-tracking first


def sync_joint(xyz: dict) -> str:
    """The joint whose raw markers the offset's check reads (held by it while it runs)."""
    return "wrist" if "wrist" in xyz else next(iter(xyz))


def synchronised_truth(session: Session, trajs: dict, *, eye=None, beside: bool = False
                       ) -> tuple[Truth, Then | Done]:
    """The truth on the session clock, and how its offset was set (its ``result()``: a dict),
    for a session of one window (a longer one: _offset_windowed, on a bounded span):
    declared (and checked against the data: a disagreement beyond 3 SD is a one-line warning)
    or "auto" (estimated from the trajectory of the best method in ``trajs``, method ->
    trajectory table; with the camera's centre ``eye`` (3,) m in W, from the residual across
    the camera's rays). With ``beside``, a declared offset's check (which cannot move the
    truth, only warn) runs on a second thread while the caller scores (core/threads.py); its
    warning comes with ``result()``, on the caller's thread. Not on a truth longer than
    BESIDE_MAX_SAMPLES: there the check's copies and temporaries on top of the scoring's
    were compare's peak (25 MB at 60 minutes; issue 15), and it runs first."""
    gt = session.groundtruth
    declared = session.sync.groundtruth_offset_s != "auto"
    raw = read_truth(session, offset_s=0.0)
    ref = next((m for m in SYNC_PREFERENCE if m in trajs), next(iter(trajs)))
    traj = trajs[ref]
    joint = sync_joint(raw.xyz)
    est = columns(traj, [f"{joint}_x", f"{joint}_y", f"{joint}_z"])
    centre = session.offset_s("groundtruth_offset_s") if declared else 0.0
    t_raw, x_raw, t_est = raw.t, raw.xyz[joint], traj["t"]  # bound now: the caller pops them

    def check():
        return None if est is None else estimate_offset(
            t_est, est, t_raw, x_raw, raw.rate_hz,
            search_s=CHECK_SEARCH_S if declared else AUTO_SEARCH_S, centre_s=centre, eye=eye)

    if not declared:
        off = check()
        if off is None:
            raise DataError(gt.file, f"its clock offset cannot be estimated: within ±{AUTO_SEARCH_S:g}"
                            f" s it never overlaps trajectory-{ref}.csv enough",
                            "declare [sync] groundtruth_offset_s in seconds")
        info = {"value": round(off.estimate_s, 4), "sd": round(off.sd_s, 4), "from": "auto",
                "estimated_with": ref}
        return Truth(raw.t + off.estimate_s, raw.xyz, raw.rate_hz), Done(info)
    if beside and raw.t.size <= BESIDE_MAX_SAMPLES:
        return Truth(raw.t + centre, raw.xyz, raw.rate_hz), Then(Deferred(check), partial(
            _judged, gt.file, centre, ref, 0.5 / raw.rate_hz))
    judged = _judged(gt.file, centre, ref, 0.5 / raw.rate_hz, check())  # the clock shifted
    return Truth(raw.t + centre, raw.xyz, raw.rate_hz), Done(judged)  # after: one t at once


def _judged(file, centre: float, ref: str, slack: float, off) -> dict:
    """How a declared offset was set, with the data's estimate (from trajectory-``ref``) and
    SD; one warning line when they disagree by more than 3 SD plus ``slack`` (half the truth's
    sample period)."""
    info = {"value": centre, "from": "declared"}
    if off is not None:
        info.update(estimate=round(off.estimate_s, 4), sd=round(off.sd_s, 4), estimated_with=ref)
        if abs(off.estimate_s - centre) > 3 * off.sd_s + slack:
            warnings.warn(f"{file}: the data put its clock offset at {off.estimate_s:+.3f} ± "
                          f"{off.sd_s:.3f} s, not the declared {centre:+.3f} s; check [sync] "
                          "groundtruth_offset_s", stacklevel=1)
    return info


def _camera_centre(work: Path):
    """The camera's centre in W from calibrate's camera.yaml in the work folder (None without
    one: the offset then weighs the whole residual)."""
    try:
        return read_calibrated_camera(work / "camera.yaml").centre_W
    except ArmtrackError:  # not calibrated here (compare needs only the trajectories)
        return None


def _joints(traj: dict) -> dict:
    """joint -> (n, 3) m of each joint the trajectory table has."""
    return {j: columns(traj, [f"{j}_x", f"{j}_y", f"{j}_z"]) for j in JOINTS if f"{j}_x" in traj}


def _keep(session: Session) -> set[str]:
    """The columns of a trajectory table that compare reads (its time, the joints' and named
    points' positions, the wrist's SDs and angles): a 60-minute table's velocities and other
    SDs are 8 MB it need not hold while it scores (issue 15)."""
    points = (*JOINTS, *session.groundtruth.markers)
    return {"t", *(f"{p}_{a}" for p in points for a in XYZ), *(f"wrist_{a}_sd" for a in XYZ),
            *WRIST_ANGLES, *(f"{a}_sd" for a in WRIST_ANGLES)}


def _used(session: Session, traj: dict) -> dict:
    """_keep's columns of a trajectory table."""
    keep = _keep(session)
    return {k: v for k, v in traj.items() if k in keep}


def _scored(session: Session, work: WorkFolder, trajs: dict, truth: Truth,
            pinned: str | None = None) -> tuple[list, list, dict]:
    """errors.csv's rows, measures.csv's rows and the frames without truth, of every method
    in ``trajs`` against ``truth`` (on the session clock), whose markers are taken out of it
    as they are used (truth.xyz is left empty) and filtered in place, but for ``pinned``'s,
    which the offset's check may still be reading beside."""
    rows, mrows, excluded = [], [], {}
    for m, traj in trajs.items():
        t = traj["t"]
        if truth.t[0] > t[-1] or truth.t[-1] < t[0]:
            raise DataError(session.groundtruth.file, f"does not overlap trajectory-{m}.csv in "
                            f"time (Qualisys {truth.t[0]:.2f}…{truth.t[-1]:.2f} s, trajectory "
                            f"{t[0]:.2f}…{t[-1]:.2f} s on the session clock)",
                            "check [sync] groundtruth_offset_s")
        s = score(m, t, _joints(traj), truth)  # the joints' (n, 3) copies freed with the call
        rows += s.rows
        excluded.update(s.excluded)
    # filtered at its own rate, as labs do, a joint at a time: each joint's raw markers are
    # dropped as its filtered ones are made (scored: a 60-minute capture's three joints held
    # twice were 26 MB more; issue 15)
    t_truth, rate, raw = truth.t, truth.rate_hz, truth.xyz
    del truth
    for_measures = Truth(t_truth, {}, rate)
    for joint in sorted(raw, key=lambda j: j == pinned):  # the pinned one last
        one = Truth(t_truth, {joint: raw.pop(joint)}, rate)
        for_measures.xyz.update(denoised(one, DEFAULT.lowpass_hz, own=joint != pinned).xyz)
        del one
    last = list(trajs)[-1]
    for m, traj in trajs.items():  # the last takes the filtered markers (26 MB at 60 minutes)
        markers = truth_markers(traj["t"], for_measures, take=m == last)  # at its frames
        truth = truth_inputs(trajectory_inputs(traj, session), session, markers)
        del markers
        mrows += measure_comparison(m, kinematics_rows(work / f"kinematics-{m}.csv"), truth)
        del truth
    return rows, mrows, excluded


def _scored_whole(session: Session, work: WorkFolder, trajs: dict) -> tuple:
    """errors.csv's rows, measures.csv's rows, the frames without truth and the offset's
    settings of a session of one window, held whole."""
    truth, pending = synchronised_truth(session, trajs, eye=_camera_centre(work.path),
                                        beside=True)  # a declared offset's check beside
    try:
        rows, mrows, excluded = _scored(session, work, trajs, truth, None if isinstance(
            pending, Done) else sync_joint(truth.xyz))  # the check beside reads that joint
    finally:  # the check's estimate (and its warning) before any error of the scoring's
        offset = pending.result()
    return rows, mrows, excluded, offset


def _trajectory_table(session: Session, spills: ExitStack, path: Path) -> SpilledTable:
    """_keep's columns of a trajectory table in a spill, streamed (plain_tables.
    trajectory_blocks); a table the plain reader does not take read whole, as before."""
    keep = _keep(session)
    spill = spills.enter_context(Spill(path.parent))
    try:
        return SpilledTable(spill, trajectory_blocks(path, keep.__contains__))
    except NotPlain:
        spill.close()
    return SpilledTable(spills.enter_context(Spill(path.parent)),
                        [_used(session, trajectory_columns(path))])


def _truth_table(session: Session, spill: Spill) -> tuple[SpilledTable, float, tuple]:
    """The truth on its own clock (offset 0) in ``spill``, its rate and its roles."""
    rate, roles, blocks = truth_stream(session)  # streamed where it can be (a QTM 3D export)
    return SpilledTable(spill, blocks), rate, roles


def _offset_windowed(session: Session, tabs: dict, truth: SpilledTable, rate: float, eye
                     ) -> tuple[float, dict]:
    """synchronised_truth's offset and its settings for a session of several windows, from
    a bounded span (compare_windows.sync_span): the declared one checked, or "auto"."""
    gt = session.groundtruth
    declared = session.sync.groundtruth_offset_s != "auto"
    ref = next((m for m in SYNC_PREFERENCE if m in tabs), next(iter(tabs)))
    joint = "wrist" if "wrist" in truth.names else next(
        k for k in truth.names if k != "t")
    centre = session.offset_s("groundtruth_offset_s") if declared else 0.0
    off = bounded_offset(tabs[ref], truth, joint, rate, centre_s=centre, eye=eye,
                         search_s=CHECK_SEARCH_S if declared else AUTO_SEARCH_S)
    if declared:
        return centre, _judged(gt.file, centre, ref, 0.5 / rate, off)
    if off is None:
        raise DataError(gt.file, f"its clock offset cannot be estimated: within ±{AUTO_SEARCH_S:g}"
                        f" s it never overlaps trajectory-{ref}.csv enough",
                        "declare [sync] groundtruth_offset_s in seconds")
    return off.estimate_s, {"value": round(off.estimate_s, 4), "sd": round(off.sd_s, 4),
                            "from": "auto", "estimated_with": ref}


def compare(path: str | Path, *, methods: tuple[str, ...] = (),
            out: str | Path | None = None) -> dict[str, Any]:
    session = load_session(path)
    require(session, "groundtruth")
    if session.palm is not None:  # Cordella et al.: pipeline/palm.py
        from armtrack_cli.pipeline.palm import compare_palm  # its libraries only when needed

        return compare_palm(session, out_dir(session, out), methods)
    work = WorkFolder(out_dir(session, out))
    methods = tuple(methods) or work.trajectories(METHODS)
    if not methods:
        raise DataError(work.path, "holds no trajectory-METHOD.csv", "run `armtrack fuse` first")
    with ExitStack() as spills:  # the spills' folders removed at the end, after a failure too
        tabs = {m: _trajectory_table(session, spills, work / f"trajectory-{m}.csv")
                for m in methods}
        if any(len(session_windows(tab)) > 1 for tab in tabs.values()):
            truth, rate, roles = _truth_table(session, spills.enter_context(Spill(work.path)))
            off, offset = _offset_windowed(session, tabs, truth, rate, _camera_centre(work.path))
            rows, mrows, excluded = scored_windowed(session, work, tabs, truth, roles, off, rate)
        else:  # one window: the whole session at once, as before windows
            trajs = {m: tab.rows(0, len(tab)) for m, tab in tabs.items()}
            del tabs
            spills.close()
            rows, mrows, excluded, offset = _scored_whole(session, work, trajs)
    with output_set():
        write_rows(work / "errors.csv", rows, columns=COLUMNS, command="compare",
                   settings={"methods": list(methods), "excluded_frames": excluded,
                             "groundtruth_offset_s": offset})
        write_rows(work / "measures.csv", mrows, command="compare",
                   settings={"methods": list(methods)})
    text = table_one(rows, "wrist") + ("\n\n" + table_one(rows, "elbow")
                                       if any(r["joint"] == "elbow" for r in rows) else "")
    return {"errors": str(work / "errors.csv"), "measures": str(work / "measures.csv"),
            "methods": list(methods), "excluded_frames": excluded, "table": text,
            "groundtruth_offset_s": offset,
            "rows": rows}
