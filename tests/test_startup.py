"""Start-up (issue 15): what a shell script's `armtrack --help` and `armtrack info SESSION`
load in a fresh process. Asserted on sys.modules, never on a timing (benchmarks/run.py times
them)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from .conftest import REPO

HEAVY = ("numpy", "pandas", "scipy", "cv2", "matplotlib", "numba", "av", "mcap")


def _loaded(argv: list[str]) -> tuple[set[str], subprocess.CompletedProcess]:
    """Run armtrack's CLI on ARGV in a fresh interpreter; the HEAVY modules it loaded."""
    code = ("import sys\nfrom armtrack_cli.cli import main\n"
            "try:\n    main(sys.argv[1:], standalone_mode=False)\nexcept SystemExit:\n    pass\n"
            f"print('loaded:', *(m for m in {HEAVY!r} if m in sys.modules), file=sys.stderr)")
    r = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True,
                       cwd=REPO, check=True)
    return set(r.stderr.strip().splitlines()[-1].split()[1:]), r


@pytest.mark.parametrize("argv", [["--help"], ["fuse", "--help"], ["simulate", "--help"]])
def test_help_loads_no_numeric_library(argv):
    loaded, r = _loaded(argv)
    assert loaded == set()
    assert "Usage:" in r.stdout


def test_info_loads_numpy_and_opencv_only():
    """info reads every stream (numpy) and probes the video (OpenCV's VideoCapture: frame
    count, rate, size); it needs no pandas, scipy, matplotlib, numba, PyAV or mcap."""
    loaded, r = _loaded(["info", str(REPO / "sample_sessions" / "circle-01")])
    assert loaded <= {"numpy", "cv2"}
    assert "600 frames 640x480" in r.stdout
