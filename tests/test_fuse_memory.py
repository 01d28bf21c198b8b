"""fuse lets go of what its later phases no longer need, so that a long session's peak memory
is not their sum (issue 15). Asserted as objects freed (their weak references dead after a
collection), not as resident memory, which is the machine's and the allocator's."""

from __future__ import annotations

import gc
import importlib
import weakref
from pathlib import Path

import numpy as np
import pytest

from armtrack_cli import pipeline
from armtrack_cli.fuse import arm_smoother, methods

from .conftest import detected_sample

fuse_stage = importlib.import_module("armtrack_cli.pipeline.fuse")  # the module (pipeline.fuse
#                                                                    is the stage's function)



def _root(a: np.ndarray) -> np.ndarray:
    """The array that owns a's memory (a view's base, and its base, …)."""
    while isinstance(a.base, np.ndarray):
        a = a.base
    return a


@pytest.fixture(scope="module")
def detected(tmp_path_factory):
    return detected_sample(tmp_path_factory)


def test_the_smoother_runs_without_the_imu_samples_first_pass_or_start(detected, monkeypatch):
    """By the arm smoother's first pass the IMU's samples (folded by then), the first pass's
    means (copied into the start trajectory) and the filter's steps (the first pass was the
    last to use them) are freed, and stay so in every later pass. fuse's outputs are written
    as before."""
    imu, first, steps, passes = [], [], [], []
    made, stepped = fuse_stage.ImuSamples, fuse_stage.models.composite_steps

    def imu_samples(*arrays):  # the IMU's arrays as fuse's inputs hold them
        imu.extend(weakref.ref(_root(a)) for a in arrays if a is not None)
        return made(*arrays)

    def composite_steps(*a, **k):  # the filter's steps as fuse's inputs hold them
        st = stepped(*a, **k)
        steps.extend(weakref.ref(_root(x)) for x in (st.dt, st.dp, st.dv))
        return st

    smooth = methods.smooth

    def first_pass(*a, **k):
        est = smooth(*a, **k)
        if k.get("means_only"):
            first.append(weakref.ref(_root(est.mean)))
        return est

    blocked = arm_smoother.smooth_blocked

    def watched(x0, P0, model, *a, **k):
        gc.collect()
        passes.append((sum(r() is not None for r in imu), sum(r() is not None for r in first),
                       sum(r() is not None for r in steps)))
        return blocked(x0, P0, model, *a, **k)

    monkeypatch.setattr(fuse_stage, "ImuSamples", imu_samples)
    monkeypatch.setattr(fuse_stage.models, "composite_steps", composite_steps)
    monkeypatch.setattr(methods, "smooth", first_pass)
    monkeypatch.setattr(arm_smoother, "smooth_blocked", watched)
    mapped, set_mapped = [], fuse_stage.large_arrays_mapped

    def large_arrays_mapped():  # before reading: the reader's arrays freed to the system too
        mapped.append(len(imu))
        set_mapped()

    monkeypatch.setattr(fuse_stage, "large_arrays_mapped", large_arrays_mapped)
    out = pipeline.fuse(detected)
    assert out["method"] == "arm-smoother" and Path(out["trajectory"]).exists()
    assert len(imu) == 4 and len(first) == 1 and len(steps) == 3 and len(passes) >= 2
    assert all(p == (0, 0, 0) for p in passes), passes
    assert mapped == [0]


def test_without_release_the_inputs_keep_their_imu(detected):
    """Inputs that were not handed over (release_imu False: every caller but fuse's) keep
    their IMU samples through the arm smoother, for a second method on the same inputs."""
    s, _ = fuse_stage.settings_for(None, (), kind="arm")
    p = fuse_stage.prepare(fuse_stage.load_session(detected), detected / "armtrack", s)
    x0 = np.zeros(6)
    x0[:3], _ = fuse_stage.models.initial_wrist(p.projection, p.inputs.z[0], arm=p.arm,
                                                q_WB=p.inputs.q_WB[0],
                                                plane_height_m=s.init_plane_m)
    P0 = np.diag([s.init_pos_sigma_m**2] * 3 + [s.init_vel_sigma_m_s**2] * 3)
    methods.run("arm-smoother", p.inputs, x0, P0, p.projection, s, p.arm)
    assert p.inputs.imu is not None and not p.inputs.release_imu
    assert p.inputs.steps is not None


def test_the_gyro_samples_are_freed_before_the_fold(detected, monkeypatch):
    """The arm smoother lets each of the IMU's arrays go after its last use: the gyroscope's
    once the orientation track is made, before the fold, so the two are never held together
    with the whole IMU (fuse@60's peak, issue 15). fuse's outputs are written as before."""
    imu, at_fold = [], []
    made, fold = fuse_stage.ImuSamples, arm_smoother.imu_fold.fold

    def imu_samples(*arrays):
        imu.append([weakref.ref(_root(a)) for a in arrays])
        return made(*arrays)

    def watched(*a, **k):
        gc.collect()
        at_fold.append([r() is not None for r in imu[0]])
        return fold(*a, **k)

    monkeypatch.setattr(fuse_stage, "ImuSamples", imu_samples)
    monkeypatch.setattr(arm_smoother.imu_fold, "fold", watched)
    out = pipeline.fuse(detected)
    assert out["method"] == "arm-smoother" and Path(out["trajectory"]).exists()
    assert at_fold == [[True, True, True, False]]  # t, q_WB, f_B still folded; w_B freed
