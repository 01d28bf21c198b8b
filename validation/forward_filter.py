"""`make validate`: the paper's forward filter (tao2008-pf-constraint) on occluded sessions,
with and without the guards of fuse/robust.py, written to docs/validation-forward-filter.md.

Every session is made and scored through the command line as a user would: `armtrack
simulate --occlusion START:DURATION` (MTw-class IMU), `armtrack run --through detect`,
`armtrack fuse --recipe tao2008-pf-constraint` twice (as shipped: χ² gate, re-acquisition and
re-seeding on; and with them off: `--set fuse.gate_chi2=0 --set fuse.reseed_share=0`), then
`armtrack compare` (errors.csv: max 3-D error, % of frames within ±5 cm on the worst axis).
The simulator's exact truth (OUT.truth.npz) splits the error into frames hidden by the card
and frames with the patch in view, and says whether a run lost the arm: its error exceeds
10 cm on a frame where the camera sees the patch.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd

REPO = Path(__file__).resolve().parents[1]
ARMTRACK = str(Path(sys.executable).with_name("armtrack"))
CONFIGS = {"guarded": (), "unguarded": ("--set", "fuse.gate_chi2=0", "--set",
                                        "fuse.reseed_share=0")}
DURATIONS = (0.5, 0.75, 1.0)  # s, the card's, by seed
DURATION = "8"  # s, each session's


def sessions(seeds: int, figure8_seeds: int) -> list[tuple[str, int, float, float]]:
    """(task, seed, occlusion start s, duration s): circle, rectangle, reach × seeds and the
    figure-eight × figure8_seeds; the card comes at a seed-dependent phase of the motion."""
    out = [(t, s) for t in ("circle", "rectangle", "reach") for s in range(seeds)]
    out += [("figure8", s) for s in range(figure8_seeds)]
    return [(t, s, round(2.5 + (1.37 * s) % 3.5, 2), DURATIONS[s % 3]) for t, s in out]


def _cli(*args: str) -> str:
    r = subprocess.run([ARMTRACK, *args], capture_output=True, text=True)
    if r.returncode:
        raise RuntimeError(f"armtrack {args[0]}: {r.stderr.strip().splitlines()[-1]}")
    return r.stdout


def score(folder: Path, out: Path) -> dict:
    """compare's wrist rows and, from the exact truth, the error while hidden, in view, after."""
    _cli("compare", str(folder), "--out", str(out), "--method", "pf-constraint")
    rows = pd.read_csv(out / "errors.csv", comment="#")
    w = rows[(rows.joint == "wrist") & (rows.method == "pf-constraint")].set_index("axis")
    fuse = json.loads((out / "fuse.json").read_text())
    tr = np.load(str(folder) + ".truth.npz")
    est = pd.read_csv(out / "trajectory-pf-constraint.csv", comment="#")
    e = np.linalg.norm(est[["wrist_x", "wrist_y", "wrist_z"]].to_numpy() - tr["frame_wrist"],
                       axis=1) * 100
    hidden = tr["frame_occluded"]
    fps = 1.0 / np.median(np.diff(tr["frame_t"]))
    run, longest = 0, 0
    for v in (e > 5.0) & ~hidden:
        run = run + 1 if v else 0
        longest = max(longest, run)
    lost = bool(np.nanmax(e[~hidden]) > 10.0)
    return {"max_cm": float(w.loc["3d", "max_abs_cm"]), "rmse_cm": float(w.loc["3d", "rmse_cm"]),
            "within5": float(min(w.loc[a, "within_5cm_pct"] for a in "xyz")),
            "hidden_max_cm": float(np.nanmax(e[hidden])), "view_max_cm": float(np.nanmax(
                e[~hidden])), "view_over5_s": longest / fps, "lost": lost,
            "gated": fuse.get("gated_frames", 0), "reseeded": fuse.get("reseeded", 0) +
            fuse.get("reacquired", 0)}


def one(spec: tuple[str, int, float, float], tmp: Path) -> dict:
    task, seed, start, dur = spec
    folder = tmp / f"{task}-s{seed}"
    res = {"session": folder.name, "task": task, "seed": seed, "start": start, "dur": dur}
    try:
        _cli("simulate", str(folder), "--task", task, "--seed", str(seed), "--duration",
             DURATION, "--occlusion", f"{start}:{dur}", "--force")
        _cli("run", str(folder), "--through", "detect")
        for name, extra in CONFIGS.items():
            res[name] = _fuse_and_score(folder, name, extra)
    except RuntimeError as e:  # one line in the table, the other sessions go on
        res["error"] = str(e)
    print(f"{folder.name}: {res.get('error', 'done')}", file=sys.stderr, flush=True)
    return res


def _fuse_and_score(folder: Path, name: str, extra: tuple[str, ...]) -> dict:
    out = folder / "armtrack" / name
    out.mkdir(parents=True, exist_ok=True)
    for f in ("camera.yaml", "detections.csv"):
        (out / f).write_bytes((folder / "armtrack" / f).read_bytes())
    summary = _cli("fuse", str(folder), "--recipe", "tao2008-pf-constraint", "--out",
                   str(out), "--json", *extra)
    (out / "fuse.json").write_text(summary)
    return score(folder, out)


