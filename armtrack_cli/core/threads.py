"""Work beside the main thread (issue 15: the machine has two cores and fuse or compare kept
one busy): ``Deferred(fn, *args)`` starts fn(*args) on its own thread, ``result()`` waits for
it and returns its value or raises its exception, on the caller's thread; ``Lazy`` starts it
only when asked to (``start()``), ``Then`` applies a function to its value once, on the
caller's thread (a declared clock offset's check and its warning). Only for work whose
time goes to code that lets go of the GIL (numpy's array operations, numba kernels compiled
with ``nogil=True``); pure-Python work on two threads takes as long as on one.

Memory: glibc gives each thread that allocates an arena of its own, whose freed pages stay
in the process (an arena is trimmed only from its top), so a second thread's temporaries
add to the main thread's. ``one_arena`` (run before the first thread starts) keeps every
thread on the main arena (mallopt M_ARENA_MAX = 1; a no-op without glibc): long-10's measures
with their path draws on a second thread rose 39 MB on one arena, 51 MB with an arena per
thread, 36 MB on one thread (those draws stay on one thread: no faster on two).

Fine-grained hand-offs (a smoother's blocks, hundreds a pass) pay a scheduler's wake-up each
when every core is busy with other work: there they were slower than one thread (long-10's
fuse 15.5 s against 14.9 s at load 6.5 on two cores), so such callers ask ``spare_core()``
first and run everything on their own thread when no core is free (``now``: Deferred's
interface, the call made at once)."""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from typing import Any

M_ARENA_MAX = -8  # glibc's malloc.h
_arena = {"set": False}


def one_arena() -> None:
    """Every thread's allocations from glibc's main arena (once per process)."""
    if _arena["set"]:
        return
    _arena["set"] = True
    import ctypes

    try:
        ctypes.CDLL(None).mallopt(M_ARENA_MAX, 1)
    except (OSError, AttributeError):  # not glibc
        pass


class Deferred:
    """fn(*args, **kwargs) on a thread of its own, started at once; ``result()`` its value."""

    def __init__(self, fn: Callable[..., Any], *args: Any, **kwargs: Any):
        one_arena()
        self._value: Any = None
        self._error: BaseException | None = None

        def work() -> None:
            try:
                self._value = fn(*args, **kwargs)
            except BaseException as exc:  # noqa: BLE001 (re-raised by result())
                self._error = exc

        self._thread = threading.Thread(target=work, name=getattr(fn, "__name__", "deferred"),
                                        daemon=True)
        self._thread.start()

    def result(self) -> Any:
        """fn's value once it has returned (waiting for it); its exception re-raised here."""
        self._thread.join()
        if self._error is not None:
            error, self._error = self._error, None
            raise error
        return self._value


class Done:
    """A value already known, with Deferred's ``result()``: a caller that runs the work at
    once (too large to run beside, or needed before anything else) hands back the same."""

    def __init__(self, value: Any):
        self._value = value

    def start(self) -> None:
        """Nothing to start (a deferred check's ``start``)."""

    def result(self) -> Any:
        return self._value


class Lazy:
    """fn(*args, **kwargs) on a thread of its own from ``start()`` (the caller starts it where
    its own work lets go of the GIL); ``result()`` its value, the call made there and then if
    it was never started. Once started, the arguments are held by the thread alone."""

    def __init__(self, fn: Callable[..., Any], *args: Any, **kwargs: Any):
        self._call: tuple | None = (fn, args, kwargs)
        self._job: Deferred | None = None

    def start(self) -> None:
        if self._call is not None:
            fn, args, kwargs = self._call
            self._call, self._job = None, Deferred(fn, *args, **kwargs)

    def result(self) -> Any:
        if self._call is not None:
            fn, args, kwargs = self._call
            self._call, self._job = None, Done(fn(*args, **kwargs))
        return self._job.result()


class Then:
    """``fn(pending.result())``, made once on the caller's thread when ``result()`` is first
    asked (a check's judgement and its warning: on the main thread, once); ``start()`` starts
    ``pending`` where it has a start."""

    def __init__(self, pending: Any, fn: Callable[[Any], Any]):
        self._pending, self._fn, self._value = pending, fn, None

    def start(self) -> None:
        if self._pending is not None and hasattr(self._pending, "start"):
            self._pending.start()

    def result(self) -> Any:
        if self._pending is not None:
            self._value, self._pending = self._fn(self._pending.result()), None
        return self._value


def spare_core() -> bool:
    """Whether a second thread would find a core of this process's free: the 1-minute load
    average (which counts this process's own running thread) at least one core short of
    them, with half a core's slack."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        cores = os.cpu_count() or 1
    try:
        load = os.getloadavg()[0]
    except OSError:  # no load average here
        return cores >= 2
    return cores >= 2 and load <= cores - 0.5


def now(fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Done:
    """fn(*args, **kwargs) on this thread, at once, as Deferred's ``result()``."""
    return Done(fn(*args, **kwargs))
