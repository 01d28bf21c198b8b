"""Re-acquisition after the markers were lost for longer than max_coast_s
(fuse/palm_reacquire.py): the blobs labelled by the palm model alone, the pose fitted again,
and the filter going on."""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.filters.manifold_ukf import exp_so3, log_so3
from armtrack_cli.fuse.palm_init import initial_pose
from armtrack_cli.fuse.palm_models import PalmUkfSettings, Rig, measure
from armtrack_cli.fuse.palm_reacquire import reacquire
from armtrack_cli.fuse.palm_run import track, trajectory_table
from armtrack_cli.simulate import hand
from armtrack_cli.simulate.palm_session import PalmSimSettings, simulate_palm


def _rig():
    K = np.array([[580.0, 0, 322.7], [0, 580.0, 237.4], [0, 0, 1]])
    R_CW0 = np.diag([1.0, -1.0, -1.0])  # looking down at the hand's back
    return Rig(K, np.array([-0.08, 0.02, 0.0, 0.0, 0.0]), R_CW0, np.array([0.0, 0.0, 0.62]),
               hand.palm_model())


@pytest.mark.parametrize("with_depth", [True, False])
def test_reacquire_labels_the_blobs_and_recovers_the_pose(with_depth):
    """Random wrist poses (±50° about each axis, ±8 cm) with two clutter blobs among the six
    marker blobs, shuffled: every marker named right, the pose to 1e-6 from exact blobs."""
    rig, rng = _rig(), np.random.default_rng(5)
    for _ in range(20):
        R = exp_so3(np.radians(rng.uniform(-50, 50, 3)))
        T = rng.uniform(-0.08, 0.08, 3)
        z = measure(rig, R[None], np.r_[T, np.zeros(6)][None])[0]
        px, depth = z[:12].reshape(6, 2), z[12:]
        clutter = rng.uniform([40, 40], [600, 440], (2, 2))
        b = np.c_[np.vstack([px, clutter]), np.full(8, 100.0),
                  np.r_[depth, 0.66, 0.66] if with_depth else np.full(8, np.nan)]
        perm = rng.permutation(8)
        got = reacquire(b[perm], rig, sigma_px=1.0, sigma_z=0.004)
        assert got is not None
        R_hat, T_hat, mob = got
        assert np.array_equal(mob, np.r_[np.arange(6), -1, -1][perm])
        assert np.linalg.norm(log_so3(R_hat.T @ R)) < 1e-6 and np.abs(T_hat - T).max() < 1e-6


def test_reacquire_refuses_what_is_not_a_palm():
    rig, rng = _rig(), np.random.default_rng(6)
    b = np.c_[rng.uniform([40, 40], [600, 440], (7, 2)), np.full(7, 100.0), np.full(7, np.nan)]
    assert reacquire(b, rig, sigma_px=1.0, sigma_z=0.004) is None
    assert reacquire(b[:5], rig, sigma_px=1.0, sigma_z=0.004) is None  # fewer than six


def test_whole_hand_hidden_for_two_seconds_is_picked_up_again():
    """wrist-rom with every marker hidden from 4.75 s to 6.75 s while the wrist pronates by
    45°:
    predicted rows for 1 s, then empty rows, then the filter re-initialised from the blobs on
    the first frame they are back and tracking the truth again."""
    hide = tuple((k, 4.75, 2.0) for k in range(6))
    sim = simulate_palm(PalmSimSettings(task="wrist-rom", seed=3, duration_s=10.0, hide=hide))
    tr, cam, rng = sim.truth, sim.camera, np.random.default_rng(2)
    blobs = []
    for k in range(tr["frame_t"].size):
        v = tr["frame_marker_visible"][k]
        px = np.vstack([tr["frame_marker_px"][k][v] + rng.normal(0, 0.3, (v.sum(), 2)),
                        tr["clutter_px"][None]])
        X = tr["frame_markers_W"][k][v] @ cam.R_WC.T + cam.T_WC
        b = np.c_[px, np.full(len(px), 100.0), np.r_[X[:, 2] + rng.normal(0, 1e-3, v.sum()),
                                                       np.nan]]
        blobs.append(b[rng.permutation(len(b))])
    X0 = tr["frame_markers_W"][0] @ cam.R_WC.T + cam.T_WC
    init = initial_pose(tr["palm_H"], tr["frame_marker_px"][0], X0[:, 2], K=cam.K, dist=cam.dist)
    rig = Rig(cam.K, cam.dist, init.R_CW0, init.T_CW0, tr["palm_H"])
    s = PalmUkfSettings()
    res = track(tr["frame_t"], blobs, 0, rig, s, 640 * 480.0, 100.0)
    R_WW0 = cam.R_WC.T @ init.R_CW0
    table = trajectory_table(tr["frame_t"], res, R_WW0, cam.R_WC.T @ (init.T_CW0 - cam.T_WC),
                             "right", s.max_coast_s)
    t = table["t"].to_numpy()
    gap = (t >= 4.75) & (t < 6.75)
    back = np.flatnonzero(t >= 6.75)[0]
    assert (table["markers_used"][gap] == 0).all() and (table["predicted_only"][gap] == 1).all()
    late = gap & (t > t[gap][0] + s.max_coast_s)
    assert late.sum() > 20 and table.loc[late].iloc[:, 1:-2].isna().all().all()  # empty
    assert table["markers_used"][back] == 6  # re-initialised on the first frame back
    after = t >= 6.75
    ang = table[["flexion_deg", "deviation_deg", "pronation_deg"]].to_numpy()[after]
    moved = np.abs(tr["frame_angles_deg"][back] - tr["frame_angles_deg"][np.flatnonzero(gap)[0]])
    assert moved.max() > 20  # the wrist moved a lot while hidden
    assert np.sqrt(np.mean((ang - tr["frame_angles_deg"][after]) ** 2)) < 2.0
    wrist = table[["wrist_x", "wrist_y", "wrist_z"]].to_numpy()[after]
    assert np.sqrt(np.mean(np.sum((wrist - tr["frame_wrist"][after]) ** 2, axis=1))) < 0.005
    b, mob = blobs[back], res.marker_of_blob[back]  # the re-acquisition's labels
    for k in range(6):
        assert mob[np.argmin(np.linalg.norm(b[:, :2] - tr["frame_marker_px"][back, k], axis=1))] == k
    assert (mob >= 0).sum() == 6
