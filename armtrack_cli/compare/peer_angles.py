"""Elbow flexion from a cluster-marker trial, set beside a peer's processed angles.

Written for the UE-ADL database (Vicon clusters RSHO/RUAR/RLAR of four, landmarks RGTH,
RLEP/RMEP, RSPR/RSPU in the static trial only; the authors' angles cut between movement
onset and offset and low-passed at 10 Hz) and usable for any lab that marks the arm so.

Two definitions, both from CAST-carried landmarks (joint_centres):
- three-point: 180° − the angle at the elbow centre between shoulder point and wrist centre
  (what armtrack's own measures use: joint centres only, no segment axes);
- ISB: Wu 2005 humerus and forearm frames, Z-X-Y, first angle (isb_angles), each segment's
  landmarks carried by that segment's own cluster (Cappozzo 1995: the anatomical frame is
  fixed in its segment's technical frame), or, as a variant, the epicondyles carried by the
  upper-arm cluster in both frames;
- functional axis: the same ISB frames, with the humerus' Z (flexion) axis the elbow's
  functional flexion axis found from the trial's own motion (functional_axis: the mean
  helical axis of the forearm relative to the upper-arm cluster, pronation taken out) in place
  of the epicondylar axis. ISB (the epicondylar axis) stays armtrack's definition; the
  functional axis is the named alternative ``functional_axis``.
The trial's window is found by matching the fingertip speed to the peer's finger-velocity
column (best correlation over shifts: their onset/offset are not given as frame numbers).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import butter, filtfilt

from armtrack_cli.compare import functional_axis, isb_angles
from armtrack_cli.compare.joint_centres import (
    carry_landmark,
    cluster_names,
    poses,
    three_point_angle_deg,
)
from armtrack_cli.core.streams import MarkerTrajectories


@dataclass(frozen=True)
class ArmMarkers:
    """Marker names of one arm (right by default: UE-ADL's)."""

    shoulder: str = "RGTH"
    epicondyles: tuple[str, str] = ("RLEP", "RMEP")  # lateral, medial
    styloids: tuple[str, str] = ("RSPR", "RSPU")  # radial, ulnar
    upper_cluster: str = "RUAR"
    fore_cluster: str = "RLAR"
    fingertip: str = "RFTP"


def lowpass(x: np.ndarray, rate_hz: float, cutoff_hz: float = 10.0) -> np.ndarray:
    """4th-order Butterworth, forward-backward (the peer's processing)."""
    b, a = butter(4, cutoff_hz / (rate_hz / 2))
    return filtfilt(b, a, x, axis=0)


def align_window(speed: np.ndarray, peer_speed: np.ndarray) -> tuple[int, float]:
    """(first frame, correlation) of the shift of ``peer_speed`` that best fits ``speed``."""
    n = peer_speed.size
    best = (0, -np.inf)
    for o in range(speed.size - n + 1):
        c = float(np.corrcoef(peer_speed, speed[o:o + n])[0, 1])
        if c > best[1]:
            best = (o, c)
    return best


HELICAL_STEP_S = 0.05  # finite rotations over 2 × 50 ms for the angular velocity


def _cluster_poses(static, trial, cluster: list[str]) -> np.ndarray:
    """(N, 3, 3) the cluster's rotation from its static-trial shape to each frame."""
    ref = np.nanmean(np.stack([static.marker(n) for n in cluster], axis=1), axis=0)
    return poses(ref, np.stack([trial.marker(n) for n in cluster], axis=1))[0]


def flexion_axis(static, trial, arm: ArmMarkers, up: list[str], fo: list[str]
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(n₁, the epicondylar axis EL − EM (both in the upper-arm cluster's static-trial frame),
    the upper-arm cluster's rotation per frame (N, 3, 3)): the functional flexion axis
    (functional_axis.flexion_axis over the whole trial), pointing laterally like EL − EM."""
    Ru, Rf = _cluster_poses(static, trial, up), _cluster_poses(static, trial, fo)
    step = max(1, round(HELICAL_STEP_S * trial.rate_hz))
    w, R = functional_axis.angular_velocity(functional_axis.relative_rotation(Ru, Rf),
                                            trial.rate_hz, step)
    el, em, us = (np.nanmean(static.marker(m), axis=0) for m in (*arm.epicondyles,
                                                                 arm.styloids[1]))
    n1 = functional_axis.flexion_axis(w, R, (el + em) / 2 - us)
    return (n1 if n1 @ (el - em) > 0 else -n1), el - em, Ru


def functional_flexion(static, trial, arm: ArmMarkers, up: list[str], fo: list[str],
                       points: dict[str, np.ndarray]) -> np.ndarray:
    """(N,) elbow flexion, degrees: the Z-X-Y first angle of the ISB forearm frame in a humerus
    frame whose Z is the functional flexion axis (flexion_axis), Y the projection of the
    epicondyles' midpoint → GH normal to it. ``points``: the carried landmarks gh, el_u, em_u,
    el_f, em_f, rs, us."""
    n1, _, Ru = flexion_axis(static, trial, arm, up, fo)
    p = points
    H = functional_axis.axis_frame((p["el_u"] + p["em_u"]) / 2, p["gh"], Ru @ n1)
    F = isb_angles.forearm_frame(p["us"], p["rs"], p["el_f"], p["em_f"])
    return isb_angles.zxy_deg(np.swapaxes(H, 1, 2) @ F)[:, 0]


def elbow_flexion(static: MarkerTrajectories, trial: MarkerTrajectories,
                  arm: ArmMarkers = ArmMarkers()) -> dict[str, np.ndarray]:
    """(N,) degrees, low-passed: 'three_point', 'isb' (own clusters), 'isb_upper_epicondyles',
    'functional_axis' (ISB frames, the humerus' Z the functional flexion axis)."""
    up = cluster_names(static.names, (arm.upper_cluster + "*",))
    fo = cluster_names(static.names, (arm.fore_cluster + "*",))
    el_u, em_u = (carry_landmark(static, trial, m, up) for m in arm.epicondyles)
    el_f, em_f = (carry_landmark(static, trial, m, fo) for m in arm.epicondyles)
    rs, us = (carry_landmark(static, trial, m, fo) for m in arm.styloids)
    gh = carry_landmark(static, trial, arm.shoulder, up)
    three = 180.0 - three_point_angle_deg(gh, (el_u + em_u) / 2, (rs + us) / 2)
    isb = isb_angles.elbow_flexion_deg(gh, el_u, em_u, rs, us, fore_el=el_f, fore_em=em_f)
    isb_upper = isb_angles.elbow_flexion_deg(gh, el_u, em_u, rs, us)
    func = functional_flexion(static, trial, arm, up, fo, {
        "gh": gh, "el_u": el_u, "em_u": em_u, "el_f": el_f, "em_f": em_f, "rs": rs, "us": us})
    return {k: lowpass(v, trial.rate_hz) for k, v in
            (("three_point", three), ("isb", isb), ("isb_upper_epicondyles", isb_upper),
             ("functional_axis", func))}


def rom_beside_peer(static: MarkerTrajectories, trial: MarkerTrajectories,
                    peer_elbow_deg: np.ndarray, peer_finger_speed: np.ndarray,
                    arm: ArmMarkers = ArmMarkers()) -> dict[str, float]:
    """Elbow flexion RoM (deg) of each definition over the peer's window, and the peer's."""
    speed = np.linalg.norm(np.gradient(lowpass(trial.marker(arm.fingertip), trial.rate_hz),
                                       axis=0), axis=1) * trial.rate_hz
    first, corr = align_window(speed, peer_finger_speed)
    window = slice(first, first + peer_finger_speed.size)
    out = {f"{k}_rom_deg": float(np.ptp(v[window])) for k, v in
           elbow_flexion(static, trial, arm).items()}
    return {**out, "peer_rom_deg": float(np.ptp(peer_elbow_deg)), "window_first_frame": first,
            "window_correlation": corr}
