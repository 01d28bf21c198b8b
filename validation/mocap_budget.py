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
from mocap_reading import READING

from armtrack_cli.fuse.models import ray_sphere

RAY_HEADER = ["| session | camera elevation (deg) | board pose error: rotation (deg), position "
              "(cm), Mahalanobis² | patch in view (frames) | detect ok | ok and in "
              "view | px error of ok, 99 % (max) | cos(ray, E − S), median (10 %) | "
              "abs(E − S), 5-95 % (cm) | shoulder moves, max (cm) |",
              "|---|---|---|---|---|---|---|---|---|---|"]
BUDGET_HEADER = ["| session | declared arm | true moving shoulder, declared L1 | best sphere in "
                 "hindsight | arm-smoother, fixed | arm-smoother, drifting | drifting + rest | "
                 "camera + IMU only (no arm) | camera + IMU + rest (no arm) |",
                 "|---|---|---|---|---|---|---|---|---|"]


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


STILL_M_S = 0.02  # "the hand rests" for the error split: true wrist speed below 2 cm/s


def where(est: np.ndarray, truth_npz: Path, reported: np.ndarray) -> dict:
    """Where the wrist error of one run is (cm): est (n, 3) m at the session's frames against
    the truth's frame_wrist, split along the true camera ray (its mean: + away from the camera)
    and across it, frames with a detection (``reported`` (n,) bool) and without, frames where
    the true wrist is still (speed < STILL_M_S) and moving."""
    tr = np.load(truth_npz)
    n = min(len(est), tr["frame_wrist"].shape[0])
    W, e = tr["frame_wrist"][:n], est[:n] - tr["frame_wrist"][:n]
    ray = W - _camera_centre(tr)
    ray /= np.linalg.norm(ray, axis=1)[:, None]
    along = np.einsum("ni,ni->n", e, ray)
    across = np.linalg.norm(e - along[:, None] * ray, axis=1)
    err = np.linalg.norm(e, axis=1)
    speed = np.interp(tr["frame_t"][:n], tr["t"], np.linalg.norm(tr["wrist_vel"], axis=1))
    still, seen = speed < STILL_M_S, np.asarray(reported[:n], bool)

    def rms(x, m):
        return float(np.sqrt(np.mean(x[m] ** 2)) * 100) if m.any() else float("nan")

    every = np.ones(n, bool)
    return {"rmse": rms(err, every), "along_mean": float(along.mean() * 100),
            "along": rms(along, every), "across": rms(across, every),
            "seen": rms(err, seen), "hidden": rms(err, ~seen), "n_hidden": int((~seen).sum()),
            "still": rms(err, still), "moving": rms(err, ~still), "n_still": int(still.sum()),
            "n": n}


def true_imu_text(text: str, q_true: np.ndarray, acc_bias: np.ndarray) -> str:
    """An Xsens MT Manager export (the simulator's imu.txt) with its orientation replaced by
    the true one (δθ = 0) and the accelerometer's bias removed (b_a = 0); noise kept. Rows are
    the simulator's samples in order (from-mocap sessions drop none)."""
    lines = text.splitlines()
    k = next(i for i, line in enumerate(lines) if not line.startswith("//"))
    cols = lines[k].split("\t")
    acc = [cols.index(f"Acc_{a}") for a in "XYZ"]
    qc = [cols.index(f"Quat_q{i}") for i in range(4)]
    rows = lines[k + 1:]
    if len(rows) != len(q_true):
        raise ValueError(f"{len(rows)} IMU rows but {len(q_true)} true orientations")
    out = lines[:k + 1]
    for row, q in zip(rows, q_true):
        cells = row.split("\t")
        for j, b in zip(acc, acc_bias):
            cells[j] = f"{float(cells[j]) - b:.6f}"
        for j, v in zip(qc, q):
            cells[j] = f"{v:.6f}"
        out.append("\t".join(cells))
    return "\n".join(out) + "\n"


