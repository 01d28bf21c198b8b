"""The multi-seed study of ukf-palm (issue 11), written to docs/palm-validation.md.

Simulated palm sessions (wrist-rom and reach-grasp × seeds): a clutter blob on the table
throughout, a second one appearing beside the hand mid-session, and one palm marker hidden
for 1.2 s. Each goes through calibrate -> detect -> fuse -> compare exactly as a user runs
them, twice: with armtrack's defaults (projections and depths at every frame) and with the
cordella-ukf-palm recipe (the paper's filter: depth at the initialisation only). compare
scores against the Qualisys palm markers; association is checked against the simulator's
truth (which blob is which marker).

    python validation/palm.py [--seeds 3] [--duration 12] [--out docs/palm-validation.md]
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from armtrack_cli import pipeline  # noqa: E402
from armtrack_cli.compare.palm import association_score  # noqa: E402
from armtrack_cli.simulate.palm_session import PalmSimSettings  # noqa: E402

TASKS = ("wrist-rom", "reach-grasp", "wrist-deviation", "wrist-flexion")
CONFIGS = {"defaults": None, "cordella-ukf-palm": "cordella-ukf-palm"}
HIDE_START, HIDE_S, CLUTTER2_S = 4.0, 1.2, 6.0
GOALS = "angle RMSE ≤ 2°, WRIST RMSE ≤ 5 mm, RoM within 2°, association ≥ 99 %"


def _read(path: Path) -> pd.DataFrame:
    return pd.read_csv(path, comment="#")


def _blobs(dest: Path, n: int):
    det, asc = _read(dest / "detections.csv"), _read(dest / "associations-ukf-palm.csv")
    names = ["WRIST", "MCP2", "MCP3", "MCP4", "MCP5", "CMC1"]
    code = asc["marker"].map(lambda m: names.index(m) if m in names else -1).to_numpy()
    blobs, mob = [np.zeros((0, 2))] * n, [np.zeros(0, int)] * n
    for f, g in det.groupby("frame"):
        blobs[f] = g[["u", "v"]].to_numpy()
        mob[f] = code[asc["frame"].to_numpy() == f][g["blob"].to_numpy()]
    return blobs, mob


def score_session(folder: Path, dest: Path, r_fuse: dict) -> dict:
    pipeline.compare(folder, out=dest)
    truth = dict(np.load(folder.parent / f"{folder.name}.truth.npz"))
    traj = _read(dest / "trajectory-ukf-palm.csv")
    ang_err = _read(dest / "wrist-angle-errors.csv").set_index("angle")
    meas = _read(dest / "measures.csv")
    meas = meas[meas["segment"] == "session"].set_index("measure")
    pos = _read(dest / "errors.csv").set_index("axis")
    n = len(traj)
    blobs, mob = _blobs(dest, n)
    clutter = np.array([truth["clutter_px"], truth.get("clutter2_px", [np.nan, np.nan])])
    a = association_score(blobs, mob, truth["frame_marker_px"], truth["frame_marker_visible"],
                          clutter)
    t = traj["t"].to_numpy()
    e = np.abs(traj[["flexion_deg", "deviation_deg", "pronation_deg"]].to_numpy()
               - truth["frame_angles_deg"][:n])
    occl = (t >= HIDE_START) & (t < HIDE_START + HIDE_S + 1.0)
    return {"session": folder.name, "fps": r_fuse["frames_per_s"],
            **{f"{k}_rmse_deg": float(ang_err.loc[k, "rmse_deg"]) for k in
               ("flexion", "deviation", "pronation")},
            "wrist_rmse_mm": float(pos.loc["3d", "rmse_cm"]) * 10,
            **{f"{k}_rom_err_deg": float(ang_err.loc[k, "rom_error_deg"]) for k in
               ("flexion", "deviation", "pronation")},
            **{f"{k}_rom_p5_p95_err_deg": float(ang_err.loc[k, "rom_p5_p95_error_deg"])
               for k in ("flexion", "deviation", "pronation")},
            **{f"{k}_rom_err_pkg_deg": float(meas.loc[f"wrist_{k}_rom", "error"]) for k in
               ("flexion", "deviation", "pronation")},
            "assoc_pct": 100 * a.accuracy, "assoc_wrong": a.wrong, "assoc_missed": a.missed,
            "clutter_used": a.clutter_used, "max_err_occlusion_deg": float(np.nanmax(e[occl])),
            "max_err_neutral_deg": float(np.nanmax(e[t < 1.5])),
            "empty_rows": int(traj["wrist_x"].isna().sum()),
            "init": r_fuse["initialised_from"], "init_px": r_fuse["init_residual_px"],
            "init_mm": r_fuse["init_residual_mm"]}


COLS = [("flexion_rmse_deg", "flex RMSE °"), ("deviation_rmse_deg", "dev RMSE °"),
        ("pronation_rmse_deg", "pron RMSE °"), ("wrist_rmse_mm", "WRIST RMSE mm"),
        ("flexion_rom_err_deg", "flex RoM err °"), ("deviation_rom_err_deg", "dev RoM err °"),
        ("pronation_rom_err_deg", "pron RoM err °"),
        ("flexion_rom_p5_p95_err_deg", "flex RoM 5-95 err °"),
        ("deviation_rom_p5_p95_err_deg", "dev RoM 5-95 err °"),
        ("pronation_rom_p5_p95_err_deg", "pron RoM 5-95 err °"), ("assoc_pct", "assoc. %"),
        ("assoc_wrong", "wrong"), ("assoc_missed", "missed"), ("clutter_used", "clutter used"),
        ("max_err_occlusion_deg", "max err occl. °"), ("max_err_neutral_deg", "max err neutral °"),
        ("fps", "frames/s")]


def table(rows: list[dict]) -> list[str]:
    out = ["| session | " + " | ".join(c[1] for c in COLS) + " |", "|---" * (len(COLS) + 1) + "|"]
    for r in rows:
        out.append(f"| {r['session']} | " + " | ".join(
            f"{r[k]:.0f}" if k == "fps" else f"{r[k]:.2f}" if isinstance(r[k], float) else
            str(r[k]) for k, _ in COLS) + " |")
    return out


def summary(results: dict) -> list[str]:
    """The must-show lines of issue 11, the worst session of each configuration."""
    out = ["## Summary (the worst session of each configuration)", "",
           "| configuration | angle RMSE ° (max) | WRIST RMSE mm (max) | deviation RoM err °, "
           "wrist-deviation (max abs) | flexion RoM err °, wrist-flexion (max abs) | "
           "RoM err °, all angles and sessions (max abs) | assoc. % (min) | clutter used | "
           "max err occl. ° |", "|---|---|---|---|---|---|---|---|---|"]
    for c, rows in results.items():
        ang = max(r[f"{k}_rmse_deg"] for r in rows for k in ("flexion", "deviation", "pronation"))
        dev = [abs(r["deviation_rom_err_deg"]) for r in rows if "deviation" in r["session"]]
        flex = [abs(r["flexion_rom_err_deg"]) for r in rows if "flexion" in r["session"]]
        rom = max(abs(r[f"{k}_rom_err_deg"]) for r in rows
                  for k in ("flexion", "deviation", "pronation"))
        out.append(f"| {c} | {ang:.2f} | {max(r['wrist_rmse_mm'] for r in rows):.2f} | "
                   f"{max(dev, default=np.nan):.2f} | {max(flex, default=np.nan):.2f} | {rom:.2f} | "
                   f"{min(r['assoc_pct'] for r in rows):.2f} | "
                   f"{sum(r['clutter_used'] for r in rows)} | "
                   f"{max(r['max_err_occlusion_deg'] for r in rows):.2f} |")
    return out + [""]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--duration", type=float, default=12.0)
    ap.add_argument("--out", default=str(REPO / "docs" / "palm-validation.md"))
    args = ap.parse_args()
    results = {c: [] for c in CONFIGS}
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for task in TASKS:
            for seed in range(1, args.seeds + 1):
                folder = Path(tmp) / f"{task}-s{seed}"
                hidden = 1 + seed % 5  # an MCP or CMC1 marker, a different one per seed
                pipeline.simulate(folder, PalmSimSettings(
                    task=task, seed=seed, duration_s=args.duration,
                    hide=((hidden, HIDE_START, HIDE_S),), clutter2_s=CLUTTER2_S))
                pipeline.calibrate(folder)
                pipeline.detect(folder)
                for c, recipe in CONFIGS.items():
                    dest = Path(tmp) / f"{folder.name}-{c}"
                    shutil.copytree(folder / "armtrack", dest)
                    r = pipeline.fuse(folder, method="ukf-palm", recipe=recipe, out=dest)
                    results[c].append(score_session(folder, dest, r))
                print(f"{folder.name}: done", file=sys.stderr)
    wall = time.perf_counter() - t0
    lines = ["# ukf-palm validation (issue 11)", "",
             f"Generated by `python validation/palm.py` in {wall:.0f} s. "
             f"{len(TASKS) * args.seeds} simulated palm sessions: tasks {', '.join(TASKS)} × "
             f"seeds 1–{args.seeds}, {args.duration:g} s each at 30 fps, 640×480 with lens "
             "distortion, depth frames (1 mm noise), Qualisys at 100 Hz (0.3 mm noise). "
             "A clutter blob lies on the table throughout; a second appears 7 cm beside the "
             f"hand at {CLUTTER2_S:g} s; one marker (MCP2…CMC1, by seed) is hidden from "
             f"{HIDE_START:g} s for {HIDE_S:g} s. Every session goes through calibrate → detect "
             "→ fuse → compare; association is checked against the simulator's truth.", "",
             f"Goals: {GOALS}; no clutter blob ever used; no divergence through the occlusion; "
             "the neutral start tracked.", "",
             "Columns: RMSE of each wrist angle and of the WRIST marker (3-D) against Qualisys; "
             "RoM error per angle, as max − min and as the 5th–95th percentile span, against "
             "the truth angles from the six Qualisys markers (wrist-angle-errors.csv; the "
             "measures package's measures.csv takes its truth frame from three markers, "
             "whose noise widens the truth's max − min by up to a degree: its RoM errors are "
             "in the JSON as *_rom_err_pkg_deg); association: % of marker-frames right (the "
             "marker's own blob used, or none used where it had none), wrong blobs used, own "
             "blobs left unused, clutter blobs used; the largest angle error during the hidden "
             "span and the second after it, and during the neutral first 1.5 s; filter speed "
             "(frames/s on this machine, the filter loop alone).", ""]
    lines += summary(results)
    for c, rows in results.items():
        lines += [f"## {c}" + (" (armtrack's defaults: depth updates)" if c == "defaults" else
                               " (the paper's filter: projections only after eq. 13-20)"), ""]
        lines += table(rows) + [""]
    Path(args.out).write_text("\n".join(lines) + "\n")
    Path(args.out).with_suffix(".json").write_text(json.dumps(results, indent=1) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
