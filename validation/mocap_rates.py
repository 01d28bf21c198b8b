"""What the scored run of a real-motion session takes from the other recordings
(validation/from_mocap.py, leave-one-out): the drifting arm's random-walk rates and prior, and
the resting hand's velocity (the rest update's SD), each measured on the truth of trials other
than the one scored."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
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


def rest_speed(truths: list[Path]) -> float:
    """How fast a resting hand moves, measured on recordings: the median over trials of the
    wrist velocity's RMS per axis where its speed is below STILL_M_S (m/s). The rest
    update's SD (validation/from_mocap.py takes it from the trials other than the one scored):
    the recordings' still hand is not still to the mm (tremor, sway, marker noise)."""
    rms = []
    for path in truths:
        tr = np.load(path)
        v = tr["wrist_vel"][np.linalg.norm(tr["wrist_vel"], axis=1) < STILL_M_S]
        rms.append(np.sqrt(np.mean(v**2)) if v.size else np.nan)
    return float(np.nanmedian(rms))
