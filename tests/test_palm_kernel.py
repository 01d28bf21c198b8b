"""The compiled ukf-palm steps (fuse/palm_kernel.py, fuse/association_kernel.py) against the
numpy reference they replace: the same numbers from the same inputs."""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.filters import manifold_ukf as mu
from armtrack_cli.filters.gaussian import SigmaPoints
from armtrack_cli.fuse import association_kernel as ak
from armtrack_cli.fuse import palm_kernel as pk
from armtrack_cli.fuse.association import associate
from armtrack_cli.fuse.palm_models import PalmUkfSettings, Rig, measure, noise_cov, process
from armtrack_cli.fuse.palm_run import track
from armtrack_cli.simulate import hand


def _rig():
    K = np.array([[580.0, 0.3, 322.7], [0, 575.0, 237.4], [0, 0, 1]])
    R = mu.exp_so3(np.array([2.9, 0.2, -0.1]))
    return Rig(K, np.array([-0.08, 0.02, 0.001, -0.0005, 0.003]), R, np.array([0.02, -0.01, 0.6]),
               hand.palm_model())


def _state(rng):
    A = rng.normal(size=(12, 12)) * 0.05
    P = A @ A.T + np.diag(np.r_[[1e-3] * 3, [1e-5] * 3, [1e-3] * 3, [0.05] * 3])
    x = np.r_[rng.normal(0, 0.02, 3), rng.normal(0, 0.1, 3), rng.normal(0, 1.0, 3)]
    return mu.ManifoldState(mu.exp_so3(rng.normal(0, 0.5, 3)), x, P)


@pytest.mark.parametrize("seed", range(5))
def test_compiled_prior_and_correct_equal_the_numpy_reference(seed):
    rng = np.random.default_rng(seed)
    rig, s, st, dt = _rig(), PalmUkfSettings(alpha=0.7, kappa=1.0), _state(rng), 0.033
    sp = SigmaPoints(18, alpha=s.alpha, beta=s.beta, kappa=s.kappa)
    rvar = np.r_[np.full(12, 1.3), np.full(6, 2e-5)]
    pr = mu.predict(st, lambda R, x, w: process(R, x, w, dt), noise_cov(s, dt), sp)
    zm, Pzz, Pxz = mu.predicted_measurement(pr, measure(rig, pr.Rs, pr.xs), np.diag(rvar))
    Wm, Wc = sp.weights()
    work = (np.empty((37, 3, 3)), np.empty((37, 9)), np.empty((37, 12)), np.empty((37, 18)))
    R, x, P = np.empty((3, 3)), np.empty(9), np.empty((12, 12))
    zk, Pzzk, Pxzk = np.empty(18), np.empty((18, 18)), np.empty((12, 18))
    cam = np.array([rig.K[0, 0], rig.K[0, 1], rig.K[0, 2], rig.K[1, 1], rig.K[1, 2]])
    pk.prior(st.R, st.x, st.P, s.accel_density, s.ang_accel_density, dt, sp.n + sp.lam, Wm, Wc,
             rig.markers_H, rig.R_CW0, rig.T_CW0, cam, rig.dist, rvar, *work, R, x, P, zk,
             Pzzk, Pxzk)
    for a, b in ((R, pr.R), (x, pr.x), (P, pr.P), (work[0], pr.Rs), (work[2], pr.E),
                 (zk, zm), (Pzzk, Pzz), (Pxzk, Pxz)):
        assert np.abs(a - b).max() <= 1e-10 * max(1.0, np.abs(b).max())
    rows = np.array([0, 1, 4, 5, 9, 10, 12, 15])
    z = zm[rows] + rng.normal(0, 1.0, rows.size) * np.r_[[1.0] * 6, [0.003] * 2]
    ref = mu.correct(pr, z, zm[rows], Pzz[rows[:, None], rows], Pxz[:, rows])
    Ro, xo, Po = np.empty((3, 3)), np.empty(9), np.empty((12, 12))
    pk.correct(pr.R, pr.x, pr.P, rows, z, zm, Pzz, Pxz, Ro, xo, Po)
    assert np.abs(Ro - ref.R).max() < 1e-12 and np.abs(xo - ref.x).max() < 1e-12
    assert np.abs(Po - ref.P).max() < 1e-12 * max(1.0, np.abs(ref.P).max())


