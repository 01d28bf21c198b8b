"""core/threads.py (work on a second thread) and its users: a declared clock offset's check run
beside the caller gives the same result and the same one warning as run inline; the
checkpointed smoother with its models built on a second thread gives the bits it gives on
one."""

from __future__ import annotations

import threading
import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from armtrack_cli.core import threads
from armtrack_cli.core.threads import Deferred, Done, now, one_arena
from armtrack_cli.pipeline.imu_offset import resolve_imu_offset
from tests.sync_cases import case
from tests.test_smoother_blocks import _blocked, _plain, _random_problem


def test_deferred_runs_on_another_thread_and_returns_its_value():
    got = Deferred(lambda a, b=0: (threading.get_ident(), a + b), 2, b=3)
    ident, value = got.result()
    assert value == 5 and ident != threading.get_ident()
    assert got.result() == (ident, 5)  # asked again: the same value


def test_deferred_raises_its_exception_in_the_caller():
    def fails():
        raise ValueError("from the thread")

    job = Deferred(fails)
    with pytest.raises(ValueError, match="from the thread"):
        job.result()


def test_done_is_a_value_already_known():
    d = Done({"value": 1.0})
    d.start()  # nothing to start
    assert d.result() == {"value": 1.0}


def test_now_runs_at_once_on_this_thread():
    assert now(lambda a, b=0: (threading.get_ident(), a + b), 2, b=3).result() == (
        threading.get_ident(), 5)


def test_spare_core_follows_the_load(monkeypatch):
    monkeypatch.setattr(threads.os, "sched_getaffinity", lambda pid: {0, 1}, raising=False)
    monkeypatch.setattr(threads.os, "getloadavg", lambda: (1.2, 0.0, 0.0))
    assert threads.spare_core()
    monkeypatch.setattr(threads.os, "getloadavg", lambda: (1.6, 0.0, 0.0))
    assert not threads.spare_core()
    monkeypatch.setattr(threads.os, "sched_getaffinity", lambda pid: {0}, raising=False)
    monkeypatch.setattr(threads.os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    assert not threads.spare_core()


@pytest.mark.parametrize("store_mb", [8.0, 0.0])  # every block stored; none (filtered again)
def test_smoother_blocks_on_two_threads_equal_one(monkeypatch, store_mb):
    """The same bits whether the next block's model (and the backward pass's keep) is made on
    a second thread or on this one, and both the plain pass's to 1e-9."""
    x0, P0, arrays = _random_problem(np.random.default_rng(3))
    got = {}
    for spare in (True, False):
        monkeypatch.setattr(threads, "spare_core", lambda spare=spare: spare)
        got[spare] = _blocked(x0, P0, arrays, 0.3, 0.2, 9.0, 64, store_mb)
    for a, b in zip(got[True], got[False]):
        assert np.array_equal(a, b)
    xs, Ps, gated = _plain(x0, P0, arrays, 0.3, 0.2, 9.0)
    assert np.array_equal(got[True][2], gated) and gated.sum() > 10
    assert np.abs(got[True][0] - xs).max() < 1e-9 and np.abs(got[True][1] - Ps).max() < 1e-9


def test_one_arena_twice_is_harmless():
    one_arena()
    one_arena()
    assert Deferred(sum, [1, 2, 3]).result() == 6


def test_declared_offsets_check_beside_equals_it_inline():
    """True offset 0.2 s declared as 0: the check beside (started, then waited for) and the
    inline one give the same dict, and each one warning line, raised on the caller's thread."""
    p = case(0.2, task="figure8")
    session = SimpleNamespace(sync=SimpleNamespace(imu_offset_s=0.0), arm=None)
    args = (session, Path("imu.txt"), p.t_imu, p.q_WB, p.a_W, p.t_frames, p.uv, p.proj, p.arm)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        used_inline, inline = resolve_imu_offset(*args)
        inline_info = inline.result()
        n_inline = len(seen)
        used_beside, beside = resolve_imu_offset(*args, beside=True)
        assert len(seen) == n_inline  # nothing checked yet
        beside.start()
        beside_info = beside.result()
    assert used_inline == used_beside == 0.0
    assert inline_info == beside_info and abs(inline_info["estimate"] - 0.2) < 0.02
    warned = [str(w.message) for w in seen if "clock offset" in str(w.message)]
    assert len(warned) == 2 and warned[0] == warned[1], warned


def test_lazy_runs_on_its_thread_once_started_else_on_the_callers():
    here = threading.get_ident()
    started = threads.Lazy(threading.get_ident)
    started.start()
    started.start()  # a second start starts nothing more
    assert started.result() != here
    assert threads.Lazy(threading.get_ident).result() == here  # never started: made here


def test_then_applies_its_function_once_on_the_callers_thread():
    calls = []

    def judge(v):
        calls.append(threading.get_ident())
        return v + 1

    got = threads.Then(threads.Lazy(sum, [1, 2]), judge)
    got.start()
    assert got.result() == got.result() == 4
    assert calls == [threading.get_ident()]
