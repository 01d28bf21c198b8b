"""pipeline/apart.py: a stage called in a child process hands back its result or its error as
if it had run here (issue 15: `armtrack run` detects in a child, so that detect's kernels and
decoder do not stay in memory through fuse)."""

from __future__ import annotations

import os
import pickle

import pytest

from armtrack_cli.core.errors import ConfigError, DataError, DescribedError
from armtrack_cli.pipeline.apart import call_apart
from armtrack_cli.session.proc_status import status_mb


def test_the_call_runs_in_another_process_and_its_value_comes_back():
    assert call_apart("os", "getpid") != os.getpid()
    assert call_apart("os.path", "join", "a", "b") == os.path.join("a", "b")
    assert call_apart("builtins", "sorted", [3, 1, 2], reverse=True) == [3, 2, 1]


def test_an_armtrack_error_comes_back_whole(tmp_path):
    """A stage's error (what the CLI prints): the same class, file, problem and hint."""
    with pytest.raises(ConfigError) as got:  # load_session of a folder without session.toml
        call_apart("armtrack_cli.session.config", "load_session", tmp_path)
    assert str(tmp_path) in got.value.path and got.value.problem


def test_an_internal_error_comes_back_as_itself():
    with pytest.raises(ValueError, match="invalid literal"):
        call_apart("builtins", "int", "x")


@pytest.mark.parametrize("exc", [
    ConfigError("session.toml", "[arm] is missing", "add it"),
    DataError("imu.txt", "no samples"),
    DescribedError([ConfigError("a.toml", "bad", "fix"), DataError("b", "worse")], {"k": 1})])
def test_armtrack_errors_pickle_whole(exc):
    back = pickle.loads(pickle.dumps(exc))
    assert type(back) is type(exc) and str(back) == str(exc) and back.args == exc.args
    assert (back.path, back.problem, back.hint) == (exc.path, exc.problem, exc.hint)
    assert getattr(back, "described", None) == getattr(exc, "described", None)


def test_the_peak_together_counts_this_process_and_the_child():
    """together_mb: this process's anonymous memory at the call plus the child's peak, at
    least (the child's VmHWM when it answered is at most its last)."""
    from armtrack_cli.pipeline import apart

    held = status_mb("RssAnon")
    child_peak = call_apart("armtrack_cli.session.proc_status", "status_mb", "VmHWM")
    assert held > 0 and child_peak > 0
    assert apart.together_mb() >= 0.9 * held + child_peak


def test_what_the_stage_prints_does_not_spoil_the_answer(capfd):
    assert call_apart("builtins", "print", "said by the stage") is None
    assert "said by the stage" in capfd.readouterr().err


def test_the_caller_works_beside_the_child_and_its_memory_then_counts(monkeypatch):
    """Apart: the child runs while the caller goes on; what the caller holds at a held()
    while the child runs counts in together_mb beside the child's peak."""
    import numpy as np

    from armtrack_cli.pipeline import apart

    monkeypatch.setattr(apart, "_TOGETHER", [0.0])  # not an earlier test's sums
    child = apart.Apart("time", "sleep", 2.0)
    assert child.running()
    before = status_mb("RssAnon")
    block = np.ones(40 << 17)  # 40 MB, touched
    child.held()
    assert child.running()  # the caller's work came while the child slept
    assert child.result() is None and not child.running()
    assert apart.together_mb() >= before + 0.9 * block.nbytes / 2**20
    del block


def test_a_child_stopped_gives_no_answer():
    from armtrack_cli.pipeline import apart

    child = apart.Apart("time", "sleep", 30.0)
    child.stop()
    assert not child.running()
    with pytest.raises(RuntimeError, match="no answer"):
        child.result()


def test_a_watched_child_counts_the_callers_peak_between_its_own_looks(monkeypatch):
    """With watch, memory the caller held for a moment while the child ran (and let go
    before result) counts in together_mb."""
    import time

    import numpy as np

    from armtrack_cli.pipeline import apart

    monkeypatch.setattr(apart, "_TOGETHER", [0.0])  # not an earlier test's sums
    child = apart.Apart("time", "sleep", 1.5, watch=True)
    before = status_mb("RssAnon")
    block = np.ones(40 << 17)  # 40 MB, touched, then freed (its own mapping: unmapped)
    time.sleep(0.3)
    nbytes = block.nbytes
    del block
    assert child.result() is None
    assert apart.together_mb() >= before + 0.9 * nbytes / 2**20