def test_compiled_association_equals_the_reference_on_random_scenes():
    """Random predicted markers (some close enough to merge), their blobs with noise, merged
    blobs, clutter, markers turned away: the same choice, blob by blob."""
    rng = np.random.default_rng(7)
    kw = dict(prior_marker=0.9, prior_clutter=0.1, image_area=640 * 480.0, gate=16.0)
    differing = 0
    for trial in range(400):
        M = 6
        zm = rng.uniform([50, 50], [300, 300], (M, 2))
        if trial % 3 == 0:
            zm[1] = zm[0] + rng.normal(0, 6, 2)  # two markers close together
        A = rng.normal(size=(M, 2, 2))
        S = A @ A.transpose(0, 2, 1) + np.eye(2) * rng.uniform(0.5, 6)
        seen = rng.random(M) < 0.85
        y = [zm[seen] + rng.normal(0, 1.5, (seen.sum(), 2)),
             rng.uniform(0, 400, (rng.integers(0, 4), 2))]
        if trial % 3 == 0:
            y.append(((zm[0] + zm[1]) / 2 + rng.normal(0, 0.5, 2))[None])
        y = np.vstack(y)[rng.permutation(sum(len(v) for v in y))]
        usable = rng.random(M) < 0.9
        merge = float(rng.choice([4.0, 10.0]))
        ref = associate(y, zm, S, usable, merge_px=merge, **kw)
        mob, bom = np.empty(len(y), np.int64), np.empty(M, np.int64)
        ak.associate(y, zm, S, usable, kw["prior_marker"], kw["prior_clutter"],
                     kw["image_area"], kw["gate"], merge, mob, bom)
        differing += not (np.array_equal(mob, ref.marker_of_blob)
                          and np.array_equal(bom, ref.blob_of_marker))
    assert differing == 0


def test_hungarian_finds_the_optimal_assignment():
    from itertools import permutations

    rng = np.random.default_rng(3)
    for _ in range(50):
        C = rng.normal(size=(4, 6))
        out = np.empty(4, np.int64)
        ak._hungarian(C, out)
        best = min(sum(C[i, p[i]] for i in range(4)) for p in permutations(range(6), 4))
        assert len(set(out)) == 4 and abs(C[np.arange(4), out].sum() - best) < 1e-12


def test_compiled_track_equals_the_numpy_loop():
    """A whole simulated session's blobs with clutter: both loops, the same track."""
    from armtrack_cli.simulate.palm_session import PalmSimSettings, simulate_palm

    sim = simulate_palm(PalmSimSettings(task="wrist-rom", seed=2, duration_s=4.0))
    tr, rng = sim.truth, np.random.default_rng(1)
    blobs = []
    for k in range(tr["frame_t"].size):
        v = tr["frame_marker_visible"][k]
        b = np.vstack([tr["frame_marker_px"][k][v] + rng.normal(0, 0.3, (v.sum(), 2)),
                       tr["clutter_px"][None]])
        blobs.append(np.c_[b, np.full(len(b), 100.0), np.full(len(b), np.nan)])
    cam = sim.camera
    X = tr["frame_markers_W"][0] @ cam.R_WC.T + cam.T_WC
    from armtrack_cli.fuse.palm_init import initial_pose

    init = initial_pose(tr["palm_H"], tr["frame_marker_px"][0], X[:, 2], K=cam.K, dist=cam.dist)
    rig = Rig(cam.K, cam.dist, init.R_CW0, init.T_CW0, tr["palm_H"])
    a, b = (track(tr["frame_t"], blobs, 0, rig, PalmUkfSettings(), 640 * 480.0, 100.0,
                  compiled=c) for c in (True, False))
    assert np.array_equal(a.used, b.used)
    assert all(np.array_equal(p, q) for p, q in zip(a.marker_of_blob, b.marker_of_blob))
    assert np.abs(a.R - b.R).max() < 1e-9 and np.abs(a.x - b.x).max() < 1e-9
