"""`armtrack simulate OUT --from-mocap FILE [--static STATIC]`: read a Vicon/Qualisys/C3D
recording with technical clusters and its static trial, find the joint centres (CAST,
compare/joint_centres.py) and the forearm cluster's rotation, and write a session that
follows it (simulate/from_mocap.py).

Markers (the UE-ADL names, Vicon Plug-in style, R or L by the side): clusters SHO*, LAR*
(four markers each, ``SIDE + "SHO1"`` …); landmarks in the static trial: GTH (greater
tubercle: the shoulder point), LEP/MEP (epicondyles: the elbow centre is their midpoint),
SPR/SPU (styloids: the wrist centre is their midpoint). Shoulder by the shoulder cluster;
elbow and wrist by the forearm cluster, which also turns the IMU.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np

from armtrack_cli.compare import joint_centres as jc
from armtrack_cli.core.errors import GroundTruthError
from armtrack_cli.core.streams import MarkerTrajectories
from armtrack_cli.pipeline.simulate import write_arm_session
from armtrack_cli.session.files import regular_file
from armtrack_cli.session.groundtruth import find_static_trial, read_markers
from armtrack_cli.simulate.from_mocap import MocapMotion, MocapSimSettings, simulate_mocap

LANDMARKS = ("GTH", "LEP", "MEP", "SPR", "SPU")
CLUSTERS = {"GTH": "SHO", "LEP": "LAR", "MEP": "LAR", "SPR": "LAR", "SPU": "LAR"}


def _cluster(static: MarkerTrajectories, trial: MarkerTrajectories, prefix: str
             ) -> tuple[np.ndarray, np.ndarray]:
    names = jc.cluster_names(trial.names, (prefix + "*",))
    if len(names) < 3 or any(n not in static.names for n in names):
        raise GroundTruthError(trial.path, f"has {len(names)} markers of the cluster {prefix}* "
                               "that the static trial also has; a rigid fit needs 3",
                               "the recording needs technical clusters (e.g. RSHO1-4, RLAR1-4)")
    ref = np.nanmean(np.stack([static.marker(n) for n in names], 1), 0)
    return ref, np.stack([trial.marker(n) for n in names], 1)


def _rotations(ref: np.ndarray, cluster: np.ndarray) -> np.ndarray:
    """(N, 3, 3) the cluster's rotation from its static shape; NaN with < 3 markers seen."""
    out = np.full((cluster.shape[0], 3, 3), np.nan)
    seen = np.isfinite(cluster).all(2) & np.isfinite(ref).all(1)
    for i in np.flatnonzero(seen.sum(1) >= 3):
        out[i] = jc.rigid_fit(ref[seen[i]], cluster[i, seen[i]])[0]
    return out


def motion_from(trial: MarkerTrajectories, static: MarkerTrajectories, side: str) -> MocapMotion:
    """Joint centres and the forearm cluster's rotation of one arm (``side`` 'R' or 'L')."""
    missing = [side + n for n in LANDMARKS if side + n not in static.names]
    if missing or "RGTH" not in static.names or "LGTH" not in static.names:
        raise GroundTruthError(static.path, f"lacks the landmarks {missing or ['RGTH/LGTH']} "
                               "(greater tubercles, epicondyles, styloids)",
                               "is this the static calibration trial?")
    centre = {}
    for lm in LANDMARKS:
        ref, cl = _cluster(static, trial, side + CLUSTERS[lm])
        centre[lm] = jc.carry(ref, np.nanmean(static.marker(side + lm), 0), cl)
    across = np.nanmean(static.marker("LGTH") - static.marker("RGTH"), 0)  # right -> left
    facing = np.cross(across, [0.0, 0.0, 1.0])  # forward = left × up (z up in the lab)
    facing[2] = 0.0
    ref, cl = _cluster(static, trial, side + "LAR")
    return MocapMotion(trial.t, centre["GTH"], 0.5 * (centre["LEP"] + centre["MEP"]),
                       0.5 * (centre["SPR"] + centre["SPU"]), _rotations(ref, cl),
                       facing / np.linalg.norm(facing), trial.rate_hz)


def moving_side(trial: MarkerTrajectories) -> str:
    """'R' or 'L': the arm whose forearm cluster travels farther."""
    def path(side):
        names = jc.cluster_names(trial.names, (side + "LAR*",))
        if not names:
            return -1.0
        x = np.nanmean(np.stack([trial.marker(n) for n in names], 1), 1)
        return float(np.nansum(np.linalg.norm(np.diff(x, axis=0), axis=1)))
    return "R" if path("R") >= path("L") else "L"


def command_line(name: str, s: MocapSimSettings, imu_format: str) -> str:
    parts = [f"armtrack simulate {name} --from-mocap {s.source}", f"--static {s.static}"]
    if s.seed:
        parts.append(f"--seed {s.seed}")
    if s.imu_preset != "mtw":
        parts.append(f"--imu-preset {s.imu_preset}")
    if imu_format != "xsens":
        parts.append(f"--imu-format {imu_format}")
    for k, v in sorted(s.imu_errors.items()):
        parts.append(f"--{'orientation-error' if k == 'orientation_rms_deg' else k.replace('_', '-')}"
                     f" {v:g}")
    if s.duration_s < 3600:
        parts.append(f"--duration {s.duration_s:g}")
    return " ".join(parts)


def simulate_from_mocap(out: str | Path, trial_path: str | Path, settings: MocapSimSettings, *,
                        static_path: str | Path | None = None, imu_format: str = "xsens",
                        force: bool = False, on_frame=None) -> dict[str, Any]:
    """Write a session following the recording ``trial_path`` (and OUT.truth.npz beside it)."""
    out, trial_path = Path(out), regular_file(trial_path, GroundTruthError,
                                              "a motion-capture recording")
    static_path = Path(static_path) if static_path else find_static_trial(trial_path)
    trial, static = read_markers(trial_path), read_markers(static_path)
    side = moving_side(trial)
    motion = motion_from(trial, static, side)
    settings = dataclasses.replace(settings, source=trial_path.name, static=static_path.name,
                                   task=trial_path.stem)
    try:
        sim = simulate_mocap(motion, settings)
    except ValueError as e:
        raise GroundTruthError(trial_path, str(e)) from None
    result = write_arm_session(out, sim, imu_format=imu_format,
                               command=command_line(out.name, settings, imu_format),
                               force=force, on_frame=on_frame,
                               side="left" if side == "L" else "right")
    return {**result, "recording": str(trial_path), "static": str(static_path),
            "side": "left" if side == "L" else "right",
            "seconds": round(float(sim.frame_t[-1]), 3)}