def _row(r: dict, c: str) -> str:
    if "error" in r:
        return f"| {r['session']} | {r['start']:g}:{r['dur']:g} | {c} | {r['error']} |"
    s = r[c]
    return (f"| {r['session']} | {r['start']:g}:{r['dur']:g} | {c} | {s['max_cm']:.1f} | "
            f"{s['within5']:.1f} | {s['rmse_cm']:.2f} | {s['hidden_max_cm']:.1f} | "
            f"{s['view_max_cm']:.1f} | {s['view_over5_s']:.2f} | {'**yes**' if s['lost'] else 'no'}"
            f" | {s['gated']} | {s['reseeded']} |")


def report(results: list[dict], wall: float, args) -> str:
    lines = ["# Validation: the paper's forward filter on occluded sessions", "",
             f"Generated by `make validate` (validation/forward_filter.py) in {wall:.0f} s. "
             f"{len(results)} simulated sessions of {args.duration:g} s (MTw-class IMU: 1° RMS orientation "
             "error, accelerometer bias 0.03 m/s²; 640×480 camera at 30 fps), each with one card "
             "over the patch (`--occlusion START:DURATION`, 0.5, 0.75 or 1 s by seed), made and "
             "scored through the command line: simulate → run --through detect → fuse "
             "--recipe tao2008-pf-constraint (500 particles, residual resampling, walk 0.01, no "
             "smoother) → compare. *guarded*: as shipped, with the χ² gate, re-acquisition and "
             "re-seeding of fuse/robust.py; *unguarded*: the same with them off. Goals (issue "
             "14): max 3-D error ≤ 10 cm and ≥ 99 % of frames within ±5 cm per axis on every "
             "session; no figure-eight run loses the arm.", "",
             "Columns: compare's max 3-D error and the worst axis's share within ±5 cm; from the "
             "simulator's truth, the largest 3-D error while the card hides the patch and while "
             "the patch is in view, the longest stretch in view with the error above 5 cm, "
             "*lost* (> 10 cm on a frame with the patch in view), and how "
             "many detections were gated and how often the cloud was re-seeded.", "",
             "| session | card s | filter | max 3-D cm | ±5 cm % | RMSE cm | hidden max cm | "
             "in-view max cm | > 5 cm in view, s | lost | gated | re-seeded |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        lines += [_row(r, c) for c in CONFIGS]
    lines += ["", "## Summary", "",
              "| filter | sessions max ≤ 10 cm | sessions ±5 cm ≥ 99 % | in-view max ≤ 10 cm | "
              "runs that lost the arm | worst max cm |", "|---|---|---|---|---|---|"]
    for c in CONFIGS:
        s = [r[c] for r in results if c in r]
        lines.append(f"| {c} | {sum(x['max_cm'] <= 10 for x in s)}/{len(s)} | "
                     f"{sum(x['within5'] >= 99 for x in s)}/{len(s)} | "
                     f"{sum(x['view_max_cm'] <= 10 for x in s)}/{len(s)} | "
                     f"{sum(x['lost'] for x in s)}/{len(s)} | {max(x['max_cm'] for x in s):.1f} |")
    for d in DURATIONS:
        s = [r["guarded"] for r in results if r["dur"] == d and "guarded" in r]
        if s:
            lines.append(f"\nCard of {d:g} s (guarded): hidden max {min(x['hidden_max_cm'] for x in s):.1f}"
                         f"–{max(x['hidden_max_cm'] for x in s):.1f} cm over {len(s)} sessions.")
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--figure8-seeds", type=int, default=10)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=str(REPO / "docs" / "validation-forward-filter.md"))
    ap.add_argument("--notes", default=str(REPO / "validation" / "forward_filter_notes.md"),
                    help="Markdown appended to the report (the analysis of the numbers).")
    ap.add_argument("--from-json", help="Only render the report again from a run's .json.")
    args = ap.parse_args()
    args.duration = float(DURATION)
    t0 = time.perf_counter()
    if args.from_json:
        saved = json.loads(Path(args.from_json).read_text())
        results, wall = saved["sessions"], saved["wall_s"]
    else:
        with tempfile.TemporaryDirectory() as tmp:
            with ThreadPoolExecutor(args.workers) as pool:
                results = list(pool.map(lambda s: one(s, Path(tmp)),
                                        sessions(args.seeds, args.figure8_seeds)))
        wall = time.perf_counter() - t0
        Path(args.out).with_suffix(".json").write_text(
            json.dumps({"wall_s": wall, "sessions": results}, indent=1))
    text = report(results, wall, args)
    notes = Path(args.notes)
    if notes.exists():
        text += "\n" + notes.read_text()
    Path(args.out).write_text(text)
    print(f"-> {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
