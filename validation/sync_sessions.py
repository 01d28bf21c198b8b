"""Rendered sessions through the CLI's pipeline for docs/validation-sync.md (run by
validation/imu_sync.py): on each simulated session (simulate -> calibrate -> detect -> fuse ->
compare, the default method),

B. [sync] imu_offset_s: the true value declared, declared 0.2 s off (fuse's warning), "auto";
C. groundtruth_offset_s = "auto": the session's Qualisys export re-made by the simulator with
   each true offset (its IMU and video do not depend on it: simulate_arm draws them first),
   compare's estimate against the truth;
D. [arm] shoulder_m / upper_arm_m / forearm_m = "auto" with imu_offset_s = "auto": the arm's
   and the offset's estimates, and compare's RMSE beside the fully declared session's.
"""

from __future__ import annotations

import dataclasses
import re
import warnings
from pathlib import Path

import numpy as np

from armtrack_cli import pipeline
from armtrack_cli.session.arm_file import read_arm_estimate
from armtrack_cli.session.export.qualisys import write_qtm_tsv
from armtrack_cli.simulate.arm_session import ArmSimSettings, simulate_arm

OFFSETS = (-0.5, -0.2, 0.05, 0.2, 0.5)
CASES = (("circle", -0.5, 1), ("reach", 0.2, 2), ("figure8", 0.05, 3), ("rectangle", -0.2, 4))


def rmse(res: dict) -> tuple[float, float]:
    got = {(r["joint"], r["axis"]): r["rmse_cm"] for r in res["rows"]}
    return got[("wrist", "3d")], got.get(("elbow", "3d"), float("nan"))


def set_toml(folder: Path, **values: str) -> None:
    """session.toml with each key's line replaced by ``key = value`` (value as TOML text)."""
    toml = folder / "session.toml"
    text = toml.read_text()
    for key, value in values.items():
        text = re.sub(rf"^{key} = .*$", f"{key} = {value}", text, flags=re.M)
    toml.write_text(text)


