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
import threading
import time
from typing import Any

from armtrack_cli.session.proc_status import status_mb

_CHILD = "from armtrack_cli.pipeline.apart import child; child()"
WATCH_S = 0.01  # how often a watched child's caller's memory is looked at (/proc: ~30 µs)
_TOGETHER = [0.0]  # MB, the highest of together_mb's sums so far in this process


def together_mb() -> float:
    """The highest resident memory (MB) of this process and a child of call_apart's at once
    so far: this process's RssAnon when the child started (it holds it while it waits; its
    file-backed pages are the same libraries' the child maps, counted there) plus the
    child's VmHWM; 0 before any call (or without /proc)."""
    return _TOGETHER[0]


def call_apart(module: str, name: str, *args, **kwargs) -> Any:
    """``module.name(*args, **kwargs)`` in a child process: its return value, or its
    exception raised here (its traceback printed by the child)."""
    return Apart(module, name, *args, **kwargs).result()


class Apart:
    """``module.name(*args, **kwargs)`` started in a child process; the caller goes on (its
    own work beside the child's: pipeline/ahead.py) until ``result()``. The caller's anonymous
    memory counts in together_mb at its highest of the start, each ``held()`` while the child
    runs and the child's end; with ``watch``, also every WATCH_S while the child runs (a thread
    looks: the caller's work has peaks between its own ``held()``s)."""

    def __init__(self, module: str, name: str, *args, watch: bool = False, **kwargs):
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
        self._what = f"{module}.{name}"
        self._held, self._out = status_mb("RssAnon"), None
        self._proc = subprocess.Popen([sys.executable, "-c", _CHILD], env=env,
                                      stdin=subprocess.PIPE, stdout=subprocess.PIPE)
        try:  # the child reads its call whole before it starts
            self._proc.stdin.write(pickle.dumps((module, name, args, kwargs)))
            self._proc.stdin.close()
        except BrokenPipeError:  # it died at once: result() says so
            pass
        if watch:
            threading.Thread(target=self._watch, daemon=True).start()

    def _watch(self) -> None:
        while self.running():
            self.held()
            time.sleep(WATCH_S)

    def running(self) -> bool:
        return self._proc.poll() is None

    def held(self) -> None:
        """The caller's anonymous memory now, counted in together_mb if the child still runs."""
        now = status_mb("RssAnon")
        if self.running():
            self._held = max(self._held, now)

    def stop(self) -> None:
        """End the child (the caller's error: its result is not wanted)."""
        if self.running():
            self._proc.kill()
        self._answer()

    def _answer(self) -> bytes:
        """The child's stdout whole (its only pipe: stderr is the caller's), once it ends."""
        if self._out is None:
            with self._proc.stdout:
                self._out = self._proc.stdout.read()
            self._proc.wait()
        return self._out

    def result(self) -> Any:
        """The call's return value, or its exception raised here; waits for the child."""
        self.held()
        out = self._answer()
        try:
            ok, value, peak = pickle.loads(out)
        except Exception:  # it died before answering (its own traceback on stderr)
            raise RuntimeError(f"{self._what} ended in its own process with exit code "
                               f"{self._proc.returncode} and no answer") from None
        _TOGETHER[0] = max(_TOGETHER[0], self._held + peak)
        if ok:
            return value
        raise value


def child() -> None:
    """The child's side: the call from stdin; its answer (True, value) or (False, exception)
    and its peak resident memory (VmHWM, MB) on stdout, which is the answer's alone (what
    the stage itself prints goes to stderr)."""
    import importlib
    import traceback

    answer = os.dup(1)
    os.dup2(2, 1)  # the stage's prints (Python's and C libraries') to stderr
    sys.stdout = sys.stderr
    module, name, args, kwargs = pickle.loads(sys.stdin.buffer.read())
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
    data = memoryview(pickle.dumps((*out, status_mb("VmHWM"))))
    while data:
        data = data[os.write(answer, data):]
