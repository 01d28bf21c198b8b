"""The ways of decoding a session's video, on the same file in one run (issue 15): CPU seconds
of this process (all its threads) and wall seconds per frame, best of 3.

    python benchmarks/decoders.py [VIDEO ...]   (default: the bundled circle-01's video)

OpenCV as armtrack reads (BGR, FFmpeg's own threads), with fewer threads and without the BGR
conversion (CAP_PROP_CONVERT_RGB = 0: OpenCV then hands back the Y plane alone); PyAV with
each thread type, its frames left as they are, taken as I420 planes (what detect uses), or
converted to BGR. Prints a markdown table; writes nothing.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENCV_LOG_LEVEL", "ERROR")  # CONVERT_RGB = 0 warns on every frame

import av  # noqa: E402
import cv2  # noqa: E402
import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parents[1]


def opencv(path: str, threads: int | None = None, convert: bool = True):
    def run() -> int:
        params = [cv2.CAP_PROP_N_THREADS, threads] if threads else []
        cap = cv2.VideoCapture(path, cv2.CAP_FFMPEG, params)
        if not convert:
            cap.set(cv2.CAP_PROP_CONVERT_RGB, 0)
        n = 0
        while cap.read()[0]:
            n += 1
        cap.release()
        return n
    return run


def pyav(path: str, thread_type: str, take: str | None = None):
    def run() -> int:
        n = 0
        with av.open(path) as c:
            s = c.streams.video[0]
            s.thread_type = thread_type
            for f in c.decode(s):
                if take == "planes":
                    [np.frombuffer(p, np.uint8) for p in f.planes]
                elif take:
                    f.to_ndarray(format=take)
                n += 1
        return n
    return run


def best(fn, runs: int = 3) -> tuple[int, float, float]:
    cpu = wall = float("inf")
    for _ in range(runs):
        c0, w0 = time.process_time(), time.perf_counter()
        n = fn()
        cpu, wall = min(cpu, time.process_time() - c0), min(wall, time.perf_counter() - w0)
    return n, cpu, wall


def main() -> None:
    paths = sys.argv[1:] or [str(REPO / "sample_sessions" / "circle-01" / "video.mp4")]
    print(f"load average (1 min) {os.getloadavg()[0]:.1f}\n")
    print("| video | decoder | frames | CPU ms/frame | OpenCV BGR CPU ÷ this | wall frames/s |")
    print("|---|---|---|---|---|---|")
    for path in paths:
        cases = [("OpenCV, BGR (as armtrack reads)", opencv(path)),
                 ("OpenCV, BGR, 1 thread", opencv(path, threads=1)),
                 ("OpenCV, CONVERT_RGB = 0 (Y plane only)", opencv(path, convert=False))]
        for tt in ("SLICE", "FRAME", "AUTO"):
            cases.append((f"PyAV {tt}, frames as decoded", pyav(path, tt)))
        cases += [("PyAV SLICE, I420 planes (detect)", pyav(path, "SLICE", "planes")),
                  ("PyAV SLICE, to_ndarray yuv420p", pyav(path, "SLICE", "yuv420p")),
                  ("PyAV SLICE, to_ndarray bgr24", pyav(path, "SLICE", "bgr24")),
                  ("PyAV AUTO, to_ndarray bgr24", pyav(path, "AUTO", "bgr24"))]
        ref = None
        for name, fn in cases:
            n, cpu, wall = best(fn)
            ref = ref or cpu
            print(f"| {Path(path).parent.name} | {name} | {n} | {1e3 * cpu / n:.3f} | "
                  f"{ref / cpu:.2f} | {n / wall:.0f} |")


if __name__ == "__main__":
    main()
