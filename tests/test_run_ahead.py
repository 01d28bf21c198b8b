"""`armtrack run` reads fuse's IMU and compare's ground truth while detect runs in its child
(pipeline/ahead.py; issue 15): the same bytes out as the stages run one after another, each
reading its own inputs; and what was read ahead is what the stages use (read once)."""

from __future__ import annotations

import importlib

import pytest

from armtrack_cli import pipeline
from armtrack_cli.simulate.arm_session import ArmSimSettings

# the modules (pipeline.fuse and pipeline.compare are the stages' functions)
fuse_stage = importlib.import_module("armtrack_cli.pipeline.fuse")
compare_stage = importlib.import_module("armtrack_cli.pipeline.compare")

METHODS = ("ekf", "arm-smoother")  # the first takes the IMU read ahead, the second reads it


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    folder = tmp_path_factory.mktemp("ahead") / "s"
    pipeline.simulate(folder, ArmSimSettings(task="reach", duration_s=8.0, seed=4,
                                             occlusions=((3.0, 0.5),), gt_gaps=1))
    return folder


def _counted(monkeypatch, module, name: str) -> list:
    calls, real = [], getattr(module, name)

    def counting(*args, **kwargs):
        calls.append(name)
        return real(*args, **kwargs)

    monkeypatch.setattr(module, name, counting)
    return calls


def test_run_with_reading_ahead_writes_what_the_stages_one_by_one_write(session, tmp_path,
                                                                       monkeypatch):
    one_by_one = tmp_path / "stages"
    pipeline.calibrate(session, out=one_by_one)
    pipeline.detect(session, out=one_by_one)
    for m in METHODS:
        pipeline.fuse(session, method=m, seed=2, out=one_by_one)
    pipeline.compare(session, methods=METHODS, out=one_by_one)

    imu_reads = _counted(monkeypatch, fuse_stage, "read_imu_part")
    truth_reads = _counted(monkeypatch, compare_stage, "read_truth")
    r = pipeline.run(session, through="compare", methods=METHODS, seed=2, out=tmp_path / "run")
    assert r["stages"] == {"calibrate": "ran", "detect": "ran", "fuse ekf": "ran",
                           "fuse arm-smoother": "ran", "compare": "ran"}
    ahead = r["results"]["detect"]["read_ahead"]
    assert ahead["seconds"] > 0
    # read once ahead for ekf, once by arm-smoother itself; the truth once, ahead
    assert len(imu_reads) == 2 and len(truth_reads) == 1

    made = sorted(p.name for p in one_by_one.iterdir())
    assert made == sorted(p.name for p in (tmp_path / "run").iterdir())
    assert {"errors.csv", "measures.csv", "trajectory-arm-smoother.csv"} <= set(made)
    for name in made:
        assert (tmp_path / "run" / name).read_bytes() == (one_by_one / name).read_bytes(), name


def test_nothing_is_read_ahead_when_detect_is_the_last_stage(session, tmp_path, monkeypatch):
    imu_reads = _counted(monkeypatch, fuse_stage, "read_imu_part")
    r = pipeline.run(session, through="detect", out=tmp_path)
    assert "read_ahead" not in r["results"]["detect"] and imu_reads == []


def test_a_part_that_fails_ahead_is_left_to_its_stage(session, tmp_path, monkeypatch):
    """An IMU that cannot be read ahead: fuse reads it itself (and meets its error there)."""
    from armtrack_cli.pipeline.ahead import read_ahead
    from armtrack_cli.session.config import load_session

    def broken(s):
        raise OSError("unreadable")

    monkeypatch.setattr(fuse_stage, "read_imu_part", broken)
    got = read_ahead(load_session(session), ("arm-smoother",), compare=True)
    assert got.take_imu() is None and got.take_truth() is not None
    assert got.take_truth() is None  # taken once


def test_the_reading_runs_below_detects_priority_until_detect_ends():
    import os
    import threading
    import time

    from armtrack_cli.pipeline.ahead import NICE, _Lowered
    from armtrack_cli.pipeline.apart import Apart

    tid = threading.get_native_id()
    before = os.getpriority(os.PRIO_PROCESS, tid)
    if before + NICE > 19 or os.geteuid() != 0:
        pytest.skip("cannot come back up from a lowered priority here")
    child = Apart("time", "sleep", 1.0)
    with _Lowered(child):
        assert os.getpriority(os.PRIO_PROCESS, tid) == before + NICE
        child.result()
        deadline = time.monotonic() + 5
        while os.getpriority(os.PRIO_PROCESS, tid) != before and time.monotonic() < deadline:
            time.sleep(0.01)
        assert os.getpriority(os.PRIO_PROCESS, tid) == before  # detect done: back up
    assert os.getpriority(os.PRIO_PROCESS, tid) == before


def test_a_warning_given_ahead_is_given_again_when_its_stage_takes_the_part(session,
                                                                           monkeypatch):
    import warnings

    from armtrack_cli.pipeline.ahead import read_ahead
    from armtrack_cli.session.config import load_session

    def warns(s):
        warnings.warn("odd units", UserWarning, stacklevel=1)
        return "the imu"

    monkeypatch.setattr(fuse_stage, "read_imu_part", warns)
    with warnings.catch_warnings(record=True) as early:
        warnings.simplefilter("always")
        got = read_ahead(load_session(session), ("arm-smoother",), compare=False)
    assert early == [] and got.truth == []
    with pytest.warns(UserWarning, match="odd units"):
        assert got.take_imu() == ["the imu"]
