"""`make bench`: speed measured on this machine, written to docs/benchmarks.md.

Every row has its goal (issue 15) and the ratio to a reference measured in the same run:
decode-only for detection, FilterPy for the Gaussian filters, the numpy reference for the
compiled particle filters, the step-at-a-time form for the smoother, Tao & Hu's 0.17 s/frame
as the historical anchor. Filters are timed in CPU seconds of one thread (BLAS pinned to one
thread), video and whole stages in wall seconds; each the best of several runs. Nothing here
is asserted: speed is reported, never tested (correctness of every fast path is tested).
"""

from __future__ import annotations

import os

_ENV = dict(os.environ)  # the user's environment, for the end-to-end stages
for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"  # the filters on one core

import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from importlib.metadata import version  # noqa: E402
from pathlib import Path  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(Path(__file__).parent))
SAMPLES = REPO / "sample_sessions"
PAPER_S_PER_FRAME = 0.17  # Tao & Hu 2008, 500 particles, Pentium 4 2.8 GHz

from report import write_report  # noqa: E402
from timing import best_of  # noqa: E402

from armtrack_cli import pipeline  # noqa: E402
from armtrack_cli.session.config import load_session  # noqa: E402
from armtrack_cli.session.video import (  # noqa: E402
    iter_frames,
    iter_frames_ahead,
    iter_frames_i420,
    probe_video,
)


def wall(fn, runs: int = 3) -> float:
    return best_of(fn, runs, clock=time.perf_counter)


def cpu() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def detection_rows(tmp: str) -> list[tuple]:
    """Decoding alone, then detection, on the same video in the same run: the bundled
    sessions, a simulated one with the moving same-hue distractor and clutter (the patch is
    lost and re-acquired on the whole frame more often), and `armtrack detect --json` in a
    fresh process as a user runs it (its own frames/s). Beside the wall times, the CPU time
    of decoding alone and of the detector alone on decoded frames: what each stage costs,
    whatever else the machine runs; `detect` overlaps the two on two threads, so on an idle
    machine it cannot beat the slower of them, and on a busy one it needs their sum."""
    from armtrack_cli.simulate.arm_session import ArmSimSettings

    busy = Path(tmp) / "moving-distractor"
    pipeline.simulate(busy, ArmSimSettings(duration_s=20.0, moving_distractor=True, clutter=True,
                                           distractor=True))
    rows = []
    for folder in (SAMPLES / "circle-01", busy, SAMPLES / "wrist-rom-01"):
        name = folder.name
        session = load_session(folder)
        video = probe_video(session.camera.video)
        n, i420 = video.n_frames, True  # detect reads both kinds as I420
        dec = wall(lambda v=video: sum(1 for _ in iter_frames(v)), 3)
        dec_cpu = best_of(lambda v=video: sum(1 for _ in iter_frames(v)), 3)
        if i420:
            yuv = wall(lambda v=video: sum(1 for _ in iter_frames_i420(v)), 3)
            yuv_cpu = best_of(lambda v=video: sum(1 for _ in iter_frames_i420(v)), 3)
        dec2 = wall(lambda v=video, y=i420: sum(1 for _ in iter_frames_ahead(v, i420=y)), 3)
        det = wall(lambda f=folder, n=name: pipeline.detect(f, out=os.path.join(tmp, n)), 3)
        kind, alone = detector_alone(session, video, i420)
        ref = min(dec, yuv) if i420 else dec  # the faster decoder's time
        rows.append((f"decode only, {name}", n, dec, ref, ""))
        rows.append((f"decode only, {name} (CPU)", n, dec_cpu, ref, ""))
        if i420:
            rows.append((f"decode only, PyAV I420 planes (no conversion), {name}", n, yuv, ref,
                         ""))
            rows.append((f"decode only, PyAV I420 planes, {name} (CPU)", n, yuv_cpu, ref, ""))
        rows.append((f"decode on a second thread{', I420' if i420 else ''}, {name}", n, dec2, ref,
                     ""))
        patch_goal = {"circle-01": "≥ 3,000 frames per CPU s",
                      "moving-distractor": "≥ 2,000 frames per CPU s"}.get(name, "") if i420 else ""
        rows.append((f"detector alone on decoded frames: {kind}, {name} (CPU)", n, alone, ref,
                     patch_goal))
        if i420:  # the OpenCV path the compiled kernel equals (tests/test_patch_kernel.py)
            rows.append((f"detector alone, OpenCV reference path (no kernel), {name} (CPU)", n,
                         detector_alone(session, video, i420, kernel=False)[1], ref, ""))
        rows.append((f"detect: {kind}, {name}", n, det, ref,
                     "≥ 1,500 frames/s and ≤ 2.5× decode-only"))
        if name in ("circle-01", "wrist-rom-01"):
            rows.append((f"`armtrack detect {name} --json` (fresh process, its own frames/s, the "
                         "CSV included; one-time set-ups apart: kernel_setup_s, decoder_setup_s)", n,
                         n / _detect_cli(folder, Path(tmp) / "cli"), ref,
                         "≥ 1,500 frames/s and ≤ 2.5× decode-only"))
            # what the fresh process pays besides (palm_profile.py, patch_profile.py)
            rows.append((f"`armtrack detect {name} --json`, the whole process (start-up, "
                         "set-up, CSV)", n, _process_wall(folder, Path(tmp) / "cli"), ref, ""))
    return rows