def with_truth(folder: Path, out: Path, dest: Path, *, camera: bool = False,
               detections: bool = False, imu: bool = False) -> tuple[Path, Path]:
    """A copy of session ``folder`` (its files linked) and of its stage outputs ``out``
    (camera.yaml, detections.csv) with parts of the input replaced by the simulator's truth
    (OUT.truth.npz beside the session): the camera's true pose, the true wrist pixel on every
    frame `detect` reported, the IMU's true orientation and no accelerometer bias. Returns
    (session, outputs) for `armtrack fuse`."""
    from armtrack_cli.core.streams import CameraModel
    from armtrack_cli.session.camera_yaml import read_camera_yaml, write_camera_yaml

    tr = np.load(folder.parent / f"{folder.name}.truth.npz")
    session, work = dest / folder.name, dest / folder.name / "out"
    work.mkdir(parents=True)
    for f in folder.iterdir():
        if f.is_file() and not (imu and f.name == "imu.txt"):
            (session / f.name).symlink_to(f.resolve())
    if imu:
        (session / "imu.txt").write_text(true_imu_text((folder / "imu.txt").read_text(),
                                                       tr["imu_q_true"], tr["acc_bias"]))
    cam = read_camera_yaml(out / "camera.yaml")
    if camera:
        cam = CameraModel(cam.K, cam.dist, cam.width, cam.height, tr["R_WC"], tr["T_WC"],
                          cam.reprojection_error_px)
    write_camera_yaml(work / "camera.yaml", cam)
    det = (out / "detections.csv").read_text().splitlines()
    if detections:
        head, px = det[0].split(","), tr["frame_wrist_px"]
        iu, iv, iok, ifr = (head.index(c) for c in ("u", "v", "ok", "frame"))
        for i in range(1, len(det)):
            c = det[i].split(",")
            if c[iok] == "1" and int(c[ifr]) < len(px):
                c[iu], c[iv] = (f"{v:.6f}" for v in px[int(c[ifr])])
                det[i] = ",".join(c)
    (work / "detections.csv").write_text("\n".join(det) + "\n")
    return session, work


def pose_error(R_WC: np.ndarray, T_WC: np.ndarray, cov: np.ndarray, truth_npz: Path
               ) -> tuple[float, float, float]:
    """The board's camera pose (R_WC, T_WC) against the simulator's: the correction c = (φ, τ)
    that moves it onto the truth (fuse/camera_pose.moved: R = exp([φ]×) R_WC, T = exp([φ]×)
    T_WC + τ), as |φ| (deg), |τ| (cm) and its Mahalanobis² cᵀ Σ⁻¹ c under the board's
    covariance ``cov`` (camera_pose.board_covariance; χ² with 6 dof where Σ is honest)."""
    from scipy.spatial.transform import Rotation

    tr = np.load(truth_npz)
    dR = Rotation.from_matrix(tr["R_WC"] @ R_WC.T)
    c = np.r_[dR.as_rotvec(), tr["T_WC"] - dR.as_matrix() @ T_WC]
    return (float(np.degrees(np.linalg.norm(c[:3]))), float(np.linalg.norm(c[3:]) * 100),
            float(c @ np.linalg.solve(cov, c)))


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


def ray_row(name: str, det: dict, geo: dict, pose: tuple[float, float, float]) -> str:
    return (f"| {name} | {geo['elevation']:.0f} | {pose[0]:.2f}, {pose[1]:.2f}, {pose[2]:.1f} | "
            f"{det['seen']} of {det['n']} | {det['ok']} | "
            f"{det['both']} | {det['err'][0]:.2f} ({det['err'][1]:.2f}) | "
            f"{geo['cos'][0]:.2f} ({geo['cos'][1]:.2f}) | {geo['L1'][0]:.1f}-{geo['L1'][1]:.1f} | "
            f"{geo['moves']:.1f} |")


def budget_row(name: str, geo: dict, *smoothed: float) -> str:
    """The constraint's own error (declared, moving, hindsight) beside the smoother's figures
    (fixed, drifting, drifting + rest, no arm, no arm + rest)."""
    def g(key):
        rms, miss = geo[key]
        return f"{rms:.1f}" + (f" ({miss:.0%} of frames miss)" if miss > 0 else "")
    cells = " | ".join("—" if np.isnan(x) else f"{x:.2f}" for x in smoothed)
    return f"| {name} | {g('declared')} | {g('moving')} | {g('hindsight')} | {cells} |"


WHERE_HEADER = ["| session | scored | along the ray, mean | across, RMS | frames with / without a "
                "detection (without) | hand still / moving (still) | true camera pose | + exact "
                "detections | + true δθ, b_a | all true, no arm | all true, no rest |",
                "|---|---|---|---|---|---|---|---|---|---|---|"]


def where_row(name: str, w: dict, truth_runs: list[float]) -> str:
    """``where``'s split of the scored run, then the wrist RMSE as the truth replaces inputs."""
    def f(x):
        return "—" if np.isnan(x) else f"{x:.2f}"
    cells = " | ".join(f(x) for x in truth_runs)
    return (f"| {name} | {w['rmse']:.2f} | {w['along_mean']:+.2f} | {w['across']:.2f} | "
            f"{f(w['seen'])} / {f(w['hidden'])} ({w['n_hidden']}) | {f(w['still'])} / "
            f"{f(w['moving'])} ({w['n_still']}) | {cells} |")


