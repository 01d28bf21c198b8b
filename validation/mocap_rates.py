"""What the scored run of a real-motion session takes from the other recordings
(validation/from_mocap.py, leave-one-out): the drifting arm's random-walk rates and prior, the
resting hand's velocity (the rest update's SD) and detect's pixel error (the camera rows' SD),
each measured on the truth of trials other than the one scored, and the settings they make."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from detect_correlation import still_tau
from mocap_budget import STILL_M_S, sphere_fit


def walk_rates(truths: list[Path], lag_s: float = 1.0) -> tuple[float, float]:
    """The drifting arm's random-walk rates (m/√s) measured on recordings: the median over
    trials of the RMS change of the shoulder point (per axis) and of |E − S| over lag_s,
    divided by √lag_s (a random walk's increments grow as √lag). validation/from_mocap.py
    takes them from the trials other than the one scored."""
    sh, ln = [], []
    for path in truths:
        tr = np.load(path)
        S, E, t = tr["shoulder"], tr["elbow"], tr["t"]
        k = int(round(lag_s / np.median(np.diff(t))))
        L = np.linalg.norm(E - S, axis=1)
        sh.append(np.sqrt(np.mean((S[k:] - S[:-k]) ** 2) / lag_s))
        ln.append(np.sqrt(np.mean((L[k:] - L[:-k]) ** 2) / lag_s))
    return float(np.median(sh)), float(np.median(ln))


def side_sign(truth_npz: Path) -> float:
    """−1 for a left arm, +1 for a right one (the session's [session] side, beside OUT.truth.npz):
    W's x is across the subject, so an anatomical offset along it changes sign with the side."""
    toml = truth_npz.parent / truth_npz.name.removesuffix(".truth.npz") / "session.toml"
    return -1.0 if re.search(r'^side = "left"', toml.read_text(), re.M) else 1.0


def arm_priors(truths: list[Path]) -> tuple[float, ...]:
    """Where the sphere the elbow turns about lies from the declared arm (the shoulder point's
    mean, |E − S|'s median), measured on recordings: for each trial the hindsight sphere's
    centre less the declared shoulder (x as for a right arm) and its radius less the declared
    L1. Returns (SD per axis of the centre's offset about its mean, SD of the radius', mean
    offset x (right arm), y, z, mean radius offset), m: the drifting arm's prior is centred on
    the declared arm plus the mean offset, as wide as the trials spread about it.
    validation/from_mocap.py takes them from the trials other than the one scored."""
    dc, dr = [], []
    for path in truths:
        tr = np.load(path)
        centre, radius = sphere_fit(tr["frame_elbow"])
        dc.append((centre - tr["arm"][:3]) * [side_sign(path), 1.0, 1.0])
        dr.append(radius - tr["arm"][3])
    mc, mr = np.mean(dc, axis=0), float(np.mean(dr))
    return (float(np.sqrt(np.mean(np.square(np.array(dc) - mc)))),
            float(np.sqrt(np.mean(np.square(np.array(dr) - mr)))), *map(float, mc), mr)


def _still_runs(v: np.ndarray, least: int = 10) -> list[np.ndarray]:
    """The runs of at least ``least`` consecutive rows of v (n, 3) slower than STILL_M_S."""
    still = np.linalg.norm(v, axis=1) < STILL_M_S
    edges = np.diff(np.r_[0, still.astype(int), 0])
    return [v[a:b] for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1))
            if b - a >= least]


def correlation_frames(runs: list[np.ndarray], most: int = 30) -> float:
    """The integrated autocorrelation time (frames) of a still hand's velocity: 1 + 2 Σ ρ_k
    over lags k = 1, 2, … until ρ_k first drops below 0 (Geyer 1992's initial positive
    sequence), ρ_k pooled over the runs and axes (each run about zero, the hand at rest). n
    frames of it tell its mean as well as n / τ independent ones."""
    x0 = sum(float(np.sum(r * r)) for r in runs)
    n0 = sum(r.size for r in runs)
    tau = 1.0
    for k in range(1, most):
        pairs = [(float(np.sum(r[k:] * r[:-k])), r[k:].size) for r in runs if len(r) > k]
        if not pairs:
            break
        rho = (sum(p for p, _ in pairs) / sum(c for _, c in pairs)) / (x0 / n0)
        if rho < 0:
            break
        tau += 2 * rho
    return tau