def _fuse(folder: Path) -> tuple[dict, list[str]]:
    """fuse, and the clock-offset warnings it gave (folder names relative)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        f = pipeline.fuse(folder)
    return f, [str(w.message).replace(str(folder.parent) + "/", "") for w in caught
               if "clock offset" in str(w.message)]


def imu_offsets(folder: Path, off: float) -> dict:
    """B: declared true, declared +0.2 s, "auto" (left in place for C)."""
    row = {}
    for how, value in (("declared", f"{off:g}"), ("wrong", f"{off + 0.2:g}"), ("auto", '"auto"')):
        set_toml(folder, imu_offset_s=value)
        f, row[how + "_warned"] = _fuse(folder)
        row[how] = f["imu_offset_s"]
        if how != "wrong":
            row[how + "_rmse"] = rmse(pipeline.compare(folder))
    return row


def truth_offsets(folder: Path, s: ArmSimSettings) -> list[dict]:
    """C: each true Qualisys offset, estimated by compare ("auto") on the trajectory in place."""
    rows = []
    set_toml(folder, groundtruth_offset_s='"auto"')
    for off in OFFSETS:
        q = simulate_arm(dataclasses.replace(s, groundtruth_offset_s=off)).qualisys
        write_qtm_tsv(folder / "qualisys.tsv", q["xyz"], q["names"], s.qualisys_hz)
        got = pipeline.compare(folder)["groundtruth_offset_s"]
        rows.append({"offset": off, "err_ms": 1000 * (got["value"] - off),
                     "sd_ms": 1000 * got["sd"], "with": got["estimated_with"]})
    q = simulate_arm(s).qualisys  # the session's own export back, declared
    write_qtm_tsv(folder / "qualisys.tsv", q["xyz"], q["names"], s.qualisys_hz)
    set_toml(folder, groundtruth_offset_s=f"{s.groundtruth_offset_s:g}")
    return rows


def auto_arm(folder: Path, s: ArmSimSettings) -> dict:
    """D: the arm "auto" with the offset declared and with it "auto"."""
    row = {}
    set_toml(folder, shoulder_m='"auto"', upper_arm_m='"auto"', forearm_m='"auto"')
    for how, value in (("arm_auto", f"{s.imu_offset_s:g}"), ("both_auto", '"auto"')):
        set_toml(folder, imu_offset_s=value)
        f, _ = _fuse(folder)
        est = read_arm_estimate(folder / "armtrack")
        row[how] = {"rmse": rmse(pipeline.compare(folder)), "offset": f["imu_offset_s"],
                    "shoulder_cm": float(np.linalg.norm(np.subtract(est["shoulder_m"],
                                                                    s.shoulder)) * 100),
                    "L1_cm": (est["upper_arm_m"] - s.upper_arm_m) * 100,
                    "L2_cm": (est["forearm_m"] - s.forearm_m) * 100}
    return row


def run_sessions(tmp: Path, duration: float, cases=CASES) -> list[dict]:
    rows = []
    for task, off, seed in cases:
        folder = tmp / f"{task}-{seed}"
        s = ArmSimSettings(task=task, seed=seed, duration_s=duration, imu_offset_s=off,
                           declare_imu_offset=False)
        pipeline.simulate(folder, s)
        pipeline.calibrate(folder)
        pipeline.detect(folder)
        row = {"task": task, "offset": off, "seed": seed, **imu_offsets(folder, off)}
        row["truth"] = truth_offsets(folder, s)
        row.update(auto_arm(folder, s))
        rows.append(row)
        print(row, flush=True)
    return rows


def markdown(rows: list[dict]) -> list[str]:
    """Sections C and D of docs/validation-sync.md from run_sessions' rows."""
    errs = np.array([t["err_ms"] for r in rows for t in r["truth"]])
    sds = np.array([t["sd_ms"] for r in rows for t in r["truth"]])
    lines = ["## C. `groundtruth_offset_s = \"auto\"`: the Qualisys clock from the trajectory",
             "", "Each session of B (its IMU offset \"auto\") with its Qualisys export re-made "
             "by the simulator at each true offset; compare estimates it against the default "
             "method's trajectory (compare/sync.py). Goal: within 5 ms.", "",
             "| session | " + " | ".join(f"{o:+.2f} s" for o in OFFSETS) + " |",
             "|---|" + "---|" * len(OFFSETS)]
    for r in rows:
        lines.append(f"| {r['task']} seed {r['seed']} | " + " | ".join(
            f"{t['err_ms']:+.1f} ± {t['sd_ms']:.1f} ms" for t in r["truth"]) + " |")
    lines += ["", f"Error ± SD per true offset. Within 5 ms: **{np.mean(np.abs(errs) <= 5) * 100:.0f} %** "
              f"of {errs.size}; max {np.abs(errs).max():.1f} ms; within 3 SD: "
              f"{np.mean(np.abs(errs) <= 3 * sds) * 100:.0f} %.", "",
              "## D. `[arm] … = \"auto\"` with the IMU offset \"auto\"", "",
              "The same sessions with shoulder, upper arm and forearm all \"auto\", the IMU "
              "offset declared (true) and \"auto\"; wrist / elbow 3-D RMSE by compare beside "
              "the fully declared session's (B).", "",
              "| session | declared arm and δ | auto arm, δ declared | auto arm, δ auto: δ ± SD s "
              "| … wrist / elbow RMSE cm | auto arm's errors: shoulder, L1, L2 cm |",
              "|---|---|---|---|---|---|"]
    for r in rows:
        de, a1, a2 = r["declared_rmse"], r["arm_auto"], r["both_auto"]
        lines.append(
            f"| {r['task']} seed {r['seed']} | {de[0]:.2f} / {de[1]:.2f} | "
            f"{a1['rmse'][0]:.2f} / {a1['rmse'][1]:.2f} | {a2['offset']['value']:+.4f} ± "
            f"{a2['offset']['sd']:.4f} (true {r['offset']:+.2f}) | {a2['rmse'][0]:.2f} / "
            f"{a2['rmse'][1]:.2f} | {a2['shoulder_cm']:.1f}, {a2['L1_cm']:+.1f}, "
            f"{a2['L2_cm']:+.1f} |")
    return lines + [""]