def rates_line(rates: list[tuple[float, ...]]) -> str:
    """The drifting arm's settings used, each trial's from the other trials (walk_rates,
    arm_priors), and the rest update's and camera rows' (rest_speed, pixel_sd, pixel_tau)."""
    sh, ln, psh, pln, dx, dy, dz, dl, rest, px, tau = np.array(rates).T * 100
    return (f"The drifting arm's settings, each trial's measured on the other six recordings: "
            f"random walks (median over trials of the RMS change over 1 s, per √s) of the "
            f"shoulder {sh.min():.2f}-{sh.max():.2f} cm/√s per axis and of the upper arm's length "
            f"{ln.min():.2f}-{ln.max():.2f} cm/√s; the prior's centre, the declared arm moved by "
            f"the mean over trials of the hindsight sphere's centre less the declared shoulder "
            f"(x for a right arm, mirrored for the left) and of its radius less the declared "
            f"L1: x {dx.min():+.1f} to {dx.max():+.1f}, y {dy.min():+.1f} to {dy.max():+.1f}, "
            f"z {dz.min():+.1f} to {dz.max():+.1f} cm, radius {dl.min():+.1f} to "
            f"{dl.max():+.1f} cm (the elbow turns about a point behind and below the shoulder "
            f"landmark, on a wider sphere); its SDs, the trials' spread about that mean, "
            f"{psh.min():.1f}-{psh.max():.1f} cm per axis and {pln.min():.1f}-{pln.max():.1f} cm. "
            f"The rest update's SD, the resting hand's velocity (RMS per axis over runs of "
            f"≥ 10 frames where the wrist is slower than {STILL_M_S * 100:.0f} cm/s) times √τ, "
            f"τ its autocorrelation time in frames (the rows are independent, the swaying "
            f"hand's velocity is not; median over trials): "
            f"{rest.min():.2f}-{rest.max():.2f} cm/s. The camera rows' SD (`fuse.pixel_sigma`, "
            f"the recipe's 4 px elsewhere), `detect`'s wrist pixel against the truth (RMS per "
            f"axis over the ok frames): {px.min() / 100:.2f}-{px.max() / 100:.2f} px, × √τ on "
            f"the frames whose detections move less than 0.5 px a frame, τ the integrated "
            f"autocorrelation time of detect's error on such frames of the other trials "
            f"(validation/detect_correlation.py): {tau.min() / 100:.1f}-{tau.max() / 100:.1f} "
            f"frames. "
            f"The defaults (`shoulder_walk_m_s` 0.011, `upper_arm_walk_m_s` 0.023, "
            f"`shoulder_sd_m` 0.11, `upper_arm_sd_m` 0.06, offsets 0) centre the prior on the "
            f"declared arm, as wide as the spheres lie from it over all seven (RMS).")


def truth_section(truths: list[str]) -> list[str]:
    """The error budget of the scored run (validation/from_mocap.py truth_row), and its
    reading."""
    return [
        "Where the scored run's error is, and what bounds it: wrist 3-D RMSE (cm) of the drifting "
        "arm + rest with the declared arm, split along the true camera ray (its mean; − towards "
        "the camera) and across it, over frames with and without a detection, and over frames "
        f"where the true wrist is still (below {STILL_M_S * 100:.0f} cm/s) and moving; then the "
        "same run with the simulator's truth replacing its input, one part more at a time: the "
        "camera's true pose (instead of the board's, from the video's first frame), the true "
        "wrist pixel on every frame `detect` reported, the IMU's true orientation and no "
        "accelerometer bias (δθ = 0, b_a = 0 given: the Xsens file rewritten, noise kept); "
        "with all of that, the arm constraint off (camera + IMU + rest), and the rest update "
        "off (drifting arm, no rest) (validation/mocap_budget.py `where`, `with_truth`).", "",
        *WHERE_HEADER, *truths, ""]


def section(rays: list[str], budget: list[str], rates: list | None = None,
            truths: list[str] | None = None) -> list[str]:
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
        "arm) and with the arm constraint off (`--set fuse.constraint_sigma_m=1.0 --set "
        "fuse.init_pos_sigma_m=0.5`: camera + IMU alone), without and with the rest update:",
        "",
        *BUDGET_HEADER, *budget, "",
        *([rates_line(rates), ""] if rates else []),
        *(truth_section(truths) if truths else []),
        *READING]
