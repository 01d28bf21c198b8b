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


def test_the_peak_together_counts_what_this_process_held_beside_the_child():
    """What this process loads while the child runs (`armtrack run`: fuse's kernels beside
    detect) is in together_mb: its highest RssAnon meanwhile, not its start's."""
    import numpy as np

    from armtrack_cli.pipeline import apart

    child = apart.Apart("time", "sleep", (0.3,))
    held = status_mb("RssAnon")
    block = np.ones(40 * 2**20 // 8)  # 40 MB, touched, held until the child ends
    assert child.result() is None
    assert apart.together_mb() >= held + 0.9 * block.nbytes / 2**20


def test_an_error_of_the_child_comes_back_after_work_beside_it():
    from armtrack_cli.pipeline.apart import Apart

    child = Apart("builtins", "int", ("x",))
    sum(range(1000))
    with pytest.raises(ValueError, match="invalid literal"):
        child.result()


def test_what_the_stage_prints_does_not_spoil_the_answer(capfd):
    assert call_apart("builtins", "print", "said by the stage") is None
    assert "said by the stage" in capfd.readouterr().err


def test_run_frees_memory_after_the_steps_it_ran_itself(tmp_path, monkeypatch):
    """`armtrack run` hands back what a step freed (release_memory: a full collection, 40-100 ms
    with numba loaded) after each step that ran in its own process, not after detect, which
    ran in a child. The stages are stubs here: only the order of calls is looked at."""
    import importlib

    from tests.conftest import REPO

    run = importlib.import_module("armtrack_cli.pipeline.run")
    seen = []

    def stage(name):
        return lambda *a, **k: seen.append(name) or {}

    monkeypatch.setattr(run, "calibrate", lambda *a, **k: seen.append("calibrate") or {})
    monkeypatch.setattr(run, "call_apart", lambda *a, **k: seen.append("detect") or {})
    monkeypatch.setattr(run, "_stage", stage)
    monkeypatch.setattr(run, "release_memory", lambda: seen.append("release"))
    out = run.run(REPO / "sample_sessions" / "circle-01", through="compare", out=tmp_path,
                  force=True)
    assert seen == ["calibrate", "release", "detect", "fuse", "release", "compare", "release"]
    assert out["stages"]["detect"] == "ran"


def _slow_write(path) -> None:
    """atomic_write's writer for the test below: half a file, then a long wait."""
    import time

    path.write_text("half written")
    time.sleep(30)


@pytest.mark.parametrize("child_too", [True, False], ids=["terminal", "caller-only"])
def test_ctrl_c_while_the_child_writes_leaves_nothing(tmp_path, capfd, child_too):
    """`armtrack run` interrupted while detect writes in its child: the child's staged file
    (.detections.XXXX.csv) was left in the work folder, the child killed before its own
    interrupt removed it. At a terminal the Ctrl-C reaches both (``terminal``); a signal to
    the caller alone (``caller-only``) is passed on to the child."""
    import signal
    import threading
    import time

    from armtrack_cli.pipeline.apart import Apart

    child = Apart("armtrack_cli.session.outputs", "atomic_write", (tmp_path / "out.csv",
                                                                   _slow_write))
    deadline = time.monotonic() + 30
    while not list(tmp_path.iterdir()) and time.monotonic() < deadline:
        time.sleep(0.02)
    assert [p.name[:5] for p in tmp_path.iterdir()] == [".out."]  # the child is writing

    def ctrl_c() -> None:  # while this process waits in result()
        if child_too:
            child._proc.send_signal(signal.SIGINT)
        os.kill(os.getpid(), signal.SIGINT)

    timer = threading.Timer(0.3, ctrl_c)
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        child.result()
    timer.join()
    assert child._proc.returncode == 130
    assert list(tmp_path.iterdir()) == []
    assert "Traceback" not in capfd.readouterr().err