def detector_alone(session, video, i420: bool = False, *, kernel: bool = True
                   ) -> tuple[str, float]:
    """What is detected, and the detector's CPU seconds (best of 3) on the decoded frames (as
    detect gets them: with ``i420`` PyAV's planes, each run on fresh YuvFrames so that no
    conversion is kept from an earlier run; ``kernel``: the patch tracker's compiled kernel,
    else its OpenCV reference path)."""
    from armtrack_cli.detect.palm_blobs import PalmBlobDetector
    from armtrack_cli.detect.patch_tracker import PatchTracker
    from armtrack_cli.vision.yuv import YuvFrame

    if i420 and session.palm is not None:
        planes, c = [img for _, _, img in iter_frames_i420(video)], session.palm.colour

        def run_palm():
            fresh = [YuvFrame(f.y, f.u, f.v) if isinstance(f, YuvFrame) else f for f in planes]
            det = PalmBlobDetector(c.low, c.high)
            t0 = time.process_time()
            for f in fresh:
                det.detect(f)
            return time.process_time() - t0

        return "palm blobs (I420)", min(run_palm() for _ in range(3))
    if i420:
        planes = [img for _, _, img in iter_frames_i420(video)]
        c = session.camera.patch

        def run():
            fresh = [YuvFrame(f.y, f.u, f.v) if isinstance(f, YuvFrame) else f for f in planes]
            tracker = PatchTracker(c.low, c.high, fps=video.fps, kernel=kernel)
            t0 = time.process_time()
            for i, f in enumerate(fresh):
                tracker.step(i, f)
            return time.process_time() - t0

        return "wrist patch (CamShift, I420)", min(run() for _ in range(3))
    frames = [img for _, _, img in iter_frames(video)]
    if session.palm is not None:
        c = session.palm.colour
        return "palm blobs", best_of(lambda: [d.detect(f) for d in [PalmBlobDetector(
            c.low, c.high)] for f in frames], 3)
    c = session.camera.patch
    return "wrist patch (CamShift)", best_of(lambda: [t.step(i, f) for t in [PatchTracker(
        c.low, c.high, fps=video.fps)] for i, f in enumerate(frames)], 3)


def detection_only() -> None:
    """`python benchmarks/run.py --detection`: the detection rows alone, written over the
    detection section of docs/benchmarks.md (the other sections kept)."""
    import tempfile

    from report import detection_lines, replace_section

    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        rows = detection_rows(tmp)
    doc = REPO / "docs" / "benchmarks.md"
    lines = detection_lines({"detect": rows, "detect_load": (load0, os.getloadavg()[0])})
    doc.write_text(replace_section(doc.read_text(), lines))
    print("\n".join(lines))


def _detect_cli(folder: Path, out: Path) -> float:
    """The best frames_per_s of three `armtrack detect --json` calls."""
    import json
    import subprocess

    exe = str(Path(sys.executable).parent / "armtrack")
    return max(json.loads(subprocess.run(
        [exe, "detect", str(folder), "--out", str(out), "--json"], capture_output=True,
        text=True, check=True, env=_ENV).stdout)["frames_per_s"] for _ in range(3))


def _process_wall(folder: Path, out: Path) -> float:
    """The best wall seconds of three whole `armtrack detect --json` processes."""
    import subprocess

    exe = str(Path(sys.executable).parent / "armtrack")
    return best_of(lambda: subprocess.run([exe, "detect", str(folder), "--out", str(out),
                                           "--json"], capture_output=True, check=True,
                                          env=_ENV), 3, clock=time.perf_counter)


