"""`[arm] shoulder_m / upper_arm_m / forearm_m = "auto"` on simulated tasks: `python
validation/arm_auto.py` writes docs/validation-arm-auto.md (part of `make validate`).

Each task (circle, rectangle, reach, figure8) × seeds with the simulator's defaults (MTw-class
IMU: 1° wandering orientation error, accelerometer bias; the occlusion and distractor the
defaults have) is simulated, calibrated and detected once; fuse then runs with the true arm
declared and with the arm "auto", each with the default method and with pf-constraint, and
compare scores both. Goals (issue 14): shoulder within 2 cm, lengths within 1 cm, wrist RMSE
within 20 % of the declared-model figure. A control row repeats one circle with an exact IMU
orientation.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from armtrack_cli import pipeline  # noqa: E402
from armtrack_cli.core.errors import ArmtrackError  # noqa: E402
from armtrack_cli.session.arm_file import read_arm_estimate  # noqa: E402
from armtrack_cli.simulate.arm_session import ArmSimSettings  # noqa: E402
from validation.from_mocap import as_auto  # noqa: E402

TASKS = ("circle", "rectangle", "reach", "figure8")
METHODS = ("arm-smoother", "pf-constraint")
GOALS = {"shoulder_cm": 2.0, "length_cm": 1.0, "wrist_ratio": 1.2}


def _wrist(folder: Path, out: Path, method: str) -> float:
    pipeline.fuse(folder, method=method, out=out)
    rows = pipeline.compare(folder, methods=(method,), out=out)["rows"]
    return next(r["rmse_cm"] for r in rows if r["joint"] == "wrist" and r["axis"] == "3d")


def _auto_copy(folder: Path) -> Path:
    """The session with its [arm] all "auto" (validation/from_mocap.as_auto), calibrate's and
    detect's outputs copied with their times, so they are not redone."""
    dest = as_auto(folder, folder.parent / f"{folder.name}-auto")
    shutil.copytree(folder / "armtrack", dest / "armtrack")
    return dest


def with_true_orientation(auto: Path, truth: Path, s: ArmSimSettings) -> np.ndarray:
    """The batch alone (pipeline/arm_model.estimate) on the same session with the IMU's true
    orientation in place of the gyro-anchored one: its shoulder error (cm), the part of the
    error the remaining constant orientation error is responsible for."""
    import dataclasses
    import importlib

    from armtrack_cli.pipeline import arm_model
    from armtrack_cli.session.config import load_session
    from armtrack_cli.session.imu import read_imu

    fuse_mod = importlib.import_module("armtrack_cli.pipeline.fuse")
    sess = load_session(auto)
    p = fuse_mod.prepare(sess, auto / "armtrack", fuse_mod.settings_for(None, (), kind=sess.kind)[0])
    imu = read_imu(sess.imu.file)
    ok = np.isfinite(imu.acc).all(1) & np.isfinite(imu.quat).all(1)
    q_true = np.load(truth)["imu_q_true"][ok]
    est = arm_model.estimate(sess, dataclasses.replace(p, q_anchored=q_true))
    return (est.shoulder - np.array(s.shoulder)) * 100


def session_row(folder: Path, s: ArmSimSettings) -> dict:
    """Declared and auto arm on one simulated session: wrist RMSE per method, and the auto
    estimate's errors against the true arm with its SDs (cm)."""
    pipeline.calibrate(folder)
    pipeline.detect(folder)
    auto = _auto_copy(folder)
    row = {"declared": {}, "auto": {}}
    for m in METHODS:
        row["declared"][m] = _wrist(folder, folder / "armtrack", m)
        row["auto"][m] = _wrist(auto, auto / "armtrack", m)
    est = read_arm_estimate(auto / "armtrack")
    row["d_shoulder"] = (np.array(est["shoulder_m"]) - np.array(s.shoulder)) * 100
    row["d_L1"] = (est["upper_arm_m"] - s.upper_arm_m) * 100
    row["d_L2"] = (est["forearm_m"] - s.forearm_m) * 100
    row["sd"] = np.r_[est["shoulder_sd_m"], est["upper_arm_sd_m"], est["forearm_sd_m"]] * 100
    row["d_shoulder_true_q"] = with_true_orientation(auto, folder.parent / f"{folder.name}.truth.npz",
                                                     s)
    m = METHODS[0]
    row["met"] = bool(np.linalg.norm(row["d_shoulder"]) <= GOALS["shoulder_cm"]
                      and max(abs(row["d_L1"]), abs(row["d_L2"])) <= GOALS["length_cm"]
                      and row["auto"][m] <= GOALS["wrist_ratio"] * row["declared"][m])
    return row


def line(name: str, r: dict) -> str:
    if "error" in r:
        return f"| {name} | not computable: {r['error']} ||||||||||"
    sh = ", ".join(f"{v:+.1f}" for v in r["d_shoulder"])
    sd = ", ".join(f"{v:.1f}" for v in r["sd"][:3])
    cells = " | ".join(f"{r['declared'][m]:.2f} | {r['auto'][m]:.2f}" for m in METHODS)
    return (f"| {name} | {cells} | {sh} ({sd}) | {np.linalg.norm(r['d_shoulder']):.1f} | "
            f"{r['d_L1']:+.1f} ({r['sd'][3]:.1f}) | {r['d_L2']:+.1f} ({r['sd'][4]:.1f}) | "
            f"{'yes' if r['met'] else 'no'} | {np.linalg.norm(r['d_shoulder_true_q']):.1f} |")


