"""The ground truth compare scores against, whatever the lab exported: each joint named in
[groundtruth] markers (a marker, or mid(…) of several), in W, on the session clock.

A marker that [groundtruth] clusters names is an anatomical landmark from the static trial,
carried by its cluster (compare.joint_centres, CAST), whether or not the trial has a column
for it (Nexus exports the unworn landmarks as empty columns).
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import TYPE_CHECKING

import numpy as np

from armtrack_cli.compare import joint_centres
from armtrack_cli.core.errors import ConfigError, GroundTruthError
from armtrack_cli.core.streams import MarkerTrajectories
from armtrack_cli.session.config import Session
from armtrack_cli.session.groundtruth import body_rotation_W, read_markers
from armtrack_cli.session.point_expr import point_markers
from armtrack_cli.session.qualisys import missing_marker, to_world

if TYPE_CHECKING:  # compare's scoring and the hand's angles: loaded where used (`info` needs neither)
    from armtrack_cli.compare.score import Truth


def _columns(traj: MarkerTrajectories, names: list[str], what: str) -> np.ndarray:
    missing = [n for n in names if n not in traj.names]
    if missing:
        raise GroundTruthError(traj.path, f"has no marker {missing[0]!r} ({what})",
                               f"its markers are {', '.join(traj.names)}")
    return np.stack([traj.marker(n) for n in names], axis=1)


def marker_problem(session: Session, traj: MarkerTrajectories, name: str,
                   static: MarkerTrajectories | None) -> GroundTruthError | None:
    """Why ``name`` (a marker of the trial, or a landmark [groundtruth] clusters carries from the
    static trial) cannot be had from the files, or None when it can."""
    gt = session.groundtruth
    if name not in gt.clusters:
        in_static = static is not None and name in static.names
        hint = ("it is in the static trial: name its cluster in [groundtruth] clusters"
                if in_static else "a landmark seen only in the static trial needs [groundtruth] "
                "clusters")
        if name not in traj.names:
            return missing_marker(traj, name, f"[groundtruth] markers in "
                                  f"{session.toml_path.name}; {hint}")
        gone = _never_seen(traj, name)
        return GroundTruthError(gone.path, gone.problem, hint) if gone and in_static else gone
    if static is None:
        return GroundTruthError(session.toml_path, f"[groundtruth] clusters carries {name!r} from "
                                "the static trial, but [groundtruth] static names none",
                                'add static = "…_static.csv"')
    if name not in static.names:
        return missing_marker(static, name, "a landmark [groundtruth] clusters carries; the "
                              "static trial must hold it")
    names = joint_centres.cluster_names(static.names, gt.clusters[name])
    if len(names) < 3:
        return GroundTruthError(static.path, f"has {len(names)} markers of the cluster carrying "
                                f"{name!r} ({', '.join(names) or 'none'}): a rigid fit needs at "
                                "least 3", "check [groundtruth] clusters")
    lost = [n for n in names if n not in traj.names]
    if lost:
        return GroundTruthError(traj.path, f"has no marker {lost[0]!r} of the cluster carrying "
                                f"{name!r}", f"its markers are {', '.join(traj.names)}")
    return _never_seen(static, name)


def _never_seen(traj: MarkerTrajectories, name: str) -> GroundTruthError | None:
    if np.isfinite(traj.marker(name)).all(axis=1).any():
        return None
    return GroundTruthError(traj.path, f"marker {name!r} is never seen: every frame is a gap",
                            "check the marker labels in the capture software")


def name_problems(session: Session, traj: MarkerTrajectories,
                  static: MarkerTrajectories | None) -> list[GroundTruthError]:
    """Every marker, landmark or rigid body [groundtruth] names that compare could not find in
    the files (one error each, in the order named): for `armtrack info` to list."""
    gt = session.groundtruth
    seen, out = set(), []
    for expr in gt.markers.values():
        for n in point_markers(expr) or ():
            if n not in seen:
                seen.add(n)
                out += [e for e in (marker_problem(session, traj, n, static),) if e]
    if gt.hand is not None:
        try:
            body_rotation_W(traj, gt.hand, gt.to_world, session.toml_path)
        except GroundTruthError as exc:
            out.append(exc)
    elif session.palm is not None:
        out += [ConfigError(session.toml_path, f"[groundtruth] markers lacks palm marker {m}",
                            "name its Qualisys marker, or a 6DOF hand body as [groundtruth] hand")
                for m in session.palm.markers if m not in gt.markers]
    return out


def marker_track(session: Session, traj: MarkerTrajectories, name: str,
                 static: MarkerTrajectories | None) -> np.ndarray:
    """(N, 3) one marker of the trial, or a landmark carried by its cluster (capture frame)."""
    gt = session.groundtruth
    problem = marker_problem(session, traj, name, static)
    if problem is not None:
        raise problem
    if name not in gt.clusters:
        return traj.marker(name)
    names = joint_centres.cluster_names(static.names, gt.clusters[name])
    ref, point = joint_centres.calibrate(_columns(static, names, "cluster, static trial"),
                                         _columns(static, [name], "landmark")[:, 0])
    return joint_centres.carry(ref, point, _columns(traj, names, f"cluster carrying {name}"))


def joint_points(session: Session, traj: MarkerTrajectories) -> dict[str, np.ndarray]:
    """role -> (N, 3) m in the capture frame, for every role [groundtruth] markers names."""
    gt = session.groundtruth
    static = read_markers(gt.static) if gt.static is not None else None
    out = {}
    for role, expr in gt.markers.items():
        tracks = [marker_track(session, traj, n, static) for n in point_markers(expr)]
        # mid(...): a gap in any marker is a gap; one marker is itself (its mean: the same
        # numbers), a view of the table (read_truth carries it into W: no copy of it here)
        out[role] = tracks[0] if len(tracks) == 1 else np.mean(tracks, axis=0)
        if not np.isfinite(out[role]).all(axis=1).any():
            raise GroundTruthError(traj.path, f"marker {expr!r} ({role}) is never seen: every "
                                   "frame is a gap", "check the marker labels in the capture "
                                   "software (and [groundtruth] clusters for landmarks)")
    return out


def read_truth(session: Session, *, offset_s: float | None = None) -> Truth:
    """The [groundtruth] joints in W, on the session clock (session time = stream + offset;
    the declared offset unless ``offset_s`` is given)."""
    from armtrack_cli.compare.score import Truth

    gt = session.groundtruth
    traj = read_markers(gt.file)
    pts = joint_points(session, traj)
    t = traj.t + (session.offset_s("groundtruth_offset_s") if offset_s is None else offset_s)
    rate = traj.rate_hz
    del traj  # the file's table freed once the last point taken from it is in W (issue 15)
    return Truth(t, {j: to_world(pts.pop(j), gt.to_world) for j in list(pts)},
                 rate)  # every named point: joints, or a palm session's markers


def truth_stream(session: Session) -> tuple[float, tuple[str, ...], Iterator[dict]]:
    """(rate, roles, blocks): read_truth(session, offset_s=0)'s clock and points a chunk at a
    time, each block {"t": (n,), role: (n, 3) m in W}, for compare to spill (issue 15). A QTM
    3D export whose points are its own markers is streamed (session/qualisys_stream.py; its
    "never seen" errors raised once it is read, in read_truth's order); any other file (C3D,
    Vicon, QTM 6DOF, clusters carrying landmarks, a name the file lacks) is read whole by
    read_truth and handed over as one block: its peak grows with the capture as before."""
    exprs = _streamable(session)
    if exprs is None:
        truth = read_truth(session, offset_s=0.0)
        return truth.rate_hz, tuple(truth.xyz), iter([{"t": truth.t, **truth.xyz}])
    names, rate, chunks = exprs[0]
    return rate, tuple(exprs[1]), _stream_blocks(session, names, chunks, exprs[1])


def _streamable(session: Session):
    """((names, rate, chunks), role -> its markers) when the truth can be streamed, else None."""
    from armtrack_cli.core.limits import MAX_TEXT_BYTES
    from armtrack_cli.session import c3d, qtm6dof, vicon
    from armtrack_cli.session.files import regular_file
    from armtrack_cli.session.groundtruth import FORMATS
    from armtrack_cli.session.qualisys import _header
    from armtrack_cli.session.qualisys_stream import qualisys_chunks
    from armtrack_cli.session.text_head import read_text_head

    gt = session.groundtruth
    regular_file(gt.file, GroundTruthError, f"a ground-truth file ({FORMATS})",
                 hint="check [groundtruth] file in session.toml", max_bytes=MAX_TEXT_BYTES)
    if gt.static is not None or gt.clusters or c3d.is_c3d(gt.file):
        return None
    lines = read_text_head(gt.file, GroundTruthError, f"a ground-truth file ({FORMATS})")
    if vicon.looks_like_vicon(lines) or qtm6dof.is_6dof(_header(gt.file, lines)[0]):
        return None
    markers = {role: point_markers(expr) for role, expr in gt.markers.items()}
    names, rate, chunks = qualisys_chunks(gt.file)
    if any(n not in names for ns in markers.values() for n in ns or (None,)):
        return None  # read_truth names what is missing, after its own checks
    return (names, rate, chunks), markers


def _stream_blocks(session: Session, names: tuple[str, ...], chunks, markers: dict
                   ) -> Iterator[dict]:
    gt = session.groundtruth
    seen, whole = dict.fromkeys(names, False), dict.fromkeys(markers, False)
    for t, xyz in chunks:
        block = {"t": t}
        for role, ns in markers.items():
            tracks = [xyz[:, names.index(n), :] for n in ns]
            for n, track in zip(ns, tracks):
                seen[n] = seen[n] or bool(np.isfinite(track).all(axis=1).any())
            point = tracks[0] if len(tracks) == 1 else np.mean(tracks, axis=0)
            whole[role] = whole[role] or bool(np.isfinite(point).all(axis=1).any())
            block[role] = to_world(point, gt.to_world)
        yield block
    for role, ns in markers.items():  # joint_points' checks, in its order
        for n in ns:
            if not seen[n]:
                raise GroundTruthError(gt.file, f"marker {n!r} is never seen: every frame is a "
                                       "gap", "check the marker labels in the capture software")
        if not whole[role]:
            raise GroundTruthError(gt.file, f"marker {gt.markers[role]!r} ({role}) is never "
                                   "seen: every frame is a gap", "check the marker labels in "
                                   "the capture software (and [groundtruth] clusters for "
                                   "landmarks)")


def read_hand_angles(session: Session) -> tuple[np.ndarray, np.ndarray] | None:
    """(t on the session clock (M,), wrist angles (M, 3) deg: flexion, deviation, pronation)
    from the QTM 6DOF body [groundtruth] hand names, or None when it names none. For palm
    sessions' wrist angles to be scored against (compare.hand_truth)."""
    gt = session.groundtruth
    if gt is None or gt.hand is None:
        return None
    from armtrack_cli.compare import hand_truth

    traj = read_markers(gt.file)
    R_WH = body_rotation_W(traj, gt.hand, gt.to_world, session.toml_path)
    t = traj.t + session.offset_s("groundtruth_offset_s")
    return t, hand_truth.wrist_angles_deg(t, R_WH, session.meta.side)
