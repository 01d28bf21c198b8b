"""A stage called in a child process of its own, its result (or its error) handed back: what
the stage loads (detect's compiled kernels, the video decoder's libraries and buffers) goes
with the child, instead of staying in the caller's memory for the stages after it (issue 15:
in `armtrack run`, about 36 MB of detect's stayed through fuse, whose memory peaks).

A plain ``subprocess`` of this interpreter, not ``multiprocessing``: a Dask worker (run_many)
is a daemonic process, which multiprocessing forbids to have children. The child finds the
package where the caller found it (its sys.path), writes to the caller's stderr (warnings as
they come). The two are resident at once: ``together_mb`` is their highest sum (the caller's
anonymous memory while it waits, the child's peak), what benchmarks/run.py stage() reports
where it is above the caller's own peak: a stage moved apart does not hide its memory."""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

_CHILD = "from armtrack_cli.pipeline.apart import child; child()"
_TOGETHER = [0.0]  # MB, the highest of together_mb's sums so far in this process


def together_mb() -> float:
    """The highest resident memory (MB) of this process and a child of call_apart's at once
    so far: this process's RssAnon when the child started (it holds it while it waits; its
    file-backed pages are the same libraries' the child maps, counted there) plus the
    child's VmHWM; 0 before any call (or without /proc)."""
    return _TOGETHER[0]


def _status_mb(key: str) -> float:
    """/proc/self/status's ``key`` (VmHWM, RssAnon), MB; 0 where there is none."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith(key + ":"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    return 0.0


def call_apart(module: str, name: str, *args, **kwargs) -> Any:
    """``module.name(*args, **kwargs)`` in a child process: its return value, or its
    exception raised here (its traceback printed by the child)."""
    with tempfile.TemporaryDirectory(prefix="armtrack-") as tmp:
        answer = Path(tmp) / "answer.pickle"
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
        held = _status_mb("RssAnon")
        done = subprocess.run([sys.executable, "-c", _CHILD], env=env, check=False,
                              input=pickle.dumps((module, name, args, kwargs, str(answer))))
        if not answer.exists():
            raise RuntimeError(f"{module}.{name} ended in its own process with exit code "
                               f"{done.returncode} and no answer")
        ok, value, peak = pickle.loads(answer.read_bytes())
    _TOGETHER[0] = max(_TOGETHER[0], held + peak)
    if ok:
        return value
    raise value


def child() -> None:
    """The child's side: the call from stdin, its answer (True, value) or (False, exception)
    and its peak resident memory (VmHWM, MB) into the file the caller named."""
    import importlib
    import traceback

    module, name, args, kwargs, answer = pickle.loads(sys.stdin.buffer.read())
    try:
        out = (True, getattr(importlib.import_module(module), name)(*args, **kwargs))
    except BaseException as exc:  # handed back whole, raised there
        if not isinstance(exc, Exception):
            raise
        from armtrack_cli.core.errors import ArmtrackError

        if not isinstance(exc, ArmtrackError):  # an internal error: where, for the report
            traceback.print_exc()
        try:
            pickle.loads(pickle.dumps(exc))
            out = (False, exc)
        except Exception:  # an exception that does not survive pickling: its text
            out = (False, RuntimeError(f"{type(exc).__name__}: {exc}"))
    Path(answer).write_bytes(pickle.dumps((*out, _status_mb("VmHWM"))))