HEADER = ["| session | arm-smoother wrist RMSE, declared arm (cm) | … auto arm | pf-constraint, "
          "declared | … auto | shoulder error x, y, z (SD) cm | shoulder error, 3-D cm | "
          "L1 error (SD) cm | L2 error (SD) cm | all goals | shoulder error, 3-D cm, the batch "
          "with the true orientation |",
          "|---|---|---|---|---|---|---|---|---|---|---|"]


def write(out: Path, rows: list[tuple[str, dict]], wall: float, seeds: int) -> None:
    ok = [r for _, r in rows if "error" not in r and not _ == "control"]
    sh = [float(np.linalg.norm(r["d_shoulder"])) for r in ok]
    ln = [max(abs(r["d_L1"]), abs(r["d_L2"])) for r in ok]
    ratio = [r["auto"][METHODS[0]] / r["declared"][METHODS[0]] for r in ok]
    lines = [
        "# The arm model from the data on simulated tasks", "",
        f"Generated by `python validation/arm_auto.py --seeds {seeds}` (part of `make validate`) "
        f"in {wall:.0f} s. Each session (simulator defaults: MTw-class IMU with its 1° wandering "
        "orientation error and accelerometer bias, 20 s) is fused with the true arm declared and "
        "with `[arm] shoulder_m / upper_arm_m / forearm_m = \"auto\"` (fuse/arm_auto.py: a batch "
        "least-squares over the most varied stretch, with the gyro-anchored orientation of "
        "fuse/gyro_orientation.py and one constant orientation error estimated), scored by "
        "`compare`. Goals (issue 14): shoulder within 2 cm, lengths within 1 cm, wrist RMSE "
        "within 20 % of the declared-model figure (the default method, arm-smoother). SDs are "
        "the estimator's own.", "", *HEADER, *(line(n, r) for n, r in rows), "",
        f"Over the {len(ok)} sessions: shoulder error ≤ 2 cm on {sum(v <= 2 for v in sh)}, "
        f"max {max(sh, default=np.nan):.1f} cm; both lengths within 1 cm on "
        f"{sum(v <= 1 for v in ln)}, max {max(ln, default=np.nan):.1f} cm; wrist RMSE auto / "
        f"declared (arm-smoother) ≤ 1.2 on {sum(v <= 1.2 for v in ratio)}, max "
        f"{max(ratio, default=np.nan):.2f}; all goals on {sum(r['met'] for r in ok)}.", "",
        READING, ""]
    out.write_text("\n".join(lines))


READING = (
    "Reading. The batch sees the elbow only through the wrist and the IMU's forearm axis "
    "(eq. 2), and over a table-top task the elbow covers a small cap of its sphere, whose "
    "centre moves along the cap's normal by about ten times any systematic error in the "
    "elbow: a 0.3° tilt of the forearm axis (L2 · 0.006 = 1.5 mm at the elbow) moves the "
    "shoulder by 1-2 cm. The gyro-anchored orientation (fuse/gyro_orientation.py) leaves one "
    "constant error of that size (the reported error's mean over the session), and the batch "
    "cannot tell its tilt from the accelerometer's bias (both a nearly constant acceleration "
    "while the forearm turns little). The last column, the same batch given the true "
    "orientation, still misses by 0.7-2.3 cm: the cap's own ambiguity (the shoulder SDs, "
    "2-8 cm) is the floor, and the seed-0 sessions, whose constant tilt is the largest "
    "(0.34°), add about 1 cm to it and miss the wrist goal on every task. The wrist then "
    "follows the "
    "shoulder: the smoother's wrist lies on the estimated sphere, so the shoulder's error "
    "along the camera's line of sight becomes the wrist's, and the wrist goal (within 20 % "
    "of the declared arm's 0.1-0.4 cm) would need the shoulder to a few mm. The lengths' SDs "
    "(3-5 cm for L1) say the data hardly fix them: the estimates sit near the weak "
    "anthropometric prior (fuse/arm_auto.py: 0.30 and 0.26 m, SD 5 cm), which is 1 cm from "
    "the simulator's arm (0.31, 0.27 m), so the length errors are the prior's, and their "
    "meeting the 1 cm goal says little. Declared, "
    "tape-measured lengths with `shoulder_m = \"auto\"` remove two of the five unknowns; "
    "a longer or more varied stretch (a calibration movement sweeping the forearm through "
    "its range) narrows the cap's ambiguity.")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--tasks", default=",".join(TASKS))
    ap.add_argument("--out", default=str(REPO / "docs" / "validation-arm-auto.md"))
    args = ap.parse_args()
    t0 = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        runs = [(f"{t}-s{k}", ArmSimSettings(task=t, seed=k)) for t in args.tasks.split(",")
                for k in range(args.seeds)]
        runs.append(("control", ArmSimSettings(task="circle", seed=0,
                                               imu_errors={"orientation_rms_deg": 0.0})))
        for name, s in runs:
            folder = Path(tmp) / name
            pipeline.simulate(folder, s)
            try:
                rows.append((name, session_row(folder, s)))
            except ArmtrackError as e:  # a stage refused: the row says why
                rows.append((name, {"error": str(e).replace(tmp + "/", "")}))
            print(line(name, rows[-1][1]), flush=True)
    write(Path(args.out), rows, time.perf_counter() - t0, args.seeds)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
