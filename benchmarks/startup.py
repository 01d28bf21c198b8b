"""Start-up (issue 15): what a shell script pays before armtrack does any work.

Each figure is the best of several fresh processes, beside the reference measured in the same
run: the interpreter starting and exiting with nothing to do (`python -c pass`). The goal is
on import time: `armtrack --help` and `armtrack info SESSION` start in ≤ 0.3 s of imports.
tests/test_startup.py asserts what they load (sys.modules), this file only how long it takes.
`python benchmarks/startup.py` reruns this section of docs/benchmarks.md alone.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SESSION = REPO / "sample_sessions" / "circle-01"
GOAL_S = 0.3
HEAD = "## Start-up: a fresh process per call"

# In-process import time: `import armtrack_cli.cli`, then (for info) the stage's modules that
# armtrack_cli.pipeline loads on first use; printed as seconds.
_IMPORTS = ("import time; t = time.perf_counter(); import armtrack_cli.cli; "
            "c = time.perf_counter() - t; {more}"
            "print(c, time.perf_counter() - t)")


def _best(argv: list[str], runs: int) -> tuple[float, str]:
    """Best wall seconds of ``runs`` fresh processes, and the last one's stdout."""
    best, out = float("inf"), ""
    for _ in range(runs):
        t = time.perf_counter()
        r = subprocess.run(argv, capture_output=True, text=True, cwd=REPO, check=True)
        best, out = min(best, time.perf_counter() - t), r.stdout
    return best, out


def _imports(more: str, runs: int) -> tuple[float, float]:
    """Best in-process seconds of importing the CLI, and of the CLI plus ``more``."""
    cli, total = [], []
    for _ in range(runs):
        out = _best([sys.executable, "-c", _IMPORTS.format(more=more)], 1)[1].split()
        cli.append(float(out[0]))
        total.append(float(out[1]))
    return min(cli), min(total)


def startup_rows(runs: int = 7) -> list[tuple[str, float, float | None]]:
    """(what, seconds, the import-time goal or None) rows; the first is the reference."""
    import os

    armtrack = str(Path(sys.executable).parent / "armtrack")
    python = _best([sys.executable, "-c", "pass"], runs)[0]
    cli, _ = _imports("", runs)
    _, info_imports = _imports("from armtrack_cli import pipeline; pipeline.info; ", runs)
    helped = _best([armtrack, "--help"], runs)[0]
    info = _best([armtrack, "info", str(SESSION)], runs)[0]
    return [("`python -c pass`: the interpreter alone (reference)", python, None),
            ("`import armtrack_cli.cli` (in the process)", cli, GOAL_S),
            ("`armtrack --help`, the whole process", helped, None),
            ("`armtrack --help`, beyond the interpreter", helped - python, GOAL_S),
            ("imports of `armtrack info` (the CLI and the info stage, in the process)",
             info_imports, GOAL_S),
            (f"`armtrack info {SESSION.name}`, the whole process (every stream read and "
             "checked)", info, None),
            ("load average (1 min) at the end", os.getloadavg()[0], None)]


def startup_lines(rows) -> list[str]:
    """The section of docs/benchmarks.md."""
    ref = rows[0][1]
    L = [HEAD, "",
         "Wall seconds, best of 7 fresh processes each, beside the interpreter's own start in "
         "the same run. `armtrack --help` imports click and armtrack's command table only; "
         "`info` adds numpy and OpenCV (the video's frame count, rate and size); no command "
         "imports pandas, scipy, matplotlib or numba before it needs them "
         "(tests/test_startup.py checks sys.modules). `python benchmarks/startup.py` reruns "
         "this section alone.", "",
         "| what | seconds | × the interpreter alone | goal | |", "|---|---|---|---|---|"]
    for what, sec, goal in rows[:-1]:
        ok = ("met" if sec <= goal else "**not met**") if goal else ""
        g = f"≤ {goal:g} s of imports" if goal else ""
        L.append(f"| {what} | {sec:.3f} | {sec / ref:.1f} | {g} | {ok} |")
    L += ["", f"Load average (1 min) at the end: {rows[-1][1]:.1f}."]
    return L


if __name__ == "__main__":
    from report import replace_section

    doc = REPO / "docs" / "benchmarks.md"
    lines = startup_lines(startup_rows())
    doc.write_text(replace_section(doc.read_text(), lines))
    print("\n".join(lines))