def prepared(tmp: str):
    import numpy as np

    from armtrack_cli.fuse.models import initial_wrist
    from armtrack_cli.pipeline.fuse import prepare, settings_for

    folder = SAMPLES / "circle-01"
    out = Path(tmp) / "fuse"
    pipeline.calibrate(folder, out=out)
    pipeline.detect(folder, out=out)
    # pf-constraint: the filters' rows and the scaling run on arrays (the default arm-smoother
    # needs the IMU samples themselves; its first pass is this pf-constraint + RTS)
    s, _ = settings_for(None, (), method="pf-constraint", seed=0)
    prep = prepare(load_session(folder), out, s)
    inp, proj, arm = prep.inputs, prep.projection, prep.arm
    x0 = np.zeros(6)
    x0[:3], _ = initial_wrist(proj, inp.z[0], arm=arm, q_WB=inp.q_WB[0], plane_height_m=0.07)
    P0 = np.diag([s.init_pos_sigma_m**2] * 3 + [s.init_vel_sigma_m_s**2] * 3)
    return folder, out, s, inp, proj, arm, x0, P0


def tiled(inp, n_frames: int):
    """circle-01's inputs repeated to n_frames (a longer session of the same kind; the
    filters' work per frame does not depend on the values)."""
    import numpy as np

    from armtrack_cli.fuse.methods import Inputs
    from armtrack_cli.fuse.models import Steps

    reps = -(-n_frames // inp.z.shape[0])
    t = lambda a: np.concatenate([a] * reps)[:n_frames]  # noqa: E731
    st = inp.steps
    dt = t(st.dt)
    dt[dt == 0] = np.median(st.dt[1:])
    dt[0] = 0.0
    return Inputs(Steps(dt, t(st.dp), t(st.dv), st.q), t(inp.z), t(inp.q_WB))


def scaling_rows(inp, proj, arm, x0, P0, s) -> list[tuple]:
    """fuse's filter + smoother (the default method) for 1, 10 and 60 minutes at 30 fps."""
    from armtrack_cli.fuse.methods import run

    rows = []
    for minutes in (1, 10, 60):
        long = tiled(inp, minutes * 60 * 30)
        sec = best_of(lambda i=long: run(s.method, i, x0, P0, proj, s, arm),
                      runs=3 if minutes < 60 else 1)
        rows.append((minutes, long.z.shape[0], sec))
    return rows


def user_rows(folder, out) -> list[tuple]:
    """`armtrack fuse … --json` as a user runs it: frames_per_s as the command reports it (its
    own wall clock around the filter), its CPU seconds, and the compiled kernel's one-time
    set-up in that process, which it reports apart."""
    import json
    import subprocess

    exe = str(Path(sys.executable).parent / "armtrack")
    rows = []
    for recipe in ("tao2008-pf-constraint", "tao2008-pf", "tao2008-ekf", "tao2008-ukf"):
        best = None
        for _ in range(3):
            r = subprocess.run([exe, "fuse", str(folder), "--recipe", recipe, "--out", str(out),
                                "--json"], capture_output=True, text=True, check=True, env=_ENV)
            d = json.loads(r.stdout)
            best = d if best is None or d["seconds"] < best["seconds"] else best
        rows.append((recipe, best["frames"], best["seconds"], best["frames_per_s"],
                     best["cpu_seconds"], best["kernel_setup_s"]))
    return rows


def stage(code: str, env: dict | None = None) -> tuple[float, float, str]:
    """Wall seconds and peak memory (MB) of one pipeline call in its own process (the user's
    environment, or ``env``), and its error's last line if it failed."""
    import subprocess

    # VmHWM: this process's peak resident memory (ru_maxrss would carry the parent's peak
    # across the exec), or, where a stage ran apart (pipeline/apart.py: `armtrack run`
    # detects in a child), its memory and the child's at once, whichever is higher; the
    # stage's own imports only (armtrack_cli.pipeline loads each stage on first use)
    prog = ("import sys, time; from armtrack_cli import pipeline; "
            "from armtrack_cli.pipeline.apart import together_mb; "
            "from armtrack_cli.session.proc_status import status_mb; "
            "t = time.perf_counter(); " + code + "; print(time.perf_counter() - t, "
            "max(status_mb('VmHWM'), together_mb()))")
    r = subprocess.run([sys.executable, "-c", prog], capture_output=True, text=True,
                       cwd=REPO, env=_ENV if env is None else env)
    if r.returncode:  # reported in the table, not fatal
        last = (r.stderr.strip().splitlines() or ["?"])[-1]
        print(f"stage failed: {code}\n{r.stderr}", file=sys.stderr)
        return float("nan"), float("nan"), last
    sec, mb = (float(v) for v in r.stdout.split()[-2:])
    return sec, mb, ""


def warm_numba(tmp: str) -> tuple:
    """numba's one-time compile, measured, then its cache (and armtrack's bytecode) made warm,
    as an install leaves them:
    `pipeline.run` on circle-01 through fuse (every kernel detect and the default method
    use) in a throw-away process with an empty NUMBA_CACHE_DIR (it compiles everything: the
    row's seconds and peak memory), then again with the user's cache (it compiles only what a
    source change made stale), so that the end-to-end rows measure the stages, not the
    compiler."""
    import compileall
    import tempfile

    # armtrack's bytecode too, as an install leaves it (pip compiles it; an editable install
    # writes it on first import, unless PYTHONDONTWRITEBYTECODE is set, as it is on this
    # machine: each stage's process then compiled every armtrack module it imported from
    # source, ~0.05 s a stage, 0.15-0.25 s over calibrate, fuse and compare)
    compileall.compile_dir(REPO / "armtrack_cli", quiet=1)

    def code(out: str) -> str:
        return (f"pipeline.run({str(SAMPLES / 'circle-01')!r}, through='fuse', "
                f"out={str(Path(tmp) / out)!r})")

    with tempfile.TemporaryDirectory() as cache:
        row = ("one-time compile: `armtrack run circle-01 --through fuse` with an empty numba "
               "cache", *stage(code("compile"), {**_ENV, "NUMBA_CACHE_DIR": cache}),
               os.getloadavg()[0])
    stage(code("warm"))  # the user's cache, as an install leaves it
    return row


def end_to_end(tmp: str, minutes: float) -> list[tuple]:
    """A session through every stage with the default method, each stage in its own process
    so its peak memory is its own; and decoding its video once, the reference. The session
    is simulated once per simulator version (benchmarks/sessions.py: build/bench-sessions/);
    a multiple of 10 minutes beyond 10 is made of back-to-back copies of the 10-minute one
    (sessions.tiled_session); BENCH_SESSIONS=DIR takes DIR/long-MINUTES instead where it
    exists."""
    import shutil

    from sessions import long_session, tiled_session

    keep = Path(os.environ.get("BENCH_SESSIONS", "/nonexistent")) / f"long-{minutes:g}"
    if (keep / "video.mp4").exists():
        cached = keep
    elif minutes > 10 and minutes % 10 == 0:  # copies of the 10-minute one (sessions.py)
        cached = tiled_session(int(minutes // 10), 10.0, env=_ENV)
    else:
        cached = long_session(minutes, env=_ENV)
    folder = str(Path(tmp) / f"long-{minutes:g}")  # outputs in tmp, the session left as it is
    shutil.rmtree(folder, ignore_errors=True)
    Path(folder).mkdir()
    for f in cached.iterdir():
        if f.is_file():
            os.symlink(f, Path(folder) / f.name)
    video = str(Path(folder) / "video.mp4")
    rows = [("decode the video once (reference)", *stage(
        "from armtrack_cli.session.video import iter_frames, probe_video; "
        f"sum(1 for _ in iter_frames(probe_video({video!r})))"), os.getloadavg()[0])]
    for name in ("calibrate", "detect", "fuse", "compare"):
        rows.append((name, *stage(f"pipeline.{name}({folder!r})"), os.getloadavg()[0]))
    return rows


def run_one_process(tmp: str, minutes: float) -> tuple:
    """`armtrack run SESSION --through compare` as one process (each library imported once),
    into a fresh work folder so that every stage runs: wall seconds, peak memory (MB), error,
    load. After end_to_end(tmp, minutes), whose session folder it reuses."""
    folder = Path(tmp) / f"long-{minutes:g}"
    out = Path(tmp) / f"run-{minutes:g}"
    return ("`armtrack run` (calibrate → compare in one process)", *stage(
        f"pipeline.run({str(folder)!r}, through='compare', out={str(out)!r})"),
        os.getloadavg()[0])


def end_to_end_only() -> None:
    """`python benchmarks/run.py --end-to-end`: the end-to-end sections alone (BENCH_MINUTES,
    each stage in its own process and `armtrack run` as one, the growth and memory tables),
    written over those of docs/benchmarks.md (the other sections kept)."""
    import tempfile

    from report import end_to_end_lines

    minutes = [float(m) for m in os.environ.get("BENCH_MINUTES", "1,10,60").split(",")]
    from armtrack_cli.core.methods import DEFAULT_FOR_KIND

    res = {"default": DEFAULT_FOR_KIND["arm"], "e2e": {}, "run": {}}
    with tempfile.TemporaryDirectory() as tmp:
        res["compile"] = warm_numba(tmp)
        for m in minutes:
            res["e2e"][m] = end_to_end(tmp, m)
            res["run"][m] = run_one_process(tmp, m)
    res["floor"] = import_floor()
    doc = REPO / "docs" / "benchmarks.md"
    text, lines = doc.read_text(), end_to_end_lines(res)
    # from the compile's section (end_to_end_lines' first) or, without it, the first session's
    heads = [i for i in (text.find("\n## numba's one-time compile"), text.find("\n## A "))
             if i >= 0]
    start = min(heads) if heads else -1
    end = text.find("\n## Palm sessions")
    start = len(text.rstrip("\n")) if start < 0 else start
    end = len(text) if end < 0 else end
    doc.write_text(text[:start] + "\n" + "\n".join(lines) + "\n" + text[end:])
    print("\n".join(lines))


def import_floor() -> list[tuple[str, float]]:
    """Peak resident memory (MB) of a fresh process that only imports: each library fuse
    needs alone, and each stage's module (what it holds before reading a byte)."""
    rows = []
    for what, code in [("python", "pass"), ("numpy", "import numpy"), ("cv2", "import cv2"),
                       ("pandas", "import pandas"), ("scipy.signal", "import scipy.signal"),
                       ("numba", "import numba")] + [
            (f"armtrack_cli.pipeline.{st}", f"from armtrack_cli import pipeline; pipeline.{st}")
            for st in ("calibrate", "detect", "fuse", "compare")]:
        rows.append((what, stage(code)[1]))
    return rows


def main() -> None:
    import tempfile

    from filters import gaussian_vs_filterpy, pf_vs_reference, resampling_vs_filterpy, smoother_rows
    from pf_profile import passes
    from startup import startup_rows

    minutes = [float(m) for m in os.environ.get("BENCH_MINUTES", "1,10,60").split(",")]
    load0 = os.getloadavg()[1]
    res = {"startup": startup_rows()}
    with tempfile.TemporaryDirectory() as tmp:
        load_det = os.getloadavg()[0]
        res["detect"] = detection_rows(tmp)
        res["detect_load"] = (load_det, os.getloadavg()[0])
        folder, out, s, inp, proj, arm, x0, P0 = prepared(tmp)
        res["pf_load"] = os.getloadavg()[0]
        res["pf"] = pf_vs_reference(inp, proj, arm, x0, P0, s)
        res["pf_passes"] = passes()
        res["method"] = s.method
        res["gauss"] = gaussian_vs_filterpy(inp, proj, x0, P0, s)
        res["smoother"] = smoother_rows()
        res["resampling"] = resampling_vs_filterpy()
        res["scaling"] = scaling_rows(inp, proj, arm, x0, P0, s)
        res["user"] = user_rows(folder, out)
        res["e2e"], res["run"] = {}, {}
        res["compile"] = warm_numba(tmp)
        for m in minutes:
            res["e2e"][m] = end_to_end(tmp, m)
            res["run"][m] = run_one_process(tmp, m)
        res["floor"] = import_floor()
    libs = ", ".join(f"{p} {version(p)}" for p in ("numpy", "scipy", "numba",
                                                   "opencv-python-headless", "filterpy"))
    res["machine"] = (f"{cpu()}, {os.cpu_count()} logical CPUs, Python "
                      f"{platform.python_version()}; {libs}; load average (5 min) "
                      f"{load0:.1f} at the start, {os.getloadavg()[1]:.1f} at the end")
    res["paper"] = PAPER_S_PER_FRAME
    from armtrack_cli.core.methods import DEFAULT_FOR_KIND
    res["default"] = DEFAULT_FOR_KIND["arm"]
    text = write_report(res, REPO / "docs" / "benchmarks.md")
    print(text)


if __name__ == "__main__":
    if "--detection" in sys.argv[1:]:
        detection_only()
    elif "--end-to-end" in sys.argv[1:]:
        end_to_end_only()
    else:
        main()