def rest_speed(truths: list[Path]) -> float:
    """The rest update's SD (m/s), measured on recordings: the median over trials of a still
    hand's velocity RMS per axis (at the video's frames, in runs of ≥ 10 frames slower than
    STILL_M_S) times √τ, τ its correlation_frames. The update's rows are independent, one per
    resting frame, while the recordings' still hand sways for several frames (tremor, sway,
    marker noise): rows of the RMS alone would pin the resting hand's mean velocity τ times
    tighter than those frames know it (validation/from_mocap.py takes it from the trials
    other than the one scored)."""
    sd = []
    for path in truths:
        tr = np.load(path)
        v = np.stack([np.interp(tr["frame_t"], tr["t"], tr["wrist_vel"][:, i]) for i in range(3)], 1)
        runs = _still_runs(v)
        if runs:
            rms = np.sqrt(np.mean(np.concatenate(runs) ** 2))
            sd.append(rms * np.sqrt(correlation_frames(runs)))
    return float(np.median(sd)) if sd else float("nan")


def pixel_sd(truths: list[Path]) -> float:
    """How far `detect`'s wrist pixel lies from the truth, measured on the other sessions: the
    RMS per axis (px) of (u, v) − the true wrist pixel over their frames with ok = 1, pooled
    (each session's detections.csv in SESSION/armtrack/, beside OUT.truth.npz). The camera
    rows' SD of the scored run (fuse.pixel_sigma) instead of the recipe's 4 px, which stood
    for the camera pose's error too; that error has its own states (fuse.camera_pose)."""
    err = []
    for path in truths:
        tr = np.load(path)
        folder = path.parent / path.name.removesuffix(".truth.npz")
        det = np.genfromtxt(folder / "armtrack" / "detections.csv", delimiter=",", names=True)
        n = tr["frame_t"].size
        ok = det["ok"][:n] == 1
        err.append((np.c_[det["u"][:n], det["v"][:n]] - tr["frame_wrist_px"][:n])[ok])
    return float(np.sqrt(np.mean(np.concatenate(err) ** 2)))


def pixel_tau(truths: list[Path]) -> float:
    """How many frames detect's error stays correlated where the patch is still, measured on
    the other sessions (detect_correlation.still_tau: the integrated autocorrelation time of
    their errors against the truth on the frames their detections call still): the camera
    rows' variance there is pixel_sigma² × this (fuse.pixel_still_tau, fuse/camera_rows.py)."""
    return still_tau([path.parent / path.name.removesuffix(".truth.npz") for path in truths])


def rest_sets(rates: tuple[float, ...]) -> tuple[str, ...]:
    """The rest update (fuse/rest.py): v = 0 where the hand rests, ± the resting hand's
    velocity per axis measured on the other trials (rates[8], rest_speed)."""
    return (f"fuse.rest_velocity_sd_m_s={rates[8]:.4f}",)


# the scored run also corrects the camera's pose from the board's covariance (fuse/camera_pose.py)
CAMERA = ("fuse.camera_pose=board",)


def trial_rates(others: list[Path]) -> tuple[float, ...]:
    """Everything the scored run takes from the other trials' recordings: the drifting arm's
    walk rates and prior (drift_sets), then the resting hand's velocity SD (rest_sets) and
    detect's pixel error (scored_sets; their detections must exist, detect_all)."""
    return (walk_rates(others) + arm_priors(others)
            + (rest_speed(others), pixel_sd(others), pixel_tau(others)))


def pixel_sets(rates: tuple[float, ...]) -> tuple[str, ...]:
    """The camera's pose corrected from the board's covariance, and the camera rows' SD
    detect's pixel error as measured on the other trials (pixel_sd), × √τ where the patch is
    still (pixel_tau)."""
    return CAMERA + (f"fuse.pixel_sigma={rates[9]:.4f}", f"fuse.pixel_still_tau={rates[10]:.3f}")


def scored_sets(rates: tuple[float, ...]) -> tuple[str, ...]:
    """The scored run's settings beside the drifting arm: the rest update and pixel_sets."""
    return rest_sets(rates) + pixel_sets(rates)


def drift_sets(rates: tuple[float, ...], side: float = 1.0, offset: bool = True
               ) -> tuple[str, ...]:
    """The drifting arm with the shoulder's and the upper arm's walk rates (m/√s), priors (m)
    and the prior's offset from the declared arm (x for a right arm; ``side`` −1 mirrors it
    for a left one) measured on the other trials (walk_rates, arm_priors), not
    the scored. ``offset`` False: none (an "auto" arm is already the elbow's sphere)."""
    walk_s, walk_l, sd_s, sd_l, dx, dy, dz, dl = rates[:4] + (rates[4:8] if offset else (0.0,) * 4)
    return ("fuse.shoulder=drifting", f"fuse.shoulder_walk_m_s={walk_s:.4f}",
            f"fuse.upper_arm_walk_m_s={walk_l:.4f}", f"fuse.shoulder_sd_m={sd_s:.4f}",
            f"fuse.upper_arm_sd_m={sd_l:.4f}", f"fuse.shoulder_offset_x_m={side * dx:.4f}",
            f"fuse.shoulder_offset_y_m={dy:.4f}", f"fuse.shoulder_offset_z_m={dz:.4f}",
            f"fuse.upper_arm_offset_m={dl:.4f}")
