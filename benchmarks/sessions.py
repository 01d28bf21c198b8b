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


if __name__ == "__main__":  # python benchmarks/sessions.py 10 60: simulate ahead of `make bench`
    for m in sys.argv[1:]:
        print(long_session(float(m)))
