"""What `armtrack run` does in its own process while detect runs in a child (pipeline/apart.py;
issue 15): the part of fuse and compare that needs no detection, as far as it is worth its
memory (TRUTH_MAX_BYTES below): the ground truth read and denoised
(pipeline/compare.read_truth_part), a short session's IMU read (pipeline/fuse.read_imu_part),
their modules imported (numba among them). On two cores detect's decoding thread takes about
one and its detection thread part of the other; this takes the rest, at a lower priority
(NICE), so that it slows detect as little as it can, and whatever is left of it runs once
detect is done. Not the compiled kernels' loading (fuse/kernel_setup.py): ~0.4 s for ~40 MB
of anonymous memory held beside detect's child.

fuse and compare take what was read here (``take_imu``, ``take_truth``: the same functions on
the same files as they would call, so the same bytes out) and read it themselves when it is
not here. Nothing here fails a run: an error leaves that part undone, for the stage to do (and
to raise) in its own turn; the warnings a part gave are given again when its stage takes it."""

from __future__ import annotations

import importlib
import os
import resource
import threading
import time
import warnings
from dataclasses import dataclass, field
from typing import Any

from armtrack_cli.core.methods import PALM_METHODS
from armtrack_cli.pipeline.common import release_memory
from armtrack_cli.session.config import Session

NICE = 10  # the reading's priority below detect's while both run: CPU shares 1 : ~10
# What is worth its memory (issue 15: `armtrack run` at most 300 MB; its peak with detect's
# child is the child's plus this process's anonymous memory). On long-10 this process holds
# 21.5 MB as detect starts; the imports add 23.8 MB (0.5-0.7 s of CPU, numba's most of it);
# the ground truth 10.5 MB, read at a peak of +24 (0.55 s: its read and Winter's residual
# filtering); the IMU 9.2 MB, at a peak of +20 (0.28 s). All three put the sum ~56 MB above
# detect's alone (~309 MB on make bench's scale); the truth and the imports ~35 (~288); so the
# IMU is read ahead only from a short session's file, and the truth before the imports, so
# that its reading's peak comes before their memory is held.
TRUTH_MAX_BYTES = 16 << 20  # a 10-minute Qualisys file is 5.2 MB, a 60-minute one 31: held
#                             beside detect and through fuse, that one's arrays (52 MB) would
#                             raise run's peak
IMU_MAX_BYTES = 2 << 20  # a 1-minute IMU file is 0.65 MB, a 10-minute one 6.4
MODULES = ("armtrack_cli.pipeline.fuse", "armtrack_cli.pipeline.compare",  # and what they
           "armtrack_cli.fuse.trajectory", "armtrack_cli.session.column_csv",  # import when
           "armtrack_cli.session.tables")  # they run


@dataclass
class Ahead:
    """What was read ahead (each a one-element list that its stage empties, or empty) and
    how long the reading took (s, wall)."""

    imu: list = field(default_factory=list)  # [(pipeline.fuse.ImuRead, its warnings)]
    truth: list = field(default_factory=list)  # [(pipeline.compare.TruthRead, its warnings)]
    seconds: float = 0.0

    def take_imu(self) -> list | None:
        """[the IMU read ahead] for fuse's ``imu`` (its warnings given now), else None."""
        return _taken(self.imu)

    def take_truth(self) -> list | None:
        """[the truth read ahead] for compare's ``truth`` (its warnings given now), else None."""
        return _taken(self.truth)


def _taken(box: list) -> list | None:
    if not box:
        return None
    value, said = box.pop()
    for w in said:
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return [value]


def read_ahead(session: Session, methods: tuple[str, ...], *, compare: bool,
               beside=None) -> Ahead:
    """fuse's (for ``methods``) and, with ``compare``, compare's part that needs no detection;
    ``beside``: the detect child (pipeline/apart.Apart), told the caller's memory after each
    part while it runs; once it has ended, the rest runs at this thread's own priority."""
    start, ahead = time.perf_counter(), Ahead()
    arm = tuple(m for m in methods if m not in PALM_METHODS)
    with _Lowered(beside):
        def between() -> None:  # what a part freed handed back, what it keeps counted
            release_memory()
            if beside is not None:
                beside.held()

        if (compare and session.groundtruth is not None and session.palm is None
                and _small(session.groundtruth.file, TRUTH_MAX_BYTES)):
            from armtrack_cli.pipeline.compare import read_truth_part

            ahead.truth = _boxed(read_truth_part, session)
            between()
        if arm and session.imu is not None and _small(session.imu.file, IMU_MAX_BYTES):
            from armtrack_cli.pipeline.fuse import read_imu_part

            ahead.imu = _boxed(read_imu_part, session)
            between()
        for name in MODULES:
            _quietly(importlib.import_module, name)
        between()
    ahead.seconds = time.perf_counter() - start
    return ahead


def _small(path, most: int) -> bool:
    """Whether ``path`` is at most ``most`` bytes (False where it cannot be read: its stage
    says why)."""
    try:
        return os.path.getsize(path) <= most
    except OSError:
        return False


def _boxed(fn, *args) -> list:
    """[(fn(*args), the warnings it gave)], or [] if it raised."""
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        try:
            value = fn(*args)
        except Exception:  # its stage meets it again, in its turn
            return []
    return [(value, list(said))]


def _quietly(fn, *args) -> Any:
    try:
        return fn(*args)
    except Exception:  # its stage meets it again, in its turn
        return None


class _Lowered:
    """This thread NICE steps below its priority inside ``with``, or until ``beside`` (an
    Apart) has ended (a thread looks every 50 ms), where it may come back up after (root, or
    RLIMIT_NICE allowing it); else unchanged."""

    def __init__(self, beside=None):
        self._beside, self._old, self._lock = beside, None, threading.Lock()

    def __enter__(self) -> _Lowered:
        try:
            tid = threading.get_native_id()
            old = os.getpriority(os.PRIO_PROCESS, tid)
            soft = resource.getrlimit(resource.RLIMIT_NICE)[0]
            if os.geteuid() == 0 or soft == resource.RLIM_INFINITY or 20 - soft <= old:
                os.setpriority(os.PRIO_PROCESS, tid, min(old + NICE, 19))
                self._old = (tid, old)
        except (AttributeError, OSError):  # not Linux, or not allowed: unchanged
            return self
        if self._beside is not None:
            threading.Thread(target=self._after, args=(self._beside,), daemon=True).start()
        return self

    def _after(self, beside) -> None:
        while beside.running() and self._old is not None:  # (a poll, not a wait: the
            time.sleep(0.05)  # caller's polls would find the child running while one waits)
        self.restore()

    def restore(self) -> None:
        with self._lock:
            if self._old is not None:
                os.setpriority(os.PRIO_PROCESS, *self._old)
                self._old = None

    def __exit__(self, *exc) -> None:
        self.restore()
