"""The patch detector against a moving same-hue distractor (issue 14), written to
docs/validation-detect.md.

Simulated arm sessions (circle, rectangle, reach, figure-eight × seeds) with the other arm in
a sleeve of the patch's hue sweeping over and near the patch from 3 s on, a cluttered table,
the static disc of the patch's colour and a card over the patch for 0.7 s. Each goes through
`detect` as a user runs it; every frame's detection is scored against the
simulator's truth (the wrist joint's pixel, where the patch is centred, and whether the patch
is visible: facing the camera, not under the card, not under the other arm). Twice: with the
defaults, and with the appearance check switched off (CamShift and the jump limit alone).

Then the re-acquisition study (validation/reacquire.py): the forward-filter study's sessions
(validation/forward_filter.py: 20 s, two cards of 0.5-1 s, the other arm crossing near the
patch), each made by `armtrack simulate` and run through `detect`: after every card and every
pass of the other arm, how many frames the patch is in clear view before `ok = 1` again.

    python validation/detect_distractor.py [--seeds 3] [--duration 15] [--lag-seeds 3]
        [--lag-figure8-seeds 3] [--out FILE]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "validation"))

import forward_filter  # noqa: E402  (its sessions, one place)
import reacquire  # noqa: E402

from armtrack_cli import pipeline  # noqa: E402
from armtrack_cli.simulate.arm_session import ArmSimSettings  # noqa: E402

TASKS = ("circle", "rectangle", "reach", "figure8")
OCCLUSION = (6.0, 0.7)
GOAL_PX, GOAL_SHARE = 3.0, 0.99
NO_CHECK = ("detect.patch.max_hue_distance=1.0", "detect.patch.lost_fraction=0.0",
            "detect.patch.max_growth=1e9", "detect.patch.max_aspect=1e9",
            "detect.patch.max_aspect_change=1e9")
CONFIGS = {"defaults": (), "appearance check off": NO_CHECK}


def score(folder: Path, dest: Path) -> dict:
    """Per-frame detections of one run against the truth."""
    d = pd.read_csv(dest / "detections.csv", comment="#")
    truth = dict(np.load(folder.parent / f"{folder.name}.truth.npz"))
    ok = d["ok"].to_numpy() == 1
    vis = truth["frame_patch_visible"]
    covered = truth["frame_patch_covered"] > 0
    err = np.hypot(d["u"] - truth["frame_wrist_px"][:, 0], d["v"] - truth["frame_wrist_px"][:, 1])
    e = err.to_numpy()[ok]
    return {"frames": int(ok.size), "visible": int(vis.sum()), "covered": int(covered.sum()),
            "ok": int(ok.sum()), "within": float((e <= GOAL_PX).mean()) if e.size else np.nan,
            "max_px": float(e.max()) if e.size else np.nan,
            "found": float((ok & vis).sum() / max(vis.sum(), 1)),
            "ok_covered": int((ok & covered).sum()), "ok_hidden": int((ok & ~vis).sum())}


def run(seeds: int, duration: float) -> list[dict]:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for task in TASKS:
            for seed in range(seeds):
                name = f"{task}-s{seed}"
                folder = Path(tmp) / name
                pipeline.simulate(folder, ArmSimSettings(
                    task=task, seed=seed, duration_s=duration, moving_distractor=True,
                    clutter=True, distractor=True, occlusions=(OCCLUSION,)))
                for config, sets in CONFIGS.items():
                    dest = Path(tmp) / config.replace(" ", "-") / name
                    r = pipeline.detect(folder, out=dest, sets=sets)
                    rows.append({"session": name, "config": config,
                                 "frames_per_s": r["frames_per_s"], **score(folder, dest)})
                    print(rows[-1], flush=True)
    return rows


LAG_GOAL = 3  # frames in clear view before ok = 1 again, after a card or the other arm
LAG_MIN_STRETCH = 5  # … over clear stretches at least this long


def lag_score(folder: Path, dest: Path) -> dict:
    """Re-acquisition after each card and each pass of the other arm, against the truth."""
    d = pd.read_csv(dest / "detections.csv", comment="#")
    truth = dict(np.load(folder.parent / f"{folder.name}.truth.npz"))
    ok = d["ok"].to_numpy() == 1
    clear = truth["frame_patch_visible"].astype(bool) & (
        reacquire.sleeve_gap_px(truth) > reacquire.CLEAR_PX)
    ev = reacquire.lags(clear, ok, truth["frame_occluded"].astype(bool))
    err = np.hypot(d["u"] - truth["frame_wrist_px"][:, 0],
                   d["v"] - truth["frame_wrist_px"][:, 1]).to_numpy()[ok]
    row = {"clear": int(clear.sum()), "clear_not_ok": int((clear & ~ok).sum()),
           "blind_s": reacquire.longest_run(~ok) / 30.0, "ok": int(ok.sum()),
           "within": float((err <= GOAL_PX).mean()) if err.size else np.nan,
           "max_px": float(err.max()) if err.size else np.nan}
    first = [x for x in ev if x[1] == "start"]
    row["first"] = (first[0][3] if first[0][3] is not None else first[0][2]) if first else 0
    for cause in ("card", "arm"):
        e = [x for x in ev if x[1] == cause and x[2] >= LAG_MIN_STRETCH]
        lag = [x[3] if x[3] is not None else x[2] for x in e]
        row[cause] = len(e)
        row[f"{cause}_max"] = max(lag) if lag else 0
        row[f"{cause}_never"] = sum(x[3] is None for x in e)
        row[f"{cause}_late"] = sum(v > LAG_GOAL for v in lag)
    return row


def lag_run(seeds: int, figure8_seeds: int) -> list[dict]:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for task, seed, opts in forward_filter.sessions(seeds, figure8_seeds):
            folder = Path(tmp) / f"{task}-s{seed}"
            forward_filter._cli("simulate", str(folder), *opts)
            r = pipeline.detect(folder, out=folder / "armtrack")
            cards = " + ".join(o for o, p in zip(opts[1:], opts) if p == "--occlusion")
            rows.append({"session": folder.name, "cards": cards,
                         "frames_per_s": r["frames_per_s"],
                         **lag_score(folder, folder / "armtrack")})
            print(rows[-1], flush=True)
    return rows


def render_lags(rows: list[dict]) -> list[str]:
    late = sum(r["card_late"] + r["arm_late"] for r in rows)
    stretches = sum(r["card"] + r["arm"] for r in rows)
    worst = min(r["within"] for r in rows)
    lines = ["## Re-taking the patch after a card or the other arm", "",
             f"The forward-filter study's sessions (docs/validation-forward-filter.md: "
             f"{forward_filter.DURATION} s, two cards of 0.5-1 s 8 s apart, the other arm in a "
             "sleeve of the patch's hue crossing near it from 3 s on), made by `armtrack "
             "simulate` and run through `detect`. A frame is *clear* when the patch is visible "
             f"and the other arm lies more than {reacquire.CLEAR_PX:g} px from its outline in "
             "the image (validation/reacquire.py, from the simulator's truth); after each "
             "card and each pass of the other arm, the *lag* is the number of clear frames "
             "before `ok = 1` again (a stretch in which the patch is never reported counts "
             f"whole). Stretches of at least {LAG_MIN_STRETCH} clear frames.", "",
             f"**Goal** (issue 14): ok = 1 again within {LAG_GOAL} clear frames after every "
             f"card and every pass, ok = 1 frames within {GOAL_PX:g} px on ≥ "
             f"{100 * GOAL_SHARE:g} %. Over {len(rows)} sessions: {stretches - late} of "
             f"{stretches} stretches re-taken within {LAG_GOAL} frames; worst session "
             f"{_pct(worst)} within {GOAL_PX:g} px — goal **"
             f"{'met' if late == 0 and worst >= GOAL_SHARE else 'not met'}**.", "",
             "| session | cards s | clear frames | clear but ok = 0 | first report, lag | "
             "after a card: stretches, "
             "max lag | after the other arm: stretches, max lag | never re-taken | longest "
             f"without detection, s | ok = 1 | within {GOAL_PX:g} px | max error px |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['session']} | {r['cards']} | {r['clear']} | {r['clear_not_ok']} | "
                     f"{r['first']} | {r['card']}, {r['card_max']} | {r['arm']}, {r['arm_max']} | "
                     f"{r['card_never'] + r['arm_never']} | {r['blind_s']:.2f} | {r['ok']} | "
                     f"{_pct(r['within'])} | {r['max_px']:.1f} |")
    return lines + ["", "`longest without detection`: the longest run of frames with ok = 0, "
                    "whatever the cause (the cards and the other arm over the patch included): "
                    "what the forward filter runs through on the IMU alone.", ""]


def _pct(x: float) -> str:
    return "—" if np.isnan(x) else f"{100 * x:.1f} %"


def render(rows: list[dict], seeds: int, duration: float, seconds: float,
           lag_rows: list[dict]) -> str:
    lines = ["# Patch detection with a moving same-hue distractor", "",
             "Generated by `python validation/detect_distractor.py` (`make validate`); do not "
             "edit by hand.", "",
             f"{len(TASKS)} tasks × {seeds} seeds, {duration:g} s each at 30 fps, 640×480: the "
             "other arm in a sleeve of the patch's hue (hue ≈ 5.5 against the patch's ≈ 1.5, "
             "both inside the session's hue range 170-10) sweeping over and near the patch "
             "every 5 s from 3 s on, a cluttered table, the static disc of the patch's colour, "
             f"a card over the patch from {OCCLUSION[0]:g} s for {OCCLUSION[1]:g} s. Scored "
             "against the simulator's truth: the wrist joint's pixel (the patch's centre) and "
             "whether the patch is visible (facing the camera, under neither the card nor the "
             "other arm).", "",
             f"**Goal** (issue 14): frames with `ok = 1` within {GOAL_PX:g} px of the truth on "
             f"≥ {100 * GOAL_SHARE:g} % of them, on every session.", ""]
    for config in CONFIGS:
        sub = [r for r in rows if r["config"] == config]
        ok = sum(r["ok"] for r in sub)
        within = sum(r["within"] * r["ok"] for r in sub) / max(ok, 1)
        worst = min(r["within"] for r in sub)
        met = worst >= GOAL_SHARE
        lines += [f"## {config}", "",
                  f"Pooled: {ok} frames with ok = 1, {_pct(within)} within {GOAL_PX:g} px; "
                  f"worst session {_pct(worst)} — goal **{'met' if met else 'not met'}**.", "",
                  "| session | frames | visible | under the other arm | ok = 1 | within "
                  f"{GOAL_PX:g} px | max error px | visible found | ok while hidden |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for r in sub:
            lines.append(f"| {r['session']} | {r['frames']} | {r['visible']} | {r['covered']} "
                         f"| {r['ok']} | {_pct(r['within'])} | {r['max_px']:.1f} | "
                         f"{_pct(r['found'])} | {r['ok_hidden']} |")
        lines.append("")
    lines += ["`visible found`: share of the frames where the patch is visible that are "
              "reported (ok = 1); `ok while hidden`: frames reported although the patch is not "
              "visible (under the card or the other arm, or turned away). With the check off, "
              "CamShift's window follows the sleeve when it crosses the patch. Detection speed "
              "is in docs/benchmarks.md (`make bench`), not here.", ""]
    if lag_rows:
        lines += render_lags(lag_rows)
    lines += [f"Run time {seconds:.0f} s."]
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--duration", type=float, default=15.0)
    ap.add_argument("--lag-seeds", type=int, default=3)
    ap.add_argument("--lag-figure8-seeds", type=int, default=3)
    ap.add_argument("--out", type=Path, default=REPO / "docs" / "validation-detect.md")
    a = ap.parse_args()
    start = time.perf_counter()
    rows = run(a.seeds, a.duration)
    lag_rows = lag_run(a.lag_seeds, a.lag_figure8_seeds)
    text = render(rows, a.seeds, a.duration, time.perf_counter() - start, lag_rows)
    a.out.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
