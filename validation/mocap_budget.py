"""Where the error of a session from real motion comes from (validation/from_mocap.py's UE-ADL
tables, docs/validation-from-mocap.md): detection against the rendered truth, and the
geometry of the arm constraint against the recording, each measured apart from the filter.

- ``detection``: frames where the patch faces the camera inside the image (the renderer's own
  flag) against frames `detect` reports (ok = 1), and the pixel error of those.
- ``geometry``: the constraint alone, with everything else exact. Each frame's true camera ray
  through the wrist is intersected with the elbow's sphere, E = W − L2 u on |E − S| = L1 (Tao &
  Hu eq. 15, the true forearm axis u), the root nearer the truth taken: the distance from the
  true wrist along the ray is the error the arm model by itself leaves, for (a) the declared
  arm (the shoulder's mean, the lengths' medians), (b) the true moving shoulder S(t) with the
  declared L1 (a drifting shoulder that knew the shoulder exactly), (c) the sphere fitted to
  this trial's own elbow path in hindsight (least squares, centre and radius). Its
  sensitivity is 1 / cos of the angle between the ray and the sphere's normal E − S (column
  "cos").
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armtrack_cli.fuse.models import ray_sphere

RAY_HEADER = ["| session | camera elevation (deg) | patch in view (frames) | detect ok | ok and in "
              "view | px error of ok, 99 % (max) | cos(ray, E − S), median (10 %) | "
              "abs(E − S), 5-95 % (cm) | shoulder moves, max (cm) |",
              "|---|---|---|---|---|---|---|---|---|"]
BUDGET_HEADER = ["| session | declared arm | true moving shoulder, declared L1 | best sphere in "
                 "hindsight | arm-smoother, fixed | arm-smoother, drifting | camera + IMU only "
                 "(no arm) |", "|---|---|---|---|---|---|---|"]


def _camera_centre(tr) -> np.ndarray:
    return -tr["R_WC"].T @ tr["T_WC"]


def _along_ray(C, ray, u, S, L1, L2, lam_true) -> np.ndarray:
    """Signed distance along each ray from the true wrist to the constraint's root nearer it:
    the wrist W = C + λ r with |W − L2 u − S| = L1 is the ray meeting the sphere about
    S + L2 u (models.ray_sphere); NaN where the ray misses it."""
    near, far, miss = ray_sphere(C, ray, S + L2 * u, L1)
    lam = np.where(np.abs(near - lam_true) < np.abs(far - lam_true), near, far)
    return np.where(miss > 0, np.nan, lam - lam_true)


def sphere_fit(P: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares sphere through points P (n, 3): |P|² = 2 P·c + (r² − |c|²), linear."""
    A = np.c_[2 * P, np.ones(len(P))]
    sol = np.linalg.lstsq(A, np.sum(P**2, 1), rcond=None)[0]
    return sol[:3], float(np.sqrt(sol[3] + sol[:3] @ sol[:3]))


def geometry(truth_npz: Path) -> dict:
    """The arm constraint's own along-ray error (cm, RMS over frames; misses counted apart)."""
    tr = np.load(truth_npz)
    C = _camera_centre(tr)
    W, E, S = tr["frame_wrist"], tr["frame_elbow"], tr["frame_shoulder"]
    d = W - C
    lam = np.linalg.norm(d, axis=1)
    ray = d / lam[:, None]
    u = (W - E) / np.linalg.norm(W - E, axis=1)[:, None]
    Sd, L1, L2 = tr["arm"][:3], float(tr["arm"][3]), float(tr["arm"][4])
    Sc, Lc = sphere_fit(E)
    out = {}
    for key, centre, radius in (("declared", Sd, L1), ("moving", S, L1), ("hindsight", Sc, Lc)):
        e = _along_ray(C, ray, u, np.broadcast_to(centre, W.shape), radius, L2, lam)
        out[key] = (float(np.sqrt(np.nanmean(e**2)) * 100), float(np.mean(np.isnan(e))))
    normal = (E - Sd) / np.linalg.norm(E - Sd, axis=1)[:, None]
    cos = np.abs(np.einsum("ni,ni->n", normal, ray))
    out.update(cos=(float(np.median(cos)), float(np.percentile(cos, 10))),
               elevation=float(np.degrees(np.arcsin(-tr["R_WC"][2, 2]))),  # optical axis
               L1=np.percentile(np.linalg.norm(E - S, axis=1), [5, 95]) * 100,
               moves=float(np.linalg.norm(S - S.mean(0), axis=1).max() * 100))
    return out


def detection(folder: Path, truth_npz: Path) -> dict:
    """Patch in view (renderer) against `detect`'s ok, and the px error of ok frames."""
    tr = np.load(truth_npz)
    det = np.genfromtxt(folder / "armtrack" / "detections.csv", delimiter=",", names=True)
    n = tr["frame_t"].size
    ok = det["ok"][:n] == 1
    seen = tr["frame_patch_visible"][:n].astype(bool)
    px = tr["frame_wrist_px"][:n]
    err = np.hypot(det["u"][:n] - px[:, 0], det["v"][:n] - px[:, 1])[ok]
    return {"seen": int(seen.sum()), "ok": int(ok.sum()), "both": int((ok & seen).sum()),
            "n": n, "err": (float(np.percentile(err, 99)), float(err.max())) if err.size else
            (np.nan, np.nan)}


def ray_row(name: str, det: dict, geo: dict) -> str:
    return (f"| {name} | {geo['elevation']:.0f} | {det['seen']} of {det['n']} | {det['ok']} | "
            f"{det['both']} | {det['err'][0]:.2f} ({det['err'][1]:.2f}) | "
            f"{geo['cos'][0]:.2f} ({geo['cos'][1]:.2f}) | {geo['L1'][0]:.1f}-{geo['L1'][1]:.1f} | "
            f"{geo['moves']:.1f} |")


