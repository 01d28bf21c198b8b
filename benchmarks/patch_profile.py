"""What each part of the patch tracker costs per frame (CPU µs of this process), on the frames
as `detect` gets them (PyAV's I420 planes), for the bundled circle-01 and a simulated session
with the moving same-hue distractor and clutter (many frames re-acquired on the whole frame).

    python benchmarks/patch_profile.py

Each named call of detect/patch_tracker.py is wrapped by a timer (about 1 µs a call, counted
in the totals) and its time charged to the phase it ran in: tracking (the search window) or
acquiring (the whole frame: its mask, its regions, and the tracklets' bookkeeping in
`_follow` and `_start`, which include the regions' `describe` and `Reference.failure`);
`step` is the whole frame, Python included. One table for the OpenCV reference path, one for
the compiled kernels. Prints markdown; writes nothing.
"""

from __future__ import annotations

import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import cv2  # noqa: E402

from armtrack_cli import pipeline  # noqa: E402
from armtrack_cli.detect import patch_kernel as pk  # noqa: E402
from armtrack_cli.detect import patch_tracker as pt  # noqa: E402
from armtrack_cli.session.config import load_session  # noqa: E402
from armtrack_cli.session.video import iter_frames_i420, probe_video  # noqa: E402
from armtrack_cli.simulate.arm_session import ArmSimSettings  # noqa: E402
from armtrack_cli.vision.yuv import YuvFrame  # noqa: E402

COST: dict = defaultdict(float)
CALLS: dict = defaultdict(int)
PHASE = ["other"]


def timed(fn, name: str, phase: str | None = None):
    def wrapper(*a, **k):
        if phase:
            PHASE.append(phase)
        t0 = time.process_time()
        try:
            return fn(*a, **k)
        finally:
            key = (phase or PHASE[-1], name)
            COST[key] += time.process_time() - t0
            CALLS[key] += 1
            if phase:
                PHASE.pop()
    return wrapper


class TimedCv2:
    def __getattr__(self, name):
        return timed(getattr(cv2, name), f"cv2.{name}") if callable(getattr(cv2, name)) \
            else getattr(cv2, name)


def instrument() -> None:
    pt.cv2 = TimedCv2()
    for name in ("window_bgr", "range_mask", "look", "Regions", "sparse_patch_mask"):
        setattr(pt, name, timed(getattr(pt, name), name))
    pt.whole_bgr = timed(pt.whole_bgr, "whole_bgr (before the phase)", "acquiring")
    pt.Reference.failure = timed(pt.Reference.failure, "Reference.failure")
    pk.WindowTracker.track = timed(pk.WindowTracker.track, "kernel: WindowTracker.track")
    pk.WindowTracker.whole_mask = timed(pk.WindowTracker.whole_mask,
                                        "kernel: WindowTracker.whole_mask")
    pk.regions_of = timed(pk.regions_of, "kernel: regions_of (patch_acquire_kernel)")
    pk.FrameRegions.describe = timed(pk.FrameRegions.describe, "kernel: FrameRegions.describe")
    pt.PatchTracker._follow = timed(pt.PatchTracker._follow, "_follow (tracklets, Python)")
    pt.PatchTracker._start = timed(pt.PatchTracker._start, "_start (tracklets, Python)")
    pt.PatchTracker.step = timed(pt.PatchTracker.step, "step: the whole frame", "all")
    pt.PatchTracker._track = timed(pt.PatchTracker._track, "whole phase", "tracking")
    pt.PatchTracker._acquire = timed(pt.PatchTracker._acquire, "whole phase", "acquiring")


def profile(folder: Path, kernel: bool) -> tuple[int, dict, dict]:
    session = load_session(folder)
    video = probe_video(session.camera.video)
    planes = [f for _, _, f in iter_frames_i420(video)]
    c = session.camera.patch
    pt.PatchTracker(c.low, c.high, fps=video.fps, kernel=kernel).step(0, planes[0])  # compiled
    COST.clear()
    CALLS.clear()
    tracker = pt.PatchTracker(c.low, c.high, fps=video.fps, kernel=kernel)
    for i, f in enumerate(planes):
        tracker.step(i, YuvFrame(f.y, f.u, f.v) if isinstance(f, YuvFrame) else f)
    return len(planes), dict(COST), dict(CALLS)


def main() -> None:
    instrument()
    with tempfile.TemporaryDirectory() as tmp:
        busy = Path(tmp) / "moving-distractor"
        pipeline.simulate(busy, ArmSimSettings(duration_s=20.0, moving_distractor=True,
                                               clutter=True, distractor=True))
        for kernel in (False, True):
            print("\n" + ("compiled kernel (patch_kernel.py)" if kernel else
                          "OpenCV reference path (PatchTracker(kernel=False))") + "\n")
            table([(f.name, *profile(f, kernel))
                   for f in (REPO / "sample_sessions" / "circle-01", busy)])


def table(results) -> None:
    keys = sorted({k for _, _, cost, _ in results for k in cost},
                  key=lambda k: (k[0], k[1] != "whole phase", k[1]))
    print("| phase | part | " + " | ".join(f"{name}: calls | µs per frame (all frames)"
                                          for name, *_ in results) + " |")
    print("|---|---|" + "---|---|" * len(results))
    for k in keys:
        cells = [f"{calls.get(k, 0)} | {1e6 * cost.get(k, 0.0) / n:.1f}"
                 for _, n, cost, calls in results]
        print(f"| {k[0]} | {k[1]} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
