"""Elbow flexion from the UE-ADL Vicon trials (CAST from the clusters) beside the authors'
processed angles: `python validation/ue_adl.py` writes docs/validation-ue-adl.md (part of
`make validate`; needs ../shared/realdata/ue-adl/).

Besides armtrack's definitions it asks what the authors' angle is: their elbow flexion is
fitted, over the frames of the other five trials, as the Z-X-Y flexion of our ISB frames turned
by two fixed rotations (one on the humerus frame, one on the forearm frame, 6 parameters and
an offset), and the fitted frames are then used on the held-out trial (leave-one-out). A fixed
rotation of the frames is a different definition of the anatomical axes; if it reproduces
their angle on trials it was not fitted on, the difference is the axes, not soft tissue,
filtering or the window.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from armtrack_cli.compare import functional_axis, isb_angles  # noqa: E402
from armtrack_cli.compare.joint_centres import carry_landmark, cluster_names  # noqa: E402
from armtrack_cli.compare.peer_angles import (  # noqa: E402
    ArmMarkers,
    align_window,
    flexion_axis,
    lowpass,
    rom_beside_peer,  # noqa: E402
)
from armtrack_cli.session.groundtruth import read_markers  # noqa: E402

UE_ADL = REPO.parent / "shared" / "realdata" / "ue-adl"
OUT = REPO / "docs" / "validation-ue-adl.md"
TRIALS = {"DR1": "drinking", "DR2": "drinking", "CR1": "combing", "FR1": "forward reach",
          "FR2": "forward reach", "AR1": "reach across"}


def trial_rom(folder: Path, trial: str, static=None) -> dict[str, float]:
    static = static or read_markers(folder / "ADL001_static.csv")
    peer = pd.read_csv(folder / f"ADL001{trial}angles.csv")
    tr = read_markers(folder / f"ADL001{trial}.csv")
    out = rom_beside_peer(static, tr, peer["elbow flexion-extension"].to_numpy(),
                          peer["Finger Velocity"].to_numpy())
    arm = ArmMarkers()
    n1, epi, _ = flexion_axis(static, tr, arm, *(cluster_names(static.names, (c + "*",)) for c
                                                 in (arm.upper_cluster, arm.fore_cluster)))
    return {**out, "axis_from_epicondylar_deg": functional_axis.angle_deg(n1, epi)}


def joint_rotations(folder: Path, trial: str, static, arm: ArmMarkers | None = None):
    """(R_hf (K, 3, 3) of the ISB frames, each carried by its own cluster, over the authors'
    window; the authors' elbow flexion (K,)), finite frames only."""
    arm = arm or ArmMarkers()
    tr = read_markers(folder / f"ADL001{trial}.csv")
    peer = pd.read_csv(folder / f"ADL001{trial}angles.csv")
    speed = np.linalg.norm(np.gradient(lowpass(tr.marker(arm.fingertip), tr.rate_hz), axis=0),
                           axis=1) * tr.rate_hz
    first, _ = align_window(speed, peer["Finger Velocity"].to_numpy())
    up = cluster_names(static.names, (arm.upper_cluster + "*",))
    fo = cluster_names(static.names, (arm.fore_cluster + "*",))
    c = {m: carry_landmark(static, tr, m, up) for m in (arm.shoulder, *arm.epicondyles)}
    f = {m: carry_landmark(static, tr, m, fo) for m in (*arm.epicondyles, *arm.styloids)}
    R = isb_angles.joint_rotation(c[arm.shoulder], *(c[m] for m in arm.epicondyles),
                                  *(f[m] for m in arm.styloids),
                                  fore_el=f[arm.epicondyles[0]], fore_em=f[arm.epicondyles[1]])
    pe = peer["elbow flexion-extension"].to_numpy()
    R = R[first:first + pe.size]
    ok = np.isfinite(R).all(axis=(1, 2))
    return R[ok], pe[ok]


def _flexion(p: np.ndarray, R: np.ndarray) -> np.ndarray:
    A = Rotation.from_rotvec(p[:3]).as_matrix()
    B = Rotation.from_rotvec(p[3:6]).as_matrix()
    return isb_angles.zxy_deg(A.T @ R @ B)[:, 0] + p[6]


def fit_axes(data: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """The fixed rotations (rotation vectors of A on the humerus, B on the forearm) and offset
    that bring the Z-X-Y flexion of Aᵀ R_hf B closest to the authors' (least squares)."""
    def res(p):
        return np.concatenate([_flexion(p, R[::3]) - pe[::3] for R, pe in data])
    return least_squares(res, np.zeros(7)).x


def axes_words(p: np.ndarray) -> str:
    A = Rotation.from_rotvec(p[:3]).as_matrix()
    B = Rotation.from_rotvec(p[3:6]).as_matrix()
    tilt_z = np.degrees(np.arccos(np.clip(A[2, 2], -1, 1)))
    tilt_y = np.degrees(np.arccos(np.clip(B[1, 1], -1, 1)))
    return (f"their flexion axis lies {tilt_z:.0f}° from the epicondylar axis (ISB Z of the "
            f"humerus) and their forearm long axis {tilt_y:.0f}° from the ISB one (ulnar "
            "styloid to the epicondyles' midpoint)")


def main(folder: Path = UE_ADL, out: Path = OUT) -> None:
    start = time.perf_counter()
    static = read_markers(folder / "ADL001_static.csv")
    data = {t: joint_rotations(folder, t, static) for t in TRIALS}
    rows, carry = [], []
    for trial, task in TRIALS.items():
        r = trial_rom(folder, trial, static)
        q = fit_axes([d for k, d in data.items() if k != trial])
        R, pe = data[trial]
        r["fitted_rom_deg"] = float(np.ptp(lowpass(_flexion(q, R), 100.0)))
        ab = isb_angles.zxy_deg(R)
        ext = ab[:, 0] < np.percentile(ab[:, 0], 10)  # the most extended tenth
        carry.append(f"{trial} {np.mean(np.abs(ab[ext, 1])):.0f}°")
        rows.append((trial, task, r))
    full = fit_axes(list(data.values()))
    resid = np.concatenate([_flexion(full, R) - pe for R, pe in data.values()])
    lines = _text(rows, full, carry, float(np.std(resid)), time.perf_counter() - start)
    out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def _text(rows, full, carry, resid_sd, seconds) -> list[str]:
    head = ["# Joint centres and elbow angles from Vicon clusters, checked on UE-ADL", "",
            f"Generated by `python validation/ue_adl.py` in {seconds:.0f} s (part of `make "
            "validate`; needs `../shared/realdata/ue-adl/`, MIT; tested in "
            "`tests/test_vicon_cast.py`). One healthy adult, Vicon at 100 Hz: clusters of four "
            "markers on the shoulder (RSHO), upper arm (RUAR) and forearm (RLAR); the landmarks "
            "(greater tubercle RGTH, epicondyles RLEP/RMEP, styloids RSPR/RSPU) are worn only in "
            "the static trial.", "",
            "Method (armtrack's `[groundtruth] static` + `clusters`, `compare/joint_centres.py`): "
            "each landmark is fixed relative to its cluster by the static trial's mean (calibrated "
            "anatomical system technique, Cappozzo 1995) and carried through the movement trial by "
            "the per-frame least-squares rigid fit of the cluster (Umeyama 1991, no scale). Elbow "
            "centre = mid(RLEP, RMEP), wrist centre = mid(RSPR, RSPU), shoulder point = RGTH (the "
            "data hold no glenohumeral centre). The window is the authors' (their files start at "
            "movement onset and end at offset, 3 % of the fingertip's peak speed): found by "
            "matching the fingertip speed (low-passed 10 Hz, as theirs) to their finger-velocity "
            "column; every window correlates at r ≥ 0.985. Angles are low-passed 10 Hz (4th-order "
            "Butterworth, forward-backward), as the authors'.", "",
            "Elbow flexion range of motion, degrees (difference to the authors' in brackets):", "",
            "| trial | task | authors' RoM | three-point | ISB (own clusters) | ISB (epicondyles "
            "on upper arm) | **ISB, functional flexion axis** (axis: its angle to the epicondylar one) "
            "| ISB, axes fitted on the other five trials | window r |",
            "|---|---|---|---|---|---|---|---|---|"]
    for trial, task, r in rows:
        p = r["peer_rom_deg"]
        cells = [f"{r[k]:.1f} ({r[k] - p:+.1f})" for k in
                 ("three_point_rom_deg", "isb_rom_deg", "isb_upper_epicondyles_rom_deg",
                  "functional_axis_rom_deg", "fitted_rom_deg")]
        cells[3] += f", axis {r['axis_from_epicondylar_deg']:.0f}°"
        head.append(f"| {trial} | {task} | {p:.1f} | " + " | ".join(cells) +
                    f" | {r['window_correlation']:.3f} |")
    n_isb = sum(abs(r["isb_rom_deg"] - r["peer_rom_deg"]) < 5 for *_, r in rows)
    n_fit = sum(abs(r["fitted_rom_deg"] - r["peer_rom_deg"]) < 5 for *_, r in rows)
    n_fun = sum(abs(r["functional_axis_rom_deg"] - r["peer_rom_deg"]) < 5 for *_, r in rows)
    worst = max(abs(r["functional_axis_rom_deg"] - r["peer_rom_deg"]) for *_, r in rows)
    tilt = [r["axis_from_epicondylar_deg"] for *_, r in rows]
    return head + ["", *FUNCTIONAL.format(n_fun=n_fun, n=len(rows), worst=worst, lo=min(tilt),
                                          hi=max(tilt)).split("\n"),
                   "", *WHY.format(carry=", ".join(carry), n_isb=n_isb, n_fit=n_fit,
                                   n=len(rows), axes=axes_words(full),
                                   resid=resid_sd).split("\n")]


FUNCTIONAL = """**The functional flexion axis** (`functional_axis` in `compare/peer_angles.py`;
`compare/functional_axis.py`): the same ISB frames, with the humerus' Z axis the elbow's
flexion axis found from the trial's own motion instead of the line through the epicondyles.
The forearm cluster's rotation relative to the upper-arm cluster gives the relative angular
velocity ω (finite rotations over 100 ms); its pronation part, along the forearm's long axis
(ulnar styloid to the epicondyles' midpoint, from the static trial), is taken out, and the
axis is the principal direction of what is left (the eigenvector of Σ ω⊥ω⊥ᵀ: the mean helical
axis, each instant weighted by its squared angular speed; Woltring et al. 1985, reviewed by
Ehrig et al. 2007). Nothing is fitted to the authors' angles. It matches their RoM within 5° on
{n_fun} of {n} trials (largest difference {worst:.1f}°), and it lies {lo:.0f}–{hi:.0f}° from the
epicondylar axis, where the fit to their angles put theirs (below). On a synthetic two-hinge
elbow with clusters of four and 0.5 mm marker noise the axis comes back within 1.5° of the true one
when it is normal to the forearm's long axis, and tilted by about 0.9 × its departure from
normal when it is not (tests/test_functional_axis.py). ISB (epicondylar Z) stays
armtrack's definition; the functional axis is the named alternative for labs whose model
defines the axis by motion."""

WHY = """**How a three-point angle and their Euler angle differ, precisely.** The three-point angle φ
(180° − the angle at the elbow centre between the shoulder point and the wrist centre, what
armtrack's `elbow_flexion_*` measures use) is the angle between the two segments' long axes.
The authors' elbow flexion is the first angle a of the forearm's rotation relative to the
humerus decomposed Z-X-Y (R = Rz(a)·Rx(b)·Ry(c): flexion about the humerus' medio-lateral
axis, then the carrying (varus-valgus) angle b, then pronation c; Wu et al. 2005 §3.3). The
forearm's long axis in the humerus frame is Rz(a)Rx(b)e_y = (−sin a cos b, cos a cos b, sin b),
so **cos φ = cos a · cos b** (tests/test_vicon_cast.py checks this identity): pronation does
not enter, and φ ≥ |a|, by most where the elbow is extended and the carrying angle is large
(a = 20°, b = 15° give φ = 24.9°). The three-point range is therefore the smaller one: its
least value is raised by the carrying angle at extension (mean |b| over each trial's most
extended tenth: {carry}). Two more differences enter with real markers: the three-point
forearm line runs to the wrist centre, the ISB forearm axis to the ulnar styloid (a fixed
tilt of about 6°, which pronation swings around the axis), and any difference in the
points (greater tubercle for the glenohumeral centre) tilts both.

**Which axes the authors used.** ISB frames from the clusters (Wu et al. 2005: humerus from
GH, EL, EM; forearm from US, RS and the epicondyles' midpoint; Z-X-Y, first angle) match the
authors' RoM within 5° on {n_isb} of {n} trials: within 5° on drinking and combing when each
segment's frame is carried by its own cluster, but 5–7° over on the reaching trials; carrying
the epicondyles by the upper-arm cluster in both frames matches reaching within 2.4° but
undershoots drinking by 8–9°. The authors' angle is explained without soft tissue: when the same
ISB frames are turned by two fixed rotations fitted to the authors' angle on the other five
trials (leave-one-out; a different definition of the anatomical axes, nothing that varies in
time), the held-out trial's RoM matches within 5° on {n_fit} of {n} trials, and the fit on all six
leaves a residual of {resid:.1f}° SD per frame. Fitted on all six trials, {axes}.
The authors' model (Freitas & Scholz 2009, "adapted") is not published in enough detail to
say which landmarks set those axes; a functional glenohumeral centre (sphere fit of the
upper-arm cluster in the shoulder cluster's frame, tried) moves the absolute angles by 8–10°
but the RoM by at most 2.3°, so the shoulder point is not the cause. The fitted column is a
diagnosis, calibrated on the authors' own angles: armtrack computes the ISB definition, and
its RoM can differ from a lab's by 5–7° when that lab defines the axes otherwise."""


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else UE_ADL)