def budget_row(name: str, geo: dict, fixed: float, drifting: float, no_arm: float) -> str:
    def g(key):
        rms, miss = geo[key]
        return f"{rms:.1f}" + (f" ({miss:.0%} of frames miss)" if miss > 0 else "")
    cells = " | ".join("—" if np.isnan(x) else f"{x:.2f}" for x in (fixed, drifting, no_arm))
    return f"| {name} | {g('declared')} | {g('moving')} | {g('hindsight')} | {cells} |"


def section(rays: list[str], budget: list[str]) -> list[str]:
    """The two tables and their reading, as lines of docs/validation-from-mocap.md."""
    if not rays:
        return []
    return [
        "### Where the error is", "",
        "Detection and geometry of each session (validation/mocap_budget.py): the patch in "
        "view (facing the camera, inside the image: the renderer's flag) against `detect`'s "
        "ok = 1 and their pixel error; the cosine between the camera ray through the elbow and "
        "the sphere's normal E − S about the declared shoulder (an error δr of the sphere moves "
        "the estimate δr / cos along the ray); how far the shoulder point moves and how much "
        "|E − S| varies.", "",
        *RAY_HEADER, *rays, "",
        "Wrist error along the camera ray (RMS, cm) that the arm constraint leaves by itself, "
        "everything else exact (true ray, true forearm axis; the root nearer the truth), beside "
        "the arm-smoother's wrist 3-D RMSE with the fixed and the drifting shoulder (declared "
        "arm) and with the arm constraint off (`--set fuse.constraint_sigma_m=1.0`: camera + "
        "IMU alone):", "",
        *BUDGET_HEADER, *budget, "",
        "**Reading.** *Detection* was the first limit: with the patch in view on every frame of "
        "AR1, FR1 and FR2, `detect` had reported 53, 21 and 30 of 108, 87 and 103 frames. As the "
        "hand came towards the camera its back turned face-on and the patch's area grew up to 15 % "
        "a frame; the mass check compared it with the running median of the last 8 accepted "
        "masses, which lags by half its window, took the growth for a neighbour joining and "
        "lost the patch; at rest it was not re-linked (over 2 s). The band now follows the "
        "masses' Theil–Sen trend (detect/patch_check.py): every frame in view and not edge-on "
        "is reported, on the patch to a pixel (first table). Frames still not reported are the "
        "patch seen nearly edge-on (aspect > `max_aspect` = 3).", "",
        "*The camera* was the second: moving a 45° camera back and up until a reach fitted in "
        "the image had put it 30-37° above the table, where the ray through the elbow was "
        "nearly tangent to the sphere on the reaches (median cos 0.02, 0.15, 0.12 on AR1, FR1, "
        "FR2; the ray missed the declared sphere on 81 % of AR1's frames). The simulator now "
        "looks down at 65° (the recording guide's \"in front of and above the table, looking "
        "down\"), which also shows the back of the wrist more often.", "",
        "*The arm model* is the bound. The declared sphere alone leaves 5-6 cm along the ray "
        "(column 2), and so would a drifting shoulder that knew the shoulder point exactly on "
        "every frame (column 3): the shoulder point of these recordings (the greater tubercle, "
        "carried by the shoulder cluster) is not the centre the elbow turns about, and "
        "|E − S| varies by 4-7 cm within a trial (first table), so a constant upper-arm length "
        "about it is wrong by up to 3 cm and the ray multiplies that by 1/cos. A sphere does "
        "fit each trial's elbow path (column 4: under 1.5 cm, on the short arcs of these 3-8 s "
        "trials), but its centre lies 7-37 cm from the landmark (measured), far outside any "
        "prior about the declared shoulder.", "",
        "*What works* is that sphere estimated from the session: `[arm] … = \"auto\"` with "
        "the fixed shoulder (second table, column 5) is the arm-smoother's best or near-best "
        "figure on every trial, within 1.5 cm on all seven (0.44-1.47 cm at the last run). "
        "*The drifting shoulder* cannot find that sphere from the data: the camera sees the "
        "wrist only and the IMU the forearm, so nothing observes the shoulder but the "
        "constraint itself; freeing it hands the depth along the ray to the IMU's double "
        "integral, and the drifting column moves towards the no-arm column (last). With the "
        "declared arm it helps (the wrong sphere is let go of) but stays 1.9-6.6 cm; with the "
        "auto arm it is within 1.5 cm on AR1, DL1, DR1 and DR2 and worse than the fixed "
        "shoulder on CR1, FR1 and FR2. Its settings did not change that when measured (before "
        "the arm smoother tracked the IMU's orientation error with the gyroscope; auto arm of "
        "AR1, CR1, FR1, FR2, fixed 1.97, 3.36, 1.49, 2.73 cm: `shoulder_sd_m = 0.01` 2.12, "
        "5.45, 1.66, 2.99; a near random walk, `shoulder_tau_s = 20`, 2.57, 5.07, 1.71, 3.15; "
        "`shoulder_sd_m = 0.0001` gives the fixed figure back). Issue 14's ≤ 1.5 cm with the "
        "drifting shoulder is met on four trials with the auto arm and on none with the "
        "declared arm: even an exact shoulder leaves the declared length several cm off along "
        "the ray (column 3), and where the patch is hidden (CR1: a third of the frames, the "
        "back of the wrist turned away while combing) camera and IMU alone are the limit "
        "(last column).", ""]
