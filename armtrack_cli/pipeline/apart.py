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
import signal
import subprocess
import sys
from typing import Any

from armtrack_cli.session.proc_status import status_mb

_CHILD = "from armtrack_cli.pipeline.apart import child; child()"
STOP_GRACE_S = 1.0  # s an interrupted caller waits for its child to end by itself
_TOGETHER = [0.0]  # MB, the highest of together_mb's sums so far in this process


def together_mb() -> float:
    """The highest resident memory (MB) of this process and a child of call_apart's at once
    so far: this process's RssAnon while the child ran (the larger of what it held when it
    started it and when it waited for it; its file-backed pages are the same libraries' the
    child maps, counted there) plus the child's VmHWM; 0 before any call (or without /proc)."""
    return _TOGETHER[0]


def call_apart(module: str, name: str, *args, **kwargs) -> Any:
    """``module.name(*args, **kwargs)`` in a child process: its return value, or its
    exception raised here (its traceback printed by the child)."""
    return Apart(module, name, args, kwargs).result()


class Apart:
    """``module.name(*args, **kwargs)`` started in a child process; ``result()`` waits for it.
    Between the two this process may work beside the child: together_mb counts its RssAnon at
    the start and at result(), the larger (what it loaded and still holds; a caller that
    loads and frees beside the child would need sampling, which none does: run calls
    result() at once)."""

    def __init__(self, module: str, name: str, args: tuple = (), kwargs: dict | None = None):
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
        self._held = status_mb("RssAnon")
        self._what = f"{module}.{name}"
        self._proc = subprocess.Popen([sys.executable, "-c", _CHILD], env=env,
                                      stdin=subprocess.PIPE, stdout=subprocess.PIPE)
        try:
            self._proc.stdin.write(pickle.dumps((module, name, args, kwargs or {})))
            self._proc.stdin.close()  # the child reads its call whole before it starts
        except BrokenPipeError:  # it died at once: result() says so
            pass

    def result(self) -> Any:
        held = max(self._held, status_mb("RssAnon"))
        try:
            answer = self._proc.stdout.read()
            code = self._proc.wait()
        except BaseException:  # Ctrl-C while waiting: the child does not outlive us
            self._stop()
            raise
        finally:
            self._proc.stdout.close()
        try:
            ok, value, peak = pickle.loads(answer)
        except Exception:  # it died before answering (its own traceback on stderr)
            raise RuntimeError(f"{self._what} ended in its own process with exit code "
                               f"{code} and no answer") from None
        _TOGETHER[0] = max(_TOGETHER[0], held + peak)
        if ok:
            return value
        raise value

    def _stop(self) -> None:
        """The child ended after this process was interrupted, its staged outputs removed as
        its own interrupt removes them (session/outputs.py): a Ctrl-C at a terminal reaches
        it too, and it ends within STOP_GRACE_S; else it is sent one; killed only if it
        does not end after that (a kill leaves its staged files behind)."""
        p = self._proc
        try:
            for sig, grace in ((None, STOP_GRACE_S), (signal.SIGINT, 10 * STOP_GRACE_S)):
                if sig is not None:
                    p.send_signal(sig)
                try:
                    p.wait(grace)
                    return
                except subprocess.TimeoutExpired:
                    pass
        finally:  # a second Ctrl-C meanwhile, or a child that will not end
            if p.poll() is None:
                p.kill()
                p.wait()


def child() -> None:
    """The child's side: the call from stdin; its answer (True, value) or (False, exception)
    and its peak resident memory (VmHWM, MB) on stdout, which is the answer's alone (what
    the stage itself prints goes to stderr)."""
    import importlib
    import traceback

    answer = os.dup(1)
    os.dup2(2, 1)  # the stage's prints (Python's and C libraries') to stderr
    sys.stdout = sys.stderr
    try:
        module, name, args, kwargs = pickle.loads(sys.stdin.buffer.read())
        out = (True, getattr(importlib.import_module(module), name)(*args, **kwargs))
    except KeyboardInterrupt:  # the caller was interrupted too, and says so: no traceback
        sys.stderr.flush()
        os._exit(130)
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
    _exit_now()


def _exit_now() -> None:
    """The child's end without the interpreter's teardown (freeing every module and numba's
    compiler state: 0.18-0.22 s after detect on long-10, which the caller waited for before it
    could fuse): its outputs are written and closed, its answer sent; what Python and C
    buffered for stderr is flushed first."""
    import ctypes

    sys.stderr.flush()
    try:
        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError):  # not glibc: C's buffers are the libraries' own
        pass
    os._exit(0)
