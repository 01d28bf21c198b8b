"""What each part of palm-blob detection costs per frame (CPU µs of this process), on the frames
as `detect` gets them (PyAV's I420 planes), for the bundled wrist-rom-01: decoding, the search
of the window around the last blobs (on the planes), the search of the hand's whole region
(the hand found by skin colour, straight from the planes, its region searched), the rest of
detect(); and what a fresh `armtrack detect` process pays once before its first frame
(importing numba, numba's first-use set-up, the kernels loaded from their cache, PyAV).

    python benchmarks/palm_profile.py

Each part is wrapped by a timer (about 1 µs a call, counted in the totals); the one-time costs
are measured in fresh processes (best of 3). Prints a markdown table; writes nothing.
"""

from __future__ import annotations

import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from armtrack_cli.detect import palm_blobs as pb  # noqa: E402
from armtrack_cli.session.config import load_session  # noqa: E402
from armtrack_cli.session.video import iter_frames_i420, probe_video  # noqa: E402
from armtrack_cli.vision.yuv import YuvFrame  # noqa: E402

SESSION = REPO / "sample_sessions" / "wrist-rom-01"
COST: dict = defaultdict(float)
CALLS: dict = defaultdict(int)

ONCE = """
import time
c0 = time.process_time(); import numba
c1 = time.process_time()
from armtrack_cli.detect.palm_blobs import PalmBlobDetector
d = PalmBlobDetector((100, 150, 60), (130, 255, 255))
c2 = time.process_time(); d.warm()
c3 = time.process_time(); import av
c4 = time.process_time()
print(c1 - c0, c2 - c1, c3 - c2, c4 - c3)
"""


def timed(obj, name: str, label: str, undo: list) -> None:
    """obj.name wrapped by a timer charging label; undo gets what puts it back."""
    fn = getattr(obj, name)
    undo.append(lambda: setattr(obj, name, fn))

    def wrapper(*a, **k):
        t0 = time.process_time()
        try:
            return fn(*a, **k)
        finally:
            COST[label] += time.process_time() - t0
            CALLS[label] += 1

    setattr(obj, name, wrapper)


def per_frame(frames: list) -> dict[str, tuple[float, int]]:
    """Best of 3 runs: {part: (µs per frame, calls)}."""
    c = load_session(SESSION).palm.colour
    best: dict = {}
    for _ in range(3):
        COST.clear()
        CALLS.clear()
        det = pb.PalmBlobDetector(c.low, c.high)
        det.warm()
        fresh, undo = [YuvFrame(f.y, f.u, f.v) for f in frames], []
        timed(det, "_search", "search", undo)
        timed(det, "_full", "full", undo)
        timed(pb, "whole_bgr", "whole", undo)
        timed(det, "_hand_roi", "skin", undo)
        t0 = time.process_time()
        for f in fresh:
            det.detect(f)
        COST["detect() in all"] = time.process_time() - t0
        CALLS["detect() in all"] = len(fresh)
        for put_back in undo:
            put_back()
        if not best or COST["detect() in all"] < best["detect() in all"][0]:
            best = {k: (v, CALLS[k]) for k, v in COST.items()}
    return {k: (v * 1e6 / len(frames), n) for k, (v, n) in best.items()}


def decode_cpu(video) -> float:
    best = float("inf")
    for _ in range(3):
        t0 = time.process_time()
        sum(1 for _ in iter_frames_i420(video))
        best = min(best, time.process_time() - t0)
    return best * 1e6 / video.n_frames


def once_costs() -> list[float]:
    runs = [[float(x) for x in subprocess.run([sys.executable, "-c", ONCE], cwd=REPO,
                                              capture_output=True, text=True,
                                              check=True).stdout.split()] for _ in range(3)]
    return [min(r[i] for r in runs) for i in range(4)]


def main() -> None:
    video = probe_video(load_session(SESSION).camera.video)
    frames = [f for _, _, f in iter_frames_i420(video)]
    parts, dec, once = per_frame(frames), decode_cpu(video), once_costs()
    total = parts["detect() in all"][0]
    full, skin = parts["full"][0], parts["skin"][0]
    whole, n_whole = parts.get("whole", (0.0, 0))
    region = full - skin  # _full calls _hand_roi, then _search
    window = parts["search"][0] - region
    rows = [("detect() in all", total, video.n_frames),
            ("search of the window (kernel, on the planes)", window,
             video.n_frames - parts["full"][1]),
            ("re-acquiring: the hand's whole region, in all", full, parts["full"][1]),
            ("  the hand by skin colour at half size (kernel, on the planes)", skin,
             parts["skin"][1]),
            ("  search of the hand's region (kernel, on the planes)", region, parts["full"][1]),
            ("    of which the whole frame to BGR (OpenCV: the first frame's reference "
             "histogram)", whole, n_whole),
            ("the rest of detect() (bookkeeping, the next window)", total - window - full, "")]
    print(f"wrist-rom-01, {video.n_frames} frames; CPU µs per frame of all frames (best of "
          "3):\n")
    print("| part | µs per frame | calls | share of detect() |\n|---|---|---|---|")
    print(f"| decoding (PyAV, I420 planes; on the other thread in `detect`) | {dec:.0f} | "
          f"{video.n_frames} | |")
    for name, us, n in rows:
        print(f"| {name} | {us:.0f} | {n} | {100 * us / total:.0f} % |")
    names = ("import numba", "numba's first use and the kernels from their cache (warm)",
             "import PyAV")
    vals = (once[0], once[2], once[3])
    print("\nOnce per process (CPU ms, fresh process, best of 3):\n\n| what | ms |\n|---|---|")
    for name, v in zip(names, vals):
        print(f"| {name} | {v * 1e3:.0f} |")


if __name__ == "__main__":
    main()
