"""`armtrack compare`: trajectories against Qualisys -> errors.csv and measures.csv."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd

from armtrack_cli.compare.errors import COLUMNS, table_one
from armtrack_cli.compare.score import JOINTS, Truth, score, truth_markers
from armtrack_cli.core.errors import DataError
from armtrack_cli.core.methods import METHODS
from armtrack_cli.pipeline.common import out_dir
from armtrack_cli.pipeline.kinematics import measure_comparison, trajectory_inputs, truth_inputs
from armtrack_cli.session.config import Session, load_session, require
from armtrack_cli.session.outputs import output_set, write_table
from armtrack_cli.session.qualisys import read_qualisys, select_markers, to_world
from armtrack_cli.session.tables import read_kinematics, read_trajectory
from armtrack_cli.session.workfolder import WorkFolder


def read_truth(session: Session) -> Truth:
    """The [groundtruth] markers, in W, on the session clock."""
    gt = session.groundtruth
    qtm = read_qualisys(gt.file)
    cols = select_markers(qtm, gt.markers, session.toml_path)
    t = qtm.t + session.offset_s("groundtruth_offset_s")  # session time = stream time + offset
    return Truth(t, {j: to_world(qtm.xyz[:, c], gt.to_world) for j, c in cols.items()},
                 qtm.rate_hz)  # every named marker: joints, or a palm session's markers


def compare(path: str | Path, *, methods: tuple[str, ...] = (),
            out: str | Path | None = None) -> dict[str, Any]:
    session = load_session(path)
    require(session, "groundtruth")
    work = WorkFolder(out_dir(session, out))
    methods = tuple(methods) or work.trajectories(METHODS)
    if not methods:
        raise DataError(work.path, "holds no trajectory-METHOD.csv", "run `armtrack fuse` first")
    truth = read_truth(session)
    rows, mrows, excluded = [], [], {}
    for m in methods:
        traj = read_trajectory(work / f"trajectory-{m}.csv")
        t = traj["t"].to_numpy()
        if truth.t[0] > t[-1] or truth.t[-1] < t[0]:
            raise DataError(session.groundtruth.file, f"does not overlap trajectory-{m}.csv in "
                            f"time (Qualisys {truth.t[0]:.2f}…{truth.t[-1]:.2f} s, trajectory "
                            f"{t[0]:.2f}…{t[-1]:.2f} s on the session clock)",
                            "check [sync] groundtruth_offset_s")
        est = {j: traj[[f"{j}_x", f"{j}_y", f"{j}_z"]].to_numpy() for j in JOINTS
               if f"{j}_x" in traj}
        s = score(m, t, est, truth)
        rows += s.rows
        mrows += measure_comparison(m, read_kinematics(work / f"kinematics-{m}.csv"),
                                    truth_inputs(trajectory_inputs(traj, session), session,
                                                 truth_markers(t, truth)))
        excluded.update(s.excluded)
    with output_set():
        write_table(work / "errors.csv", pd.DataFrame(rows, columns=list(COLUMNS)),
                    command="compare", settings={"methods": list(methods), "excluded_frames": excluded})
        write_table(work / "measures.csv", pd.DataFrame(mrows), command="compare",
                    settings={"methods": list(methods)})
    text = table_one(rows, "wrist") + ("\n\n" + table_one(rows, "elbow")
                                       if any(r["joint"] == "elbow" for r in rows) else "")
    return {"errors": str(work / "errors.csv"), "measures": str(work / "measures.csv"),
            "methods": list(methods), "excluded_frames": excluded, "table": text,
            "rows": rows}
