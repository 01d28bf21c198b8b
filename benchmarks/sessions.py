"""The long simulated sessions of `make bench`, kept between runs in build/bench-sessions/KEY/
where KEY is a hash of the simulator's source (armtrack_cli/simulate/ and the writers it
calls), the settings and the library versions that shape its bytes: a session is simulated
again only when one of those changed (a 10-minute one takes minutes, a 60-minute one half an
hour)."""

from __future__ import annotations

import hashlib
import shutil
import subprocess
import sys
from importlib.metadata import version
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
CACHE = REPO / "build" / "bench-sessions"
SOURCES = ("armtrack_cli/simulate", "armtrack_cli/pipeline/simulate.py",
           "armtrack_cli/session/export")


def simulator_key(settings: str) -> str:
    """12 hex digits over the simulator's source files, ``settings`` (its repr) and the
    versions of numpy and OpenCV."""
    h = hashlib.sha256(settings.encode())
    for src in SOURCES:
        p = REPO / src
        for f in sorted(p.rglob("*.py")) if p.is_dir() else [p]:
            h.update(str(f.relative_to(REPO)).encode())
            h.update(f.read_bytes())
    for lib in ("numpy", "opencv-python-headless"):
        h.update(f"{lib} {version(lib)}".encode())
    return h.hexdigest()[:12]


def long_session(minutes: float, env=None) -> Path:
    """The folder of a default arm session of ``minutes``, simulated (in a child process, so
    its memory is not the bench's) only when no cached one matches the simulator."""
    settings = f"ArmSimSettings(duration_s={minutes * 60})"
    folder = CACHE / simulator_key(settings) / f"long-{minutes:g}"
    if (folder / "session.toml").exists():
        return folder
    part = folder.with_name(folder.name + ".part")
    shutil.rmtree(part, ignore_errors=True)
    part.parent.mkdir(parents=True, exist_ok=True)
    code = ("from armtrack_cli import pipeline; "
            "from armtrack_cli.simulate.arm_session import ArmSimSettings; "
            f"pipeline.simulate({str(part)!r}, {settings})")
    subprocess.run([sys.executable, "-c", code], check=True, cwd=REPO, env=env)
    truth = part.with_name(part.name + ".truth.npz")
    part.rename(folder)  # complete sessions only
    if truth.exists():
        truth.rename(folder.with_name(folder.name + ".truth.npz"))
    return folder


def tiled_session(copies: int, base_minutes: float = 10, env=None) -> Path:
    """A session ``copies`` × ``base_minutes`` long made of back-to-back copies of the cached
    ``base_minutes`` one (simulating 60 minutes takes half an hour; six copies of 10 take a few
    minutes, mostly re-encoding the video). Each stream is cut to whole periods of its own
    clock (base_minutes × 60 s) and continued with continuous time stamps, frame numbers and
    (wrapping) packet counters: the simulated arm starts and ends each copy at rest at the
    same place, so the motion is continuous; the IMU's slowly wandering orientation error and
    its noise restart with each copy (a jump of a fraction of a degree)."""
    base = long_session(float(base_minutes), env=env)
    folder = base.with_name(f"tiled-{copies}x{base_minutes:g}")
    if (folder / "session.toml").exists():
        return folder
    part = folder.with_name(folder.name + ".part")
    shutil.rmtree(part, ignore_errors=True)
    part.mkdir(parents=True)
    code = ("import sys; sys.path.insert(0, 'benchmarks'); from tiling import tile; "
            f"tile({str(base)!r}, {str(part)!r}, {copies}, {base_minutes * 60.0})")
    subprocess.run([sys.executable, "-c", code], check=True, cwd=REPO, env=env)
    part.rename(folder)
    return folder


if __name__ == "__main__":  # python benchmarks/sessions.py 10 60: simulate ahead of `make bench`
    for m in sys.argv[1:]:
        print(long_session(float(m)))
