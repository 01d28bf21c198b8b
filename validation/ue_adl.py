"""Elbow flexion RoM from the UE-ADL Vicon trials (CAST from the clusters) beside the authors'
processed angles: `python validation/ue_adl.py` prints the table in docs/validation.md."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from armtrack_cli.compare.peer_angles import rom_beside_peer  # noqa: E402
from armtrack_cli.session.groundtruth import read_markers  # noqa: E402

UE_ADL = REPO.parent / "shared" / "realdata" / "ue-adl"
TRIALS = {"DR1": "drinking", "DR2": "drinking", "CR1": "combing", "FR1": "forward reach",
          "FR2": "forward reach", "AR1": "reach across"}


def trial_rom(folder: Path, trial: str, static=None) -> dict[str, float]:
    static = static or read_markers(folder / "ADL001_static.csv")
    peer = pd.read_csv(folder / f"ADL001{trial}angles.csv")
    return rom_beside_peer(static, read_markers(folder / f"ADL001{trial}.csv"),
                           peer["elbow flexion-extension"].to_numpy(),
                           peer["Finger Velocity"].to_numpy())


def main(folder: Path = UE_ADL) -> None:
    static = read_markers(folder / "ADL001_static.csv")
    print("| trial | task | authors' RoM | three-point | ISB (own clusters) | ISB (epicondyles on "
          "upper arm) | window r |")
    print("|---|---|---|---|---|---|---|")
    for trial, task in TRIALS.items():
        r = trial_rom(folder, trial, static)
        p = r["peer_rom_deg"]
        cells = [f"{r[k]:.1f} ({r[k] - p:+.1f})" for k in
                 ("three_point_rom_deg", "isb_rom_deg", "isb_upper_epicondyles_rom_deg")]
        print(f"| {trial} | {task} | {p:.1f} | " + " | ".join(cells) +
              f" | {r['window_correlation']:.3f} |")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else UE_ADL)
