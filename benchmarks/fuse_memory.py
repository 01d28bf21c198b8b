"""Where fuse's resident memory goes: `python benchmarks/fuse_memory.py SESSION [STAGE] [-v]`
runs pipeline.fuse(SESSION) (the default method; the session calibrated and detected), or
pipeline.STAGE(SESSION) (compare: the session fused; run: calibrate to compare, as `make bench`
runs it, into the session's work folder), in this process while a thread samples resident
memory every 20 ms with the armtrack frames the main thread is in, then prints the peak
(VmHWM), the phases with their highest memory (-v: every rise of the timeline too), and the
stack at the highest sample: what is live at the peak (issue 15; benchmarks/run.py's
end-to-end rows give the stage's peak as `make bench` measures it).

Resident memory is split as /proc/self/status does: RssAnon (the heap and numpy's arrays:
the data) and RssFile (the pages of the libraries' files, mapped as they are imported; a
fresh venv's first imports read tens of MB more of them than an old one's, so they are not
the data's and differ from one venv to another). The highest sample is the highest RssAnon."""

from __future__ import annotations

import resource
import sys
import threading
import time
import traceback

from armtrack_cli.session.proc_status import status

KEYS = ("VmRSS", "RssAnon", "RssFile", "VmHWM")
DEPTH = 2  # the frames that name a phase


def _where(ident: int) -> tuple[str, ...]:
    """The armtrack frames the thread ``ident`` is in, outermost first, as file:line."""
    frame = sys._current_frames().get(ident)
    stack = [f for f in traceback.extract_stack(frame) if "armtrack_cli" in f.filename]
    return tuple(f"{f.filename.split('armtrack_cli/')[-1]}:{f.lineno}" for f in stack)


def _phases(log: list) -> list[tuple]:
    """Consecutive samples in the same phase (the outermost DEPTH armtrack frames: the stage's
    line and the one it called) merged: start, seconds, anon at its start and its highest,
    file highest; a phase shorter than 0.2 s that raised anon by less than 4 MB is folded into
    the one before."""
    rows: list[list] = []
    for t, anon, file, w in log:
        key = " > ".join(w[:DEPTH]) or "(imports)"
        if rows and rows[-1][5] == key:
            r = rows[-1]
            r[1], r[3], r[4] = t - r[0], max(r[3], anon), max(r[4], file)
        else:
            rows.append([t, 0.0, anon, anon, file, key])
    merged: list[list] = []
    for r in rows:
        if merged and r[1] < 0.2 and r[3] - merged[-1][3] < 4:
            m = merged[-1]
            m[1], m[3], m[4] = r[0] + r[1] - m[0], max(m[3], r[3]), max(m[4], r[4])
        else:
            merged.append(r)
    return [tuple(r) for r in merged]


def main() -> None:
    main_id, log, done = threading.main_thread().ident, [], threading.Event()

    def sample() -> None:
        while not done.is_set():
            st = status(*KEYS)
            log.append((time.perf_counter(), st["RssAnon"], st["RssFile"], _where(main_id)))
            time.sleep(0.02)

    threading.Thread(target=sample, daemon=True).start()
    t0 = time.perf_counter()
    from armtrack_cli import pipeline

    args = [a for a in sys.argv[1:] if a != "-v"]
    stage = args[1] if len(args) > 1 else "fuse"
    getattr(pipeline, stage)(args[0], **({"through": "compare"} if stage == "run" else {}))
    done.set()
    end = status(*KEYS)
    from armtrack_cli.pipeline.apart import together_mb

    child = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024  # a stage apart
    print(f"{stage} {args[0]}: {time.perf_counter() - t0:.1f} s, VmHWM {end['VmHWM']:.0f} MB; "
          f"highest RssAnon {max(r[1] for r in log):.0f} MB, RssFile {max(r[2] for r in log):.0f}"
          + (f"; a child's peak {child:.0f} MB, with this process's anon {together_mb():.0f} "
             "(run's detect, pipeline/apart.py)" if child else ""))
    if "-v" in sys.argv:  # every row where the phase changes or anon moved by more than 4 MB
        print("   s   anon  file  where")
        last_key, last_mb = None, 0.0
        for t, anon, file, w in log:
            key = w[:3]
            if key != last_key and abs(anon - last_mb) > 1 or abs(anon - last_mb) > 4:
                print(f"{t - t0:7.2f} {anon:5.0f} {file:5.0f}  {' > '.join(w[-5:])}")
                last_key, last_mb = key, anon
    print("  from     s  anon: start   max  file max  phase")
    for t, dur, first, top, ftop, key in _phases(log):
        print(f"{t - t0:6.1f} {dur:5.1f}        {first:5.0f} {top:5.0f}  {ftop:8.0f}  {key}")
    t, anon, file, w = max(log, key=lambda r: r[1])
    print(f"highest anon sample: {t - t0:.2f} s, {anon:.0f} MB anon + {file:.0f} MB file, in {' > '.join(w)}")
    t, anon, file, w = max(log, key=lambda r: r[1] + r[2])
    print(f"highest total sample: {t - t0:.2f} s, {anon:.0f} + {file:.0f} MB, in {' > '.join(w)}")


if __name__ == "__main__":
    main()
