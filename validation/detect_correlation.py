"""How detect's pixel error is correlated from frame to frame, where the patch is still and where
it moves (issue 14; fuse/camera_rows.py). `python validation/detect_correlation.py KIND=FOLDER...`
prints one row per kind: each FOLDER a session that `detect` has run on (SESSION/armtrack/
detections.csv) with the simulator's truth beside it (SESSION.truth.npz).

The error is detect's (u, v) less the true wrist pixel on the frames it reported (ok = 1), less
the session's mean error (detect's steady offset, the centroid against the wrist joint, is no
correlation from frame to frame; a mean per run would take the held part away with it; a mean
over all the sessions pooled gives still frames τ = 26-32, each session's still frames then
holding their own offset, which the lags up to LAGS do not end). Still frames are those
fuse/camera_rows.still_patch takes as still — read from the detections, as fuse reads them —
the rest moving. The lag-k
autocorrelation ρ_k is pooled over the runs of consecutive frames of one class (pairs within a
run) and both axes; the integrated autocorrelation time τ = 1 + 2 Σ ρ_k over k = 1, 2, … until ρ_k
first drops below 0 (Geyer 1992's initial positive sequence): n frames of the error tell its mean
as well as n / τ independent ones.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from armtrack_cli.fuse.camera_rows import still_patch  # noqa: E402
from armtrack_cli.fuse.settings import FuseSettings  # noqa: E402

STILL_PX = FuseSettings().pixel_still_px
LAGS = 30  # ρ_k up to this lag at most


def errors(folder: Path) -> tuple[np.ndarray, np.ndarray]:
    """(e (n, 2) px, NaN where not reported; still (n,) bool from the detections) of one
    session."""
    tr = np.load(folder.parent / f"{folder.name}.truth.npz")
    det = np.genfromtxt(folder / "armtrack" / "detections.csv", delimiter=",", names=True)
    n = tr["frame_t"].size
    z = np.c_[det["u"][:n], det["v"][:n]]
    z[det["ok"][:n] != 1] = np.nan
    return z - tr["frame_wrist_px"][:n], still_patch(z, STILL_PX)


def runs(mask: np.ndarray, least: int = 4) -> list[tuple[int, int]]:
    """[(start, stop)] of the runs of at least ``least`` consecutive True in mask."""
    edges = np.diff(np.r_[0, mask.astype(int), 0])
    return [(a, b) for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1))
            if b - a >= least]


def autocorrelation(segments: list[np.ndarray], most: int = LAGS) -> np.ndarray:
    """ρ_k, k = 1 … (most − 1 at most), pooled over segments (each (m, 2), about zero)."""
    x0 = sum(float(np.sum(r * r)) for r in segments) / sum(r.size for r in segments)
    rho = []
    for k in range(1, most):
        pairs = [(float(np.sum(r[k:] * r[:-k])), r[k:].size) for r in segments if len(r) > k]
        if not pairs:
            break
        rho.append(sum(p for p, _ in pairs) / sum(c for _, c in pairs) / x0)
    return np.array(rho)


def integrated_time(rho: np.ndarray) -> float:
    """τ = 1 + 2 Σ ρ_k up to the first negative ρ_k (Geyer's initial positive sequence)."""
    neg = np.flatnonzero(rho < 0)
    return float(1 + 2 * np.sum(rho[: neg[0] if neg.size else rho.size]))


def by_class(folders: list[Path]) -> dict[str, dict]:
    """For still and moving frames of the sessions pooled: frames, RMS of the raw error (px per
    axis), ρ_1, ρ_3 and τ."""
    out = {}
    for cls in ("still", "moving"):
        segs, centred = [], []
        for f in folders:
            e, still = errors(f)
            ok = np.isfinite(e).all(axis=1)
            mean = e[ok].mean(axis=0)
            for a, b in runs(ok & (still if cls == "still" else ~still)):
                segs.append(e[a:b])
                centred.append(e[a:b] - mean)
        if not segs:
            out[cls] = None
            continue
        every = np.concatenate(segs)
        rho = autocorrelation(centred)
        out[cls] = {"frames": every.shape[0], "rms": float(np.sqrt(np.mean(every**2))),
                    "rho1": float(rho[0]) if rho.size else np.nan,
                    "rho3": float(rho[2]) if rho.size > 2 else np.nan, "tau": integrated_time(rho)}
    return out


def still_tau(folders: list[Path]) -> float:
    """τ of detect's error on still frames, pooled over ``folders``: the camera rows'
    pixel_still_tau (validation/mocap_rates.py measures it on the trials other than the one
    scored); 1 where none has a still run."""
    c = by_class(folders)["still"]
    return 1.0 if c is None else max(1.0, c["tau"])


HEADER = ["| sessions | still frames | RMS px | ρ1 | ρ3 | τ (frames) | moving frames | RMS px | ρ1 "
          "| ρ3 | τ (frames) |", "|---|---|---|---|---|---|---|---|---|---|---|"]


def row(name: str, folders: list[Path]) -> str:
    c = by_class(folders)
    cells = []
    for cls in ("still", "moving"):
        v = c[cls]
        cells.append("0 | — | — | — | —" if v is None else
                     f"{v['frames']} | {v['rms']:.2f} | {v['rho1']:.2f} | {v['rho3']:.2f} | "
                     f"{v['tau']:.1f}")
    return f"| {name} | " + " | ".join(cells) + " |"


def main() -> None:
    groups: dict[str, list[Path]] = {}
    for arg in sys.argv[1:]:
        kind, folder = arg.split("=", 1)
        groups.setdefault(kind, []).append(Path(folder))
    print("\n".join(HEADER + [row(k, v) for k, v in groups.items()]))


if __name__ == "__main__":
    main()
