"""`armtrack compare`: trajectories against Qualisys -> errors.csv and measures.csv."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from armtrack_cli.compare.errors import COLUMNS, error_rows, table_one, truth_at
from armtrack_cli.core.errors import ConfigError, DataError
from armtrack_cli.core.measures import MEASURES, measures
from armtrack_cli.fuse.settings import METHODS
from armtrack_cli.pipeline.common import out_dir
from armtrack_cli.pipeline.palm import compare_palm
from armtrack_cli.session.config import load_session, require
from armtrack_cli.session.outputs import write_table
from armtrack_cli.session.qualisys import read_qualisys, select_markers, to_world
from armtrack_cli.session.tables import read_trajectory


def compare(path: str | Path, *, methods: tuple[str, ...] = (),
            out: str | Path | None = None) -> dict[str, Any]:
    session = load_session(path)
    require(session, "groundtruth")
    gt = session.groundtruth
    off = session.sync.groundtruth_offset_s
    if isinstance(off, str):
        raise ConfigError(session.toml_path, '[sync] groundtruth_offset_s = "auto" is not '
                          "supported yet", "write the offset in seconds")
    dest = out_dir(session, out)
    if session.palm is not None:  # Cordella et al.: pipeline/palm.py
        return compare_palm(session, dest, methods)
    if not methods:
        methods = tuple(m for m in METHODS if (dest / f"trajectory-{m}.csv").exists())
        if not methods:
            raise DataError(dest, "holds no trajectory-METHOD.csv", "run `armtrack fuse` first")
    qtm = read_qualisys(gt.file)
    cols = select_markers(qtm, gt.markers, session.toml_path)
    t_q = qtm.t + off  # session time = Qualisys time + offset
    rows, mrows, excluded = [], [], {}
    for m in methods:
        traj = read_trajectory(dest / f"trajectory-{m}.csv")
        t = traj["t"].to_numpy()
        if t_q[0] > t[-1] or t_q[-1] < t[0]:
            raise DataError(gt.file, f"does not overlap trajectory-{m}.csv in time (Qualisys "
                            f"{t_q[0]:.2f}…{t_q[-1]:.2f} s, trajectory {t[0]:.2f}…{t[-1]:.2f} s on "
                            "the session clock)", "check [sync] groundtruth_offset_s")
        truths = {}
        for joint in ("wrist", "elbow", "shoulder"):
            if joint not in cols or f"{joint}_x" not in traj:
                continue
            xyz = to_world(qtm.xyz[:, cols[joint]], gt.to_world)
            tr = truth_at(t, t_q, xyz, qtm.rate_hz)
            truths[joint] = tr
            est = traj[[f"{joint}_x", f"{joint}_y", f"{joint}_z"]].to_numpy()
            excluded[f"{m}/{joint}"] = int((np.isfinite(est).all(axis=1)
                                             & ~np.isfinite(tr).all(axis=1)).sum())
            rows += error_rows(m, joint, est, tr)
        if "wrist" in truths:
            sh = session.arm.shoulder_m if session.arm is not None else None
            est_m = measures(t, traj[["wrist_x", "wrist_y", "wrist_z"]].to_numpy(),
                             elbow=traj[["elbow_x", "elbow_y", "elbow_z"]].to_numpy()
                             if "elbow_x" in traj else None, shoulder=sh)
            ok = np.isfinite(traj["wrist_x"].to_numpy())
            tr_w = np.where(ok[:, None], truths["wrist"], np.nan)
            tr_e = truths.get("elbow")
            tr_m = measures(t, tr_w, elbow=tr_e, shoulder=sh)
            for k, unit in MEASURES.items():
                mrows.append({"method": m, "measure": k, "unit": unit, "estimate": est_m[k],
                              "truth": tr_m[k], "difference": est_m[k] - tr_m[k]})
    table = pd.DataFrame(rows, columns=list(COLUMNS))
    write_table(dest / "errors.csv", table, command="compare",
                settings={"methods": list(methods), "excluded_frames": excluded})
    write_table(dest / "measures.csv", pd.DataFrame(mrows), command="compare",
                settings={"methods": list(methods)})
    text = table_one(rows, "wrist") + ("\n\n" + table_one(rows, "elbow")
                                       if any(r["joint"] == "elbow" for r in rows) else "")
    return {"errors": str(dest / "errors.csv"), "measures": str(dest / "measures.csv"),
            "methods": list(methods), "excluded_frames": excluded, "table": text,
            "rows": rows}
