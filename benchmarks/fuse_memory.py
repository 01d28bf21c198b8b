"""Where fuse's resident memory goes: `python benchmarks/fuse_memory.py SESSION [STAGE]` runs
pipeline.fuse(SESSION) (the default method; the session calibrated and detected), or
pipeline.STAGE(SESSION) (compare: the session fused), in this
process while a thread samples VmRSS every 20 ms with the armtrack frames the main thread is
in, then prints the peak (VmHWM), the rises of the timeline by phase, and the stack at the
highest sample: what is live at the peak (issue 15; benchmarks/run.py's end-to-end rows give
the stage's peak as `make bench` measures it)."""

from __future__ import annotations

import re
import sys
import threading
import time
import traceback


def _status(key: str) -> float:
    """VmRSS or VmHWM of this process, MB."""
    return int(re.search(rf"{key}:\s*(\d+)", open("/proc/self/status").read()).group(1)) / 1024


def _where(ident: int) -> str:
    frame = sys._current_frames().get(ident)
    stack = [f for f in traceback.extract_stack(frame) if "armtrack_cli" in f.filename]
    return " > ".join(f"{f.filename.split('armtrack_cli/')[-1]}:{f.lineno}" for f in stack[-5:])


def main() -> None:
    main_id, log, done = threading.main_thread().ident, [], threading.Event()

    def sample() -> None:
        while not done.is_set():
            log.append((time.perf_counter(), _status("VmRSS"), _where(main_id)))
            time.sleep(0.02)

    threading.Thread(target=sample, daemon=True).start()
    t0 = time.perf_counter()
    from armtrack_cli import pipeline

    stage = sys.argv[2] if len(sys.argv) > 2 else "fuse"
    getattr(pipeline, stage)(sys.argv[1])
    done.set()
    print(f"{stage} {sys.argv[1]}: {time.perf_counter() - t0:.1f} s, VmHWM {_status('VmHWM'):.0f} MB")
    print("   s      MB  where (a row where the phase changes or RSS moved by more than 4 MB)")
    last_key, last_mb = None, 0.0
    for t, mb, w in log:
        key = " > ".join(w.split(" > ")[:3])
        if key != last_key and abs(mb - last_mb) > 1 or abs(mb - last_mb) > 4:
            print(f"{t - t0:7.2f} {mb:6.0f}  {w}")
            last_key, last_mb = key, mb
    t, mb, w = max(log, key=lambda r: r[1])
    print(f"highest sample: {t - t0:.2f} s, {mb:.0f} MB, in {w}")


if __name__ == "__main__":
    main()
