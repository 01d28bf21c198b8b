"""The auto arm against the arm a lab would declare: `python validation/arm_auto_tape.py` writes
the section "The arm as a lab would declare it" of docs/validation-arm-auto.md (part of `make
validate`, after validation/arm_auto.py, whose writer keeps this section).

A lab never has the exact arm: it tapes the segment lengths between bony landmarks and places the
shoulder's joint centre in the board's frame by eye or with a ruler from the acromion. The error
model (ERROR_MODEL below says where its figures come from): lengths off by N(0, σ_L) each, the
shoulder off by N(0, σ_S) per axis, a few fixed draws per session (seeds fixed). On the sessions
of validation/arm_auto_movement.py (4 tasks × 3 seeds, with the 8 s calibration movement) the
default method is fused with the true arm (the reference), all five constants "auto", the
shoulder "auto" with the lengths as taped, and the whole arm as measured; `compare` scores each
(wrist and elbow 3-D RMSE). `--quick` runs one circle with two draws as a smoke run.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from armtrack_cli import pipeline  # noqa: E402
from armtrack_cli.core.errors import ArmtrackError  # noqa: E402
from armtrack_cli.session.arm_file import ARM_FILE, read_arm_estimate  # noqa: E402
from armtrack_cli.simulate.arm_session import ArmSimSettings  # noqa: E402
from validation import arm_auto  # noqa: E402
from validation import arm_auto_movement as movement  # noqa: E402
from validation import arm_auto_tape_doc as doc  # noqa: E402
from validation.from_mocap import as_auto  # noqa: E402

SIGMA_L_M = (0.005, 0.01)  # each taped length's error (m), one level a table; the doc says why
SIGMA_S_M = (0.005, 0.01, 0.02, 0.03)  # the shoulder's error per axis (m), one level a column
DRAWS = 6  # fixed draws of the error model per session
METHOD = movement.METHOD
ARM_KEYS = arm_auto.ARM_KEYS


def draw_errors(key: tuple[int, ...], draws: int = DRAWS,
                sigma_l: tuple[float, ...] = SIGMA_L_M,
                sigma_s: tuple[float, ...] = SIGMA_S_M) -> dict[str, np.ndarray]:
    """The error model's draws for one session (seeded by ``key``): "lengths" (σ_L levels,
    draws, 2), upper arm and forearm off by N(0, σ_L); "shoulder" (σ_S levels, draws, 3), off by
    N(0, σ_S) per axis. One standard normal draw serves every level, so levels differ in scale
    only."""
    rng = np.random.default_rng([*key, 14])
    z_l, z_s = rng.standard_normal((draws, 2)), rng.standard_normal((draws, 3))
    scale = lambda s: np.asarray(s, dtype=float)[:, None, None]  # noqa: E731
    return {"lengths": scale(sigma_l) * z_l[None], "shoulder": scale(sigma_s) * z_s[None]}


def arm_copy(folder: Path, name: str, values: dict) -> Path:
    """A copy of the session (video and IMU linked; validation/from_mocap.as_auto) with the [arm]
    ``values`` (a number, a 3-vector or "auto" per key), calibrate's and detect's outputs copied
    (not an arm estimate, which kinematics would read)."""
    dest = as_auto(folder, folder.parent / f"{folder.name}-{name}", tuple(values))
    text = (dest / "session.toml").read_text()
    for key, v in values.items():
        if not isinstance(v, str):
            v = "[" + ", ".join(f"{x:.4f}" for x in v) + "]" if np.ndim(v) else f"{v:.4f}"
            text = text.replace(f'{key} = "auto"', f"{key} = {v}")
    (dest / "session.toml").write_text(text)
    shutil.copytree(folder / "armtrack", dest / "armtrack",
                    ignore=shutil.ignore_patterns(ARM_FILE, "trajectory-*", "kinematics-*"))
    return dest


def scores(folder: Path) -> tuple[float, float]:
    """Wrist and elbow 3-D RMSE (cm) of the default method on ``folder``; NaN when fuse refuses."""
    out = folder / "armtrack"
    try:
        pipeline.fuse(folder, method=METHOD, out=out)
        rows = pipeline.compare(folder, methods=(METHOD,), out=out)["rows"]
    except ArmtrackError:
        return (np.nan, np.nan)
    return tuple(next(r["rmse_cm"] for r in rows if r["joint"] == j and r["axis"] == "3d")
                 for j in ("wrist", "elbow"))


def session_row(folder: Path, s: ArmSimSettings, key: tuple[int, ...], draws: int) -> dict:
    """One session with the calibration movement: the true arm, all five "auto", and per draw of
    the error model the shoulder "auto" with the lengths as taped and the arm as measured at each
    σ_S (the same taped lengths), each scored (wrist, elbow) in cm."""
    pipeline.simulate(folder, movement.with_movement(s))
    pipeline.calibrate(folder)
    pipeline.detect(folder)
    row = {"true": scores(folder)}
    auto = arm_copy(folder, "auto", dict.fromkeys(ARM_KEYS, "auto"))
    row["auto"] = scores(auto)
    est = read_arm_estimate(auto / "armtrack")
    row["auto_err_cm"] = ([float(np.linalg.norm(np.subtract(est["shoulder_m"], s.shoulder))) * 100,
                           (est["upper_arm_m"] - s.upper_arm_m) * 100,
                           (est["forearm_m"] - s.forearm_m) * 100] if est else [np.nan] * 3)
    e = draw_errors(key, draws)
    row["taped"] = [[] for _ in SIGMA_L_M]  # [σ_L level][draw]
    row["measured"] = [[[] for _ in SIGMA_S_M] for _ in SIGMA_L_M]  # [σ_L][σ_S][draw]
    for a, k in np.ndindex(len(SIGMA_L_M), draws):
        lengths = {"upper_arm_m": s.upper_arm_m + e["lengths"][a, k, 0],
                   "forearm_m": s.forearm_m + e["lengths"][a, k, 1]}
        taped = arm_copy(folder, f"l{a}-d{k}", {**lengths, "shoulder_m": "auto"})
        row["taped"][a].append(scores(taped))
        for i, ds in enumerate(e["shoulder"][:, k]):
            arm = {**lengths, "shoulder_m": np.add(s.shoulder, ds)}
            row["measured"][a][i].append(scores(arm_copy(folder, f"l{a}-d{k}-s{i}", arm)))
    return row


def _run(job: tuple[str, ArmSimSettings, tuple[int, ...], int, str]) -> tuple[str, dict]:
    name, s, key, draws, tmp = job
    folder = Path(tmp) / name
    try:
        row = session_row(folder, s, key, draws)
    except ArmtrackError as e:  # a stage refused: the row says why
        row = {"error": str(e).replace(tmp + "/", "")}
    for f in (folder, *Path(tmp).glob(f"{name}-*")):  # the session and its copies are done with
        shutil.rmtree(f, ignore_errors=True)
    return name, row


def run_all(args: argparse.Namespace) -> tuple[dict, float]:
    """Every session's row (two sessions at a time unless told), and the wall time (s)."""
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        jobs = [(name, s, (arm_auto.TASKS.index(s.task), s.seed), args.draws, tmp)
                for name, s in arm_auto.task_runs(args.tasks.split(","), args.seeds)]
        rows = {}
        with ProcessPoolExecutor(max(1, args.jobs)) as pool:
            for name, row in pool.map(_run, jobs):
                rows[name] = row
                for a in range(len(SIGMA_L_M)):
                    print(doc.session_line(name, row, 0, a), flush=True)
    return rows, time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--tasks", default=",".join(arm_auto.TASKS))
    ap.add_argument("--draws", type=int, default=DRAWS)
    ap.add_argument("--jobs", type=int, default=2, help="sessions run at once")
    ap.add_argument("--quick", action="store_true", help="one circle, two draws (a smoke run)")
    ap.add_argument("--rows", help="write the scores to this JSON file too; with --from-rows, "
                    "read them from it instead of running the sessions")
    ap.add_argument("--from-rows", action="store_true")
    ap.add_argument("--out", default=None, help="default docs/validation-arm-auto.md "
                    "(with --quick, a file in the system's temporary folder)")
    args = ap.parse_args()
    if args.quick:
        args.tasks, args.seeds, args.draws = "circle", 1, 2
    out = Path(args.out or (Path(tempfile.gettempdir()) / "arm-auto-tape-quick.md" if args.quick
                            else REPO / "docs" / "validation-arm-auto.md"))
    if args.from_rows:
        saved = json.loads(Path(args.rows).read_text())
        rows, wall = saved["rows"], saved["wall_s"]
    else:
        rows, wall = run_all(args)
        if args.rows:
            Path(args.rows).write_text(json.dumps({"rows": rows, "wall_s": wall}, default=float))
    doc.write_section(out, rows, wall, args.jobs, SIGMA_L_M, SIGMA_S_M)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
