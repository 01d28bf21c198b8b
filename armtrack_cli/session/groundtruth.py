"""Ground truth from whatever the lab's motion capture exports, told by content:

- C3D (Qualisys, Vicon, Motion Analysis…): ``c3d.read_c3d``;
- QTM 6DOF TSV (rigid bodies): ``qtm6dof.read_qtm_6dof``; a body's origin is scored where a
  marker would be, and its rotation gives the hand orientation;
- Vicon Nexus trajectories CSV: ``vicon.read_vicon_csv`` (joint centres from clusters);
- QTM 3D TSV: ``qualisys.read_qualisys``.
Every reader returns MarkerTrajectories in the capture system's frame, metres, NaN gaps.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import GroundTruthError
from armtrack_cli.core.limits import MAX_SESSION_S, MAX_TEXT_BYTES
from armtrack_cli.core.streams import MarkerTrajectories
from armtrack_cli.session import c3d, qtm6dof, qualisys, vicon
from armtrack_cli.session.files import regular_file
from armtrack_cli.session.text_head import read_text_head

FORMATS = "QTM 3D or 6DOF TSV, C3D, or Vicon Nexus trajectories CSV"


def read_markers(path: str | Path) -> MarkerTrajectories:
    """The ground-truth file's markers (or rigid bodies), whatever its format."""
    path = regular_file(path, GroundTruthError, f"a ground-truth file ({FORMATS})",
                        hint="check [groundtruth] file in session.toml", max_bytes=MAX_TEXT_BYTES)
    if c3d.is_c3d(path):
        return _plausible(c3d.read_c3d(path))
    lines = read_text_head(path, GroundTruthError, f"a ground-truth file ({FORMATS})")
    if vicon.looks_like_vicon(lines):  # the head tells the format; a long file is read again
        whole = getattr(lines, "whole", True)
        return _plausible(vicon.read_vicon_csv(path, lines=lines if whole else None))
    keys, _ = qualisys._header(path, lines)
    if qtm6dof.is_6dof(keys):
        return _plausible(qtm6dof.read_qtm_6dof(path))
    return qualisys.read_qualisys(path)  # checks the same bounds itself


def _plausible(m: MarkerTrajectories) -> MarkerTrajectories:
    """The bounds the QTM 3D reader applies: no coordinate beyond any capture volume, no clock
    longer than any session."""
    far = np.isinf(m.xyz) | (np.abs(np.nan_to_num(m.xyz)) > qualisys.MAX_MARKER_MM * qualisys.MM)
    if far.any():
        i, k, a = np.argwhere(far)[0]
        raise GroundTruthError(m.path, f"frame {i + 1}: marker {m.names[k]!r} {'XYZ'[a]} = "
                               f"{m.xyz[i, k, a]:g} m, beyond any capture volume",
                               "the file is damaged or its units are wrong")
    if m.t.size and m.t[-1] - m.t[0] > MAX_SESSION_S:
        raise GroundTruthError(m.path, f"its clock spans {(m.t[-1] - m.t[0]) / 3600:.0f} h, "
                               "longer than any session", "its frame or rate field is damaged")
    return m


def body_rotation_W(traj: MarkerTrajectories, body: str, to_world: np.ndarray,
                    toml: Path) -> np.ndarray:
    """(N, 3, 3) R_W,body of a 6DOF rigid body (body -> W): the lab rotation carried into W."""
    if traj.rotations is None:
        raise GroundTruthError(traj.path, f"holds markers, not rigid bodies: [groundtruth] hand "
                               f"= {body!r} in {toml.name} needs a QTM 6DOF export")
    if body not in traj.names:
        raise GroundTruthError(traj.path, f"has no rigid body {body!r} ([groundtruth] hand in "
                               f"{toml.name})", f"its bodies are {', '.join(traj.names)}")
    return to_world[:3, :3] @ traj.rotations[:, traj.names.index(body)]


def find_static_trial(trial: Path) -> Path:
    """The static calibration trial beside a movement trial: the one *static*.csv there."""
    found = sorted(p for p in Path(trial).parent.glob("*.csv") if "static" in p.name.lower())
    if len(found) != 1:
        raise GroundTruthError(trial, f"has {len(found)} static trials (*static*.csv) beside it",
                               "name the static calibration trial with --static")
    return found[0]
