"""[sync] imu_offset_s = "auto": the estimator (fuse/imu_sync.py) against simulated truth, and
fuse's use of it through the CLI (auto end to end; a declared offset 0.2 s off warns)."""

from __future__ import annotations

import json
import re
from dataclasses import replace

import numpy as np
import pytest

from armtrack_cli import pipeline
from armtrack_cli.fuse import models
from armtrack_cli.fuse.imu_sync import SyncProblem, estimate_imu_offset
from armtrack_cli.simulate import imu_model, kinematics
from armtrack_cli.simulate.arm_session import ArmSimSettings
from armtrack_cli.simulate.camera import default_camera
from tests.conftest import run_cli


def problem(offset_s: float, *, task: str = "circle", seed: int = 0, duration: float = 20.0,
            orientation_deg: float = 0.0) -> SyncProblem:
    """Detections (0.5 px noise) and an IMU (MTw-class noise and bias, 100 Hz, on its own
    clock: session time = IMU time + offset_s) from the simulator's exact arm kinematics."""
    rng = np.random.default_rng(seed)
    s = ArmSimSettings(task=task, duration_s=duration)
    arm = kinematics.ArmGeometry(np.array(s.shoulder), s.upper_arm_m, s.forearm_m)
    tk = kinematics.Task(task, duration, np.array(s.centre), s.size_m)
    proj = models.Projection(default_camera())
    t_f = np.arange(int(duration * 30)) / 30.0
    uv = proj(kinematics.arm_state(arm, tk, t_f).wrist) + rng.normal(0, 0.5, (t_f.size, 2))
    t_imu = np.arange(int((duration + 1 - offset_s) * 100)) / 100.0
    st = kinematics.arm_state(arm, tk, t_imu + offset_s)
    err = imu_model.orientation_error(t_imu, orientation_deg, rng)
    q = imu_model.quat.multiply(err, st.q_WB)
    a_W = (imu_model.quat.rotate(err, st.wrist_acc + imu_model.GRAVITY_W * -1)
           + imu_model.GRAVITY_W + 0.03 + rng.normal(0, 0.02, (t_imu.size, 3)))
    return SyncProblem(t_imu, a_W, q, t_f, uv, proj,
                       models.Arm(shoulder=arm.shoulder, L1=arm.upper_arm_m, L2=arm.forearm_m,
                                  forearm_B=np.array([0.0, 1.0, 0.0])))


@pytest.mark.parametrize("offset_s,task", [(-0.5, "circle"), (0.2, "figure8")])
def test_known_offset_recovered_without_orientation_error(offset_s, task):
    """Searched over ±3 s; found within 3 SD, the SD a few frames' worth at most."""
    off = estimate_imu_offset(problem(offset_s, task=task))
    assert abs(off.estimate_s - offset_s) <= 3 * off.sd_s
    assert 0 < off.sd_s < 0.03


def test_missing_detections_and_an_imu_gap():
    p = problem(0.05, task="reach", seed=2)
    uv = p.uv.copy()
    uv[200:230] = np.nan  # a 1 s occlusion
    uv[np.random.default_rng(1).random(uv.shape[0]) < 0.1] = np.nan  # and 10 % lost frames
    keep = (p.t_imu < 8.0) | (p.t_imu > 8.5)  # a 0.5 s IMU gap
    p = replace(p, uv=uv, t_imu=p.t_imu[keep], a_W=p.a_W[keep], q_WB=p.q_WB[keep])
    off = estimate_imu_offset(p)
    assert abs(off.estimate_s - 0.05) <= 3 * off.sd_s and off.sd_s < 0.05


def test_sd_covers_the_error_with_orientation_error():
    """With ~1° of slowly varying orientation error (the simulator's MTw model) the estimate
    is within 3 SD of the truth."""
    off = estimate_imu_offset(problem(-0.2, seed=4, orientation_deg=1.0))
    assert abs(off.estimate_s + 0.2) <= 3 * off.sd_s
    assert off.sd_s < 0.1


def test_too_few_detections_is_none():
    p = problem(0.0, duration=6.0)
    assert estimate_imu_offset(replace(p, uv=np.full_like(p.uv, np.nan))) is None


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    root = tmp_path_factory.mktemp("sync") / "s"
    pipeline.simulate(root, ArmSimSettings(task="figure8", duration_s=12.0, seed=5,
                                           imu_offset_s=-0.2, declare_imu_offset=False))
    pipeline.calibrate(root)
    pipeline.detect(root)
    return root


def test_auto_end_to_end(session):
    r = run_cli("fuse", str(session), "--json")
    assert r.exit_code == 0, r.output
    got = json.loads(r.stdout)["imu_offset_s"] if r.stdout.strip().startswith("{") else None
    meta = json.loads((session / "armtrack" / "trajectory-pf-constraint.meta.json").read_text())
    off = meta["settings"]["imu_offset_s"]
    assert off["from"] == "auto" and (got is None or got == off)
    assert abs(off["value"] + 0.2) <= max(3 * off["sd"], 0.02)
    info = run_cli("info", str(session))
    assert re.search(r"clock offset -0\.\d{3} ± 0\.\d{3} s \(auto", info.output)


def test_declared_offset_wrong_by_0_2_s_warns(session):
    toml = session / "session.toml"
    toml.write_text(toml.read_text().replace('imu_offset_s = "auto"', "imu_offset_s = 0"))
    r = run_cli("fuse", str(session))
    assert r.exit_code == 0, r.output
    warn = [line for line in r.stderr.splitlines() if "clock offset" in line]
    assert len(warn) == 1 and "not the declared +0.000 s" in warn[0], r.stderr
