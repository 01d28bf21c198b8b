"""`armtrack export`: trajectories for the tools people already use, into WORK/export/.

- ``tum``: ``METHOD-JOINT.tum`` (the estimate) and, with ground truth, ``METHOD-JOINT.truth.tum``
  (the truth in W at the estimate's frame times, associated exactly as compare does it, so
  ``evo_ape tum METHOD-wrist.truth.tum METHOD-wrist.tum`` reports compare's 3-D RMSE) and
  ``truth-JOINT.tum`` (the truth at its own rate, for ``evo_traj``);
- ``csv``: the same poses as CSV with a ``t,x,y,z,qx,qy,qz,qw`` header;
- ``c3d``: ``METHOD.c3d``, the estimated joints as markers (mm) for biomechanics software.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from armtrack_cli.compare.errors import truth_at
from armtrack_cli.compare.score import JOINTS
from armtrack_cli.core import quaternion as quat
from armtrack_cli.core.errors import ConfigError, DataError
from armtrack_cli.core.methods import METHODS
from armtrack_cli.pipeline.common import out_dir
from armtrack_cli.pipeline.groundtruth import read_truth
from armtrack_cli.session.c3d import write_c3d
from armtrack_cli.session.config import load_session
from armtrack_cli.session.export.tum import write_pose_csv, write_tum
from armtrack_cli.session.groundtruth import body_rotation_W, read_markers
from armtrack_cli.session.tables import read_trajectory
from armtrack_cli.session.workfolder import WorkFolder

FORMATS = ("tum", "csv", "c3d")


def _estimate(traj) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray | None]:
    t = traj["t"].to_numpy(dtype=float)
    joints = {j: traj[[f"{j}_x", f"{j}_y", f"{j}_z"]].to_numpy(dtype=float) for j in JOINTS
              if f"{j}_x" in traj}
    q = traj[["qw", "qx", "qy", "qz"]].to_numpy(dtype=float) if "qw" in traj else None
    return t, joints, q


def _truth_hand(session, t_truth: np.ndarray) -> np.ndarray | None:
    """(M, 4) the 6DOF hand body's orientation in W (wxyz), when [groundtruth] hand names it."""
    gt = session.groundtruth
    if gt is None or gt.hand is None:
        return None
    R = body_rotation_W(read_markers(gt.file), gt.hand, gt.to_world, session.toml_path)
    q = np.full((R.shape[0], 4), np.nan)
    ok = np.isfinite(R).all(axis=(1, 2))
    q[ok] = quat.from_matrix(R[ok])
    return q


def export(path: str | Path, *, fmt: str, methods: tuple[str, ...] = (),
           out: str | Path | None = None) -> dict[str, Any]:
    if fmt not in FORMATS:
        raise ConfigError("--format", f"{fmt!r} is not an export format",
                          f"formats are {', '.join(FORMATS)}")
    session = load_session(path)
    work = WorkFolder(out_dir(session, out))
    methods = tuple(methods) or work.trajectories(METHODS)
    if not methods:
        raise DataError(work.path, "holds no trajectory-METHOD.csv", "run `armtrack fuse` first")
    dest = work / "export"
    truth = read_truth(session) if session.groundtruth is not None else None
    hand = _truth_hand(session, truth.t) if truth is not None else None
    written: list[str] = []
    for m in methods:
        t, joints, q = _estimate(read_trajectory(work / f"trajectory-{m}.csv"))
        if fmt == "c3d":
            rate = float(1.0 / np.median(np.diff(t)))
            xyz = np.stack([joints[j] for j in joints], axis=1)
            written.append(str(write_c3d(dest / f"{m}.c3d", xyz, list(joints), rate)))
            continue
        write = write_tum if fmt == "tum" else write_pose_csv
        ext = "tum" if fmt == "tum" else "csv"
        for j, xyz in joints.items():
            qj = q if j == "wrist" else None
            written.append(str(write(dest / f"{m}-{j}.{ext}", t, xyz, qj)))
            if truth is not None and j in truth.xyz:
                at = truth_at(t, truth.t, truth.xyz[j], truth.rate_hz)  # compare's association
                qt = None
                if hand is not None and j == "wrist":
                    near = np.clip(np.searchsorted(truth.t, t), 0, truth.t.size - 1)
                    qt = hand[near]
                written.append(str(write(dest / f"{m}-{j}.truth.{ext}", t, at, qt)))
    if truth is not None and fmt != "c3d":
        for j, xyz in truth.xyz.items():
            write = write_tum if fmt == "tum" else write_pose_csv
            written.append(str(write(dest / f"truth-{j}.{fmt}", truth.t, xyz,
                                     hand if j == "wrist" else None)))
    return {"session": str(session.root), "format": fmt, "methods": list(methods),
            "written": written}
