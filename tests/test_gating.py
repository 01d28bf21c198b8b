"""The χ² gate and the re-seeding of fuse/robust.py: a wrong detection the gate keeps out
changes nothing (the estimate equals the one with that detection missing), a filter that has
drifted re-acquires instead of being locked out, the ray-sphere points lie on the ray and on
the sphere, and the compiled kernels still equal the numpy references with both at work."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from armtrack_cli.core.streams import CameraModel
from armtrack_cli.fuse import robust
from armtrack_cli.fuse.methods import Inputs, run_gaussian, run_particles
from armtrack_cli.fuse.models import Arm, Projection, Steps
from armtrack_cli.fuse.settings import FuseSettings

WRONG = [8, 15, 22]  # isolated frames whose detection is replaced by a far-away pixel


def _camera_problem(n_frames=30, seed=1):
    """A wrist moving on its arm sphere (forearm still, so the sphere's centre is fixed), seen
    by a distorting pinhole camera 1.5 m above; exact IMU steps; detections with 2 px noise,
    frames 4, 5 and 11 missing. Returns inputs, x0 (the truth, 1 cm off), P0, projection, arm."""
    rng = np.random.default_rng(seed)
    K = np.array([[600.0, 0, 320], [0, 610.0, 240], [0, 0, 1]])
    R = np.array([[1.0, 0, 0], [0, -1.0, 0], [0, 0, -1.0]])  # looking down at the table
    proj = Projection(CameraModel(K, np.array([0.1, -0.05, 0.001, -0.002, 0.01]), 640, 480, R,
                                  np.array([-0.3, 0.2, 1.6])))
    arm = Arm(shoulder=np.r_[0.1, 0.45, 0.32], L1=0.31, L2=0.27, forearm_B=np.r_[0.0, 1.0, 0.0])
    centre = arm.shoulder + arm.L2 * arm.forearm_B  # q_WB = identity
    t = np.arange(n_frames) / 30.0
    d = np.array([0.5, -0.6, -0.6]) + 0.3 * np.c_[np.cos(2 * t), np.sin(2 * t), 0 * t]
    p = centre + arm.L1 * d / np.linalg.norm(d, axis=1, keepdims=True)
    v = np.gradient(p, t, axis=0)
    dt = np.r_[0.0, np.diff(t)]
    dv = np.r_[np.zeros((1, 3)), np.diff(v, axis=0)]
    dp = np.r_[np.zeros((1, 3)), p[1:] - p[:-1] - v[:-1] * dt[1:, None]]  # F x + b = x exactly
    z = proj(p) + rng.normal(0, 2.0, (n_frames, 2))
    z[[4, 5, 11]] = np.nan
    x0 = np.r_[p[0] + rng.normal(0, 0.01, 3), v[0]]
    P0 = np.diag([0.03**2] * 3 + [0.05**2] * 3)
    q = np.tile([1.0, 0, 0, 0], (n_frames, 1))
    return Inputs(Steps(dt, dp, dv, 0.05), z, q), x0, P0, proj, arm


def _run(method, inp, x0, P0, proj, arm, s, compiled):
    if method in ("ekf", "ukf"):
        return run_gaussian(inp, x0, P0, proj, s, method, compiled=compiled)
    return run_particles(inp, x0, P0, proj, s, arm, constrained=method == "pf-constraint",
                         compiled=compiled)


def _variants():
    inp, x0, P0, proj, arm = _camera_problem()
    wrong, missing = inp.z.copy(), inp.z.copy()
    wrong[WRONG] += np.array([180.0, -150.0])  # ~60 cm away at 1.6 m: no wrist is there
    missing[WRONG] = np.nan
    return (Inputs(inp.steps, wrong, inp.q_WB), Inputs(inp.steps, missing, inp.q_WB), x0, P0,
            proj, arm)


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("method", ["ekf", "ukf", "pf", "pf-constraint"])
def test_a_gated_detection_is_the_same_as_a_missing_one(method, compiled):
    wrong, missing, x0, P0, proj, arm = _variants()
    s = FuseSettings(method=method, particles=300, seed=5)
    a = _run(method, wrong, x0, P0, proj, arm, s, compiled)
    b = _run(method, missing, x0, P0, proj, arm, s, compiled)
    assert (a.codes[WRONG] == robust.GATED).all() and (b.codes[WRONG] == robust.NONE).all()
    others = np.setdiff1d(np.arange(a.codes.size), WRONG)
    np.testing.assert_array_equal(a.codes[others], b.codes[others])
    np.testing.assert_array_equal(a.mean, b.mean)
    np.testing.assert_array_equal(a.cov, b.cov)
    # and the gate is what did it: without it the wrong pixels pull the estimate away
    off = _run(method, wrong, x0, P0, proj, arm, replace(s, gate_chi2=0.0), compiled)
    assert np.abs(off.mean[WRONG[0], :3] - b.mean[WRONG[0], :3]).max() > 0.01


@pytest.mark.parametrize("method", ["ekf", "ukf", "pf", "pf-constraint"])
def test_a_drifted_filter_reacquires(method):
    """The filter starts 12 cm from the wrist, sure of itself (1 cm), as after a long
    occlusion during which it drifted: reacquire_frames detections are gated, the next is used
    (re-acquired), and from then on the filter follows the detections instead of being locked
    out."""
    inp, x0, _, proj, arm = _camera_problem(n_frames=40)
    x0 = x0 + np.r_[0.12, 0.0, 0.0, 0.0, 0.0, 0.0]
    P0 = np.diag([0.01**2] * 3 + [0.02**2] * 3)
    s = FuseSettings(method=method, particles=300, seed=5, reacquire_frames=4)
    est = _run(method, inp, x0, P0, proj, arm, s, True)
    seen = np.flatnonzero(np.isfinite(inp.z).all(axis=1))
    assert (est.codes[seen[:4]] == robust.GATED).all(), est.codes
    assert est.codes[seen[4]] == robust.REACQUIRED, est.codes
    assert (est.codes[seen[5:]] != robust.GATED).all(), est.codes
    resid = np.linalg.norm(proj(est.mean[-10:, :3]) - inp.z[-10:], axis=1)
    assert np.nanmax(resid) < 12.0, resid  # px: on the detections again (σ = 4 px)


@pytest.mark.parametrize("scheme, constrained", [("residual", True), ("systematic", True),
                                                  ("residual", False)])
def test_particle_kernel_equals_the_reference_while_gating_and_reseeding(scheme, constrained):
    """Same draws, so the same numbers (1e-12) and the same codes, with the gate, the
    re-acquisition (its roughening) and, for pf-constraint, the ESS-collapse re-seeding all at
    work."""
    inp, x0, P0, proj, arm = _camera_problem(n_frames=40)
    z = inp.z.copy()
    z[12:20] += np.array([120.0, 60.0])  # 8 wrong in a row: gated, then re-acquired
    inp = Inputs(inp.steps, z, inp.q_WB)
    s = FuseSettings(particles=300, resampling=scheme, seed=7, reacquire_frames=3,
                     reseed_ess=0.3)
    a = run_particles(inp, x0, P0, proj, s, arm, constrained=constrained, compiled=True)
    b = run_particles(inp, x0, P0, proj, s, arm, constrained=constrained, compiled=False)
    _assert_same(a, b, constrained)
    if constrained:  # and with the cloud's velocities moved toward a reference's
        s = replace(s, kalman_velocity=0.7)
        v_ref = np.random.default_rng(2).normal(0.0, 0.2, (z.shape[0], 3))
        c, d = (run_particles(inp, x0, P0, proj, s, arm, constrained=True, compiled=k,
                              v_ref=v_ref) for k in (True, False))
        _assert_same(c, d, constrained)
        assert np.abs(c.mean[1:, 3:] - a.mean[1:, 3:]).min() > 1e-6  # it did move them


def _assert_same(a, b, constrained):
    for code in (robust.GATED, robust.REACQUIRED) + ((robust.RESEEDED,) if constrained else ()):
        assert (b.codes == code).any(), (code, b.codes)
    np.testing.assert_array_equal(a.codes, b.codes)
    for u, v in ((a.mean, b.mean), (a.cov, b.cov), (a.ess, b.ess)):
        np.testing.assert_allclose(u, v, rtol=0, atol=1e-12 * np.abs(v).max())


@pytest.mark.parametrize("method", ["ekf", "ukf"])
def test_gaussian_kernel_equals_the_reference_while_gating(method):
    inp, x0, P0, proj, _ = _camera_problem(n_frames=40)
    z = inp.z.copy()
    z[12:20] += np.array([120.0, 60.0])
    inp = Inputs(inp.steps, z, inp.q_WB)
    s = FuseSettings(method=method, reacquire_frames=3)
    a = run_gaussian(inp, x0, P0, proj, s, method, compiled=True)
    b = run_gaussian(inp, x0, P0, proj, s, method, compiled=False)
    assert (b.codes == robust.GATED).any() and (b.codes == robust.REACQUIRED).any()
    np.testing.assert_array_equal(a.codes, b.codes)
    for u, v in ((a.mean, b.mean), (a.cov, b.cov)):
        np.testing.assert_allclose(u, v, rtol=0, atol=1e-12 * np.abs(v).max())


def test_ray_sphere_points_are_on_the_ray_and_on_the_sphere():
    inp, x0, _, proj, arm = _camera_problem()
    pts = robust.ray_sphere_points(proj, arm, inp.z, inp.q_WB)
    seen = np.isfinite(inp.z).all(axis=1)
    assert np.isnan(pts[~seen]).all()
    centres = arm.sphere_centres(inp.q_WB)
    hits = seen & (np.abs(pts[:, 0] - pts[:, 1]).max(axis=1) > 1e-9)  # the ray meets it
    assert hits.sum() > 10
    for b in range(2):
        r = np.linalg.norm(pts[hits, b] - centres[hits], axis=1)
        np.testing.assert_allclose(r, arm.L1, atol=1e-9)
        np.testing.assert_allclose(proj(pts[hits, b]), inp.z[hits], atol=1e-6)
    # nearer the camera first
    d = np.linalg.norm(pts[hits] - proj.eye, axis=2)
    assert (d[:, 0] <= d[:, 1]).all()


@pytest.mark.parametrize("chunk", [None, 7])
def test_the_kernels_ray_sphere_points_are_the_references(chunk, monkeypatch):
    """pf-constraint's kernel makes a re-seeding frame's two points itself, from the frame's
    ray: the same numbers as robust.ray_sphere_points (which the numpy reference re-seeds
    on), bit for bit, where the ray meets the sphere and where it misses it; and
    ray_sphere_points given the centres it would compute is itself unchanged; its rows taken
    all at once or ``chunk`` at a time (quat.ROWS_AT_ONCE: memory)."""
    from armtrack_cli.core import quaternion as quat
    from armtrack_cli.fuse.pf_guard_kernel import _ray_sphere_points

    if chunk is not None:
        monkeypatch.setattr(quat, "ROWS_AT_ONCE", chunk)
    inp, _, _, proj, arm = _camera_problem(n_frames=60)
    z = inp.z.copy()
    z[::7] += np.array([90.0, -70.0])  # off the sphere's outline: these rays miss it
    q = np.random.default_rng(5).normal(size=(z.shape[0], 4))  # the sphere moving too
    centres = arm.sphere_centres(q)
    ref = robust.ray_sphere_points(proj, arm, z, q)
    np.testing.assert_array_equal(robust.ray_sphere_points(proj, arm, z, q, centres), ref)
    rays, out = robust.detection_rays(proj, z), np.empty((2, 3))
    # the orientations made when asked (after the rays): the same numbers
    np.testing.assert_array_equal(robust.ray_sphere_points(proj, arm, z, lambda: q), ref)
    seen = np.isfinite(z).all(axis=1)
    misses = 0
    for k in np.flatnonzero(seen):
        _ray_sphere_points(proj.eye, rays[k], centres[k], arm.L1, out)
        np.testing.assert_array_equal(out, ref[k])
        misses += bool((out[0] == out[1]).all())
    assert 5 < misses < seen.sum() - 5  # both cases at work


def test_gate_counts_a_run_and_then_reacquires():
    run, codes = 0, []
    for d2 in (1.0, 50.0, 50.0, 50.0, 50.0, 50.0, 50.0, 50.0, 50.0):
        code, run = robust.gate(d2, 13.8, run, 3)
        codes.append(code)
    G, U = robust.GATED, robust.USED  # after re-acquiring, 3 frames of grace, then gated again
    assert codes == [U, G, G, G, robust.REACQUIRED, U, U, U, G]
    assert robust.gate(1e9, 0.0, 0, 3) == (robust.USED, 0)  # 0 turns the gate off


@pytest.fixture(scope="module")
def detected(tmp_path_factory):
    from armtrack_cli import pipeline
    from armtrack_cli.simulate.arm_session import ArmSimSettings

    folder = tmp_path_factory.mktemp("gate") / "figure8"
    pipeline.simulate(folder, ArmSimSettings(task="figure8", duration_s=6.0, seed=2))
    pipeline.run(folder, through="detect")
    return folder


def test_fuse_reports_gated_frames_and_ignores_them(detected, tmp_path):
    """Through the command line: wrong pixels (a same-hue object 150 px away) on frames 30,
    60 and 90 of detections.csv are gated, counted in the summary, and the trajectory is the
    one fuse writes with those three detections marked missing (ok = 0)."""
    import json

    import pandas as pd

    from .conftest import run_cli

    det = pd.read_csv(detected / "armtrack" / "detections.csv")
    rows = [30, 60, 90]
    outs = {}
    for name in ("wrong", "missing"):
        out = tmp_path / name
        out.mkdir()
        (out / "camera.yaml").write_bytes((detected / "armtrack" / "camera.yaml").read_bytes())
        d = det.copy()
        if name == "wrong":
            d.loc[rows, "u"] = np.clip(d.loc[rows, "u"] + 150, 0, 639)
            d.loc[rows, "v"] = np.clip(d.loc[rows, "v"] - 120, 0, 479)
        else:
            d.loc[rows, "ok"] = 0
        d.to_csv(out / "detections.csv", index=False)
        r = run_cli("fuse", str(detected), "--out", str(out), "--json",
                    "--recipe", "tao2008-pf-constraint")
        assert r.exit_code == 0, r.output
        outs[name] = (json.loads(r.stdout), pd.read_csv(out / "trajectory-pf-constraint.csv",
                                                          comment="#"))
    assert outs["wrong"][0]["gated_frames"] == 3
    assert outs["missing"][0]["gated_frames"] == 0
    pd.testing.assert_frame_equal(outs["wrong"][1], outs["missing"][1])


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("method", ["ekf", "pf-constraint"])
def test_after_a_card_the_first_detection_reacquires_at_once(method, compiled):
    """A card hides the patch for 6 frames (≥ reacquire_frames = 4) while the filter drifts
    12 cm (its start is off by that, sure of itself): a frame without a detection counts as a
    gated one, so the first detection after the card re-acquires at once instead of being
    gated reacquire_frames more times."""
    inp, x0, _, proj, arm = _camera_problem(n_frames=40)
    z = inp.z.copy()
    z[:6] = np.nan
    inp = Inputs(inp.steps, z, inp.q_WB)
    x0 = x0 + np.r_[0.12, 0.0, 0.0, 0.0, 0.0, 0.0]
    P0 = np.diag([0.01**2] * 3 + [0.02**2] * 3)
    s = FuseSettings(method=method, particles=300, seed=5, reacquire_frames=4)
    est = _run(method, inp, x0, P0, proj, arm, s, compiled)
    seen = np.flatnonzero(np.isfinite(inp.z).all(axis=1))
    assert est.codes[seen[0]] == robust.REACQUIRED, est.codes
    assert (est.codes != robust.GATED).all(), est.codes
