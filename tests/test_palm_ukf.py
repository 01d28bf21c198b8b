"""ukf-palm (Cordella et al.): the manifold UKF against the Kalman filter and SO(3), the
Gauss-Newton initialisation, association, the wrist-angle convention, and one short simulated
session end to end against its truth."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from armtrack_cli.compare.palm import association_score
from armtrack_cli.core import quaternion as Q
from armtrack_cli.core.wrist import hand_frame, wrist_angles_deg
from armtrack_cli.filters import gaussian as G
from armtrack_cli.filters import manifold_ukf as mu
from armtrack_cli.fuse.association import associate
from armtrack_cli.fuse.palm_init import initial_pose
from armtrack_cli.fuse.palm_models import PalmUkfSettings, Rig, distort_project
from armtrack_cli.fuse.palm_run import track, trajectory_table
from armtrack_cli.simulate import hand
from armtrack_cli.simulate.palm_session import PalmSimSettings, simulate_palm

from .conftest import run_cli


def test_augmented_manifold_ukf_equals_the_kalman_filter_on_a_linear_model():
    """x⁺ = F x + G w (noise in the augmented state), z = H x; the attitude is carried along
    untouched. Every sigma-point sum is then exact: the UKF must be the KF to round-off."""
    rng = np.random.default_rng(0)
    dt = 0.05
    F = np.array([[1, dt, 0, 0], [0, 1, 0, 0], [0, 0, 1, dt], [0, 0, 0, 1.0]])
    Gm = np.array([[dt**2 / 2, 0], [dt, 0], [0, dt**2 / 2], [0, dt]])
    Qw = np.diag([0.3, 0.7])
    H = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0], [0.5, 0.2, -0.3, 0.1]])
    Rm = np.diag([0.01, 0.02, 0.05])
    Pphi = np.diag([0.01, 0.02, 0.03])
    A = rng.normal(size=(4, 4))
    Px = A @ A.T * 0.1 + np.eye(4) * 0.01
    ukf = mu.ManifoldState(np.eye(3), rng.normal(size=4), np.block(
        [[Pphi, np.zeros((3, 4))], [np.zeros((4, 3)), Px]]))
    kf = G.Gaussian(np.r_[np.zeros(3), ukf.x], ukf.P.copy())
    Ff = np.block([[np.eye(3), np.zeros((3, 4))], [np.zeros((4, 3)), F]])
    Qf = np.zeros((7, 7))
    Qf[3:, 3:] = Gm @ Qw @ Gm.T
    Hf = np.hstack([np.zeros((3, 3)), H])
    sp = G.SigmaPoints(9, alpha=0.5, beta=2.0, kappa=0.0)  # negative centre weight on purpose
    f = lambda R, x, w: (R, x @ F.T + w @ Gm.T)  # noqa: E731
    h = lambda R, x: x @ H.T  # noqa: E731
    for k in range(30):
        z = rng.normal(size=3)
        pr = mu.predict(ukf, f, Qw, sp)
        ukf = mu.update(pr, None if k % 7 == 3 else z, h, Rm)
        kf = G.kf_predict(kf, Ff, Qf)
        kf = G.kf_update(kf, None if k % 7 == 3 else z, Hf, Rm)
        assert np.abs(ukf.x - kf.x[3:]).max() < 1e-10
        assert np.abs(ukf.P - kf.P).max() < 1e-10
    assert np.abs(ukf.R - np.eye(3)).max() < 1e-14


def test_manifold_attitude_stays_a_rotation_over_10000_steps():
    """Random-walk angular velocity, two body axes observed; the attitude must remain
    orthonormal to 1e-12 (no re-normalisation anywhere) and follow the truth."""
    rng = np.random.default_rng(1)
    dt, q = 0.01, 4.0
    sp = G.SigmaPoints(9, alpha=1.0)
    Qw = np.eye(3) * q / dt

    def f(R, x, w):
        return R @ mu.exp_so3(x * dt + 0.5 * w * dt * dt), x + w * dt

    def h(R, x):
        return np.concatenate([R[:, :, 0], R[:, :, 1]], axis=1)

    s = mu.ManifoldState(np.eye(3), np.zeros(3), np.diag([0.01] * 3 + [1.0] * 3))
    R_true, w_true = np.eye(3), np.zeros(3)
    worst, err = 0.0, []
    for _ in range(10_000):
        a = rng.normal(0, np.sqrt(q / dt), 3)
        R_true, w_true = R_true @ mu.exp_so3(w_true * dt + 0.5 * a * dt * dt), w_true + a * dt
        z = np.r_[R_true[:, 0], R_true[:, 1]] + rng.normal(0, 0.01, 6)
        s = mu.update(mu.predict(s, f, Qw, sp), z, h, np.eye(6) * 1e-4)
        worst = max(worst, np.abs(s.R.T @ s.R - np.eye(3)).max())
        err.append(np.linalg.norm(mu.log_so3(s.R.T @ R_true)))
    assert worst < 1e-12 and abs(np.linalg.det(s.R) - 1) < 1e-12
    assert np.degrees(np.sqrt(np.mean(np.square(err[100:])))) < 1.0


def _camera():
    K = np.array([[580.0, 0, 322.7], [0, 580.0, 237.4], [0, 0, 1]])
    return K, np.array([-0.08, 0.02, 0.001, -0.0005, 0.0])


def test_projection_is_opencvs():
    import cv2

    K, dist = _camera()
    X = np.random.default_rng(2).uniform([-0.2, -0.15, 0.5], [0.2, 0.15, 0.8], (50, 3))
    ref = cv2.projectPoints(X, np.zeros(3), np.zeros(3), K, dist)[0].reshape(-1, 2)
    assert np.abs(distort_project(K, dist, X) - ref).max() < 1e-9


@pytest.mark.parametrize("with_depth", [True, False])
def test_gauss_newton_initialisation_recovers_a_known_pose(with_depth):
    """Synthetic projections (OpenCV's) and depths of the palm model at a known pose;
    the iterated Gauss-Newton fit (eq. 13-20) from a pose 8° and 3 cm off recovers it."""
    import cv2

    K, dist = _camera()
    H = hand.palm_model()
    R = Q.to_matrix(Q.from_axis_angle(np.array([0.3, -0.5, 0.81]) / 1.0, 2.6))
    R = np.linalg.svd(R)[0] @ np.linalg.svd(R)[2]
    T = np.array([0.03, -0.02, 0.64])
    y = cv2.projectPoints(H, cv2.Rodrigues(R)[0], T, K, dist)[0].reshape(-1, 2)
    z = (H @ R.T + T)[:, 2] if with_depth else None
    start = (mu.exp_so3(np.radians([5.0, -4.0, 4.0])) @ R, T + [0.02, -0.01, 0.02])
    fit = initial_pose(H, y, z, K=K, dist=dist, start=start)
    assert np.abs(fit.R_CW0 - R).max() < 1e-6 and np.abs(fit.T_CW0 - T).max() < 1e-6
    assert fit.rms_px < 1e-6 and fit.used_depth == with_depth
    auto = initial_pose(H, y, z, K=K, dist=dist)  # Kabsch on depths, or planar PnP
    assert np.abs(auto.R_CW0 - R).max() < 1e-6 and np.abs(auto.T_CW0 - T).max() < 1e-6


def test_association_clutter_uniqueness_and_merged_blobs():
    zm = np.array([[100.0, 100], [140, 100], [180, 100], [186, 103]])
    S = np.tile(np.eye(2) * 2.0, (4, 1, 1))
    kw = dict(prior_marker=0.9, prior_clutter=0.1, image_area=640 * 480.0, gate=16.0,
              merge_px=4.0)
    y = np.array([[140.5, 99.6], [400, 300], [100.4, 100.2], [183.2, 101.4], [139.0, 101.0]])
    a = associate(y, zm, S, np.ones(4, bool), **kw)
    # blob 0 and 4 both near marker 1: one of them only; blob 1 clutter; blob 3 lies
    # between markers 2 and 3 (merged): gated out
    assert a.marker_of_blob[1] == -1 and a.marker_of_blob[2] == 0 and a.marker_of_blob[3] == -1
    assert sorted(a.marker_of_blob[[0, 4]].tolist()) == [-1, 1]
    assert (np.bincount(a.marker_of_blob[a.marker_of_blob >= 0], minlength=4) <= 1).all()
    hidden = associate(y, zm, S, np.array([False, True, True, True]), **kw)
    assert hidden.marker_of_blob[2] == -1  # a marker turned away cannot be chosen


@pytest.mark.parametrize("side", ["right", "left"])
def test_wrist_angles_follow_the_contract(side):
    """R_FH = Rz(dev)·Ry(flex)·Rx(−pron) built with quaternions (simulate/hand.py); the left
    hand negates deviation and pronation."""
    a = np.radians(np.random.default_rng(3).uniform(-60, 60, (200, 3)))
    R = Q.to_matrix(hand.R_FH(a[:, 0], a[:, 1], a[:, 2], side))
    assert np.abs(wrist_angles_deg(R, side) - np.degrees(a)).max() < 1e-9
    assert np.abs(wrist_angles_deg(np.eye(3)[None], side)).max() == 0.0


def test_hand_frame_from_six_markers():
    R = Q.to_matrix(Q.from_axis_angle(np.array([0.6, 0.0, 0.8]), np.radians(70)))
    P = np.array([0.4, 0.1, 0.05]) + hand.palm_model() @ R.T
    w, R_WH = hand_frame(P[None], hand.MARKERS, "right")
    assert np.abs(R_WH[0] - R).max() < 1e-12 and np.abs(w[0] - P[0]).max() == 0


def _blobs_from_truth(truth, rng, *, drop_from=None):
    """Detections as the filter sees them: visible markers (0.3 px noise) and the clutter,
    shuffled; area 100 px² each; no blobs at all from frame ``drop_from`` on."""
    blobs = []
    for k in range(truth["frame_t"].size):
        v = truth["frame_marker_visible"][k]
        b = np.vstack([truth["frame_marker_px"][k][v] + rng.normal(0, 0.3, (v.sum(), 2)),
                       truth["clutter_px"][None]])
        b = np.c_[b, np.full(len(b), 100.0), np.full(len(b), np.nan)]
        blobs.append(np.zeros((0, 4)) if drop_from is not None and k >= drop_from else
                     b[rng.permutation(len(b))])
    return blobs


def test_losing_every_marker_coasts_then_leaves_rows_empty():
    sim = simulate_palm(PalmSimSettings(task="reach-grasp", seed=5, duration_s=6.0))
    tr, cam = sim.truth, sim.camera
    blobs = _blobs_from_truth(tr, np.random.default_rng(4), drop_from=120)
    X = tr["frame_markers_W"][0] @ cam.R_WC.T + cam.T_WC
    init = initial_pose(tr["palm_H"], tr["frame_marker_px"][0], X[:, 2], K=cam.K, dist=cam.dist)
    s = PalmUkfSettings()
    res = track(tr["frame_t"], blobs, 0, Rig(cam.K, cam.dist, init.R_CW0, init.T_CW0,
                                                tr["palm_H"]), s, 640 * 480.0, 100.0)
    table = trajectory_table(tr["frame_t"], res, cam.R_WC.T @ init.R_CW0,
                             cam.R_WC.T @ (init.T_CW0 - cam.T_WC), "right", s.max_coast_s)
    t = table["t"].to_numpy()
    lost = t >= t[120]
    assert (table["markers_used"][lost] == 0).all() and (table["markers_used"][:120] >= 5).all()
    coast = lost & (t - t[119] <= 1.0)
    assert (table["predicted_only"][lost] == 1).all()
    assert table.loc[coast, "wrist_x"].notna().all() and table.loc[lost & ~coast].iloc[:, 1:-2] \
        .isna().all().all()
    sd = table.loc[coast, "wrist_x_sd"].to_numpy()
    assert (np.diff(sd) > 0).all()  # the prediction's SD grows
    e = table[["flexion_deg", "deviation_deg", "pronation_deg"]].to_numpy()[:120] \
        - tr["frame_angles_deg"][:120]
    assert np.sqrt(np.mean(e**2)) < 2.0


@pytest.fixture(scope="module")
def palm_session(tmp_path_factory):
    """A short wrist-rom session with both clutter blobs and a hidden marker, run through
    every stage as a user would."""
    root = tmp_path_factory.mktemp("ukfpalm")
    folder = root / "rom"
    for args in (("simulate", folder, "--task", "wrist-rom", "--seed", "7", "--duration", "7",
                  "--hide", "2:2.5:1.0", "--clutter2", "3"), ("calibrate", folder),
                 ("detect", folder), ("fuse", folder, "--method", "ukf-palm")):
        r = run_cli(*args)
        assert r.exit_code == 0, r.stderr
    return folder, dict(np.load(root / "rom.truth.npz"))


def test_ukf_palm_end_to_end_against_truth(palm_session):
    folder, truth = palm_session
    r = run_cli("compare", folder)
    assert r.exit_code == 0, r.stderr
    out = folder / "armtrack"
    ang = pd.read_csv(out / "wrist-angle-errors.csv", comment="#").set_index("angle")
    assert (ang["rmse_deg"] <= 2.0).all(), ang
    pos = pd.read_csv(out / "errors.csv", comment="#").set_index("axis")
    assert pos.loc["3d", "rmse_cm"] <= 0.5
    traj = pd.read_csv(out / "trajectory-ukf-palm.csv", comment="#")
    for c in ("wrist_x", "qw", "flexion_deg", "deviation_deg", "pronation_deg", "wx",
              "wrist_vx", "wrist_x_sd", "flexion_deg_sd", "markers_used"):
        assert c in traj
    assert np.abs(traj[["flexion_deg", "deviation_deg", "pronation_deg"]][:30]).max().max() < 2
    det = pd.read_csv(out / "detections.csv", comment="#")
    asc = pd.read_csv(out / "associations-ukf-palm.csv", comment="#")
    names = list(hand.MARKERS)
    n = len(traj)
    blobs = [det[det.frame == k][["u", "v"]].to_numpy() for k in range(n)]
    mob = [np.array([names.index(m) if m in names else -1 for m in asc[asc.frame == k]
                     .sort_values("blob")["marker"]], int) for k in range(n)]
    a = association_score(blobs, mob, truth["frame_marker_px"], truth["frame_marker_visible"],
                          np.array([truth["clutter_px"], truth["clutter2_px"]]))
    assert a.accuracy >= 0.99 and a.clutter_used == 0 and a.wrong == 0, a
    kin = pd.read_csv(out / "kinematics-ukf-palm.csv", comment="#").set_index("measure")
    assert {"wrist_flexion_rom", "wrist_deviation_rom_p5_p95", "wrist_pronation_peak_speed",
            "wrist_flexion_mean_speed", "wrist_path_length", "wrist_peak_speed"} <= set(kin.index)
    meas = pd.read_csv(out / "measures.csv", comment="#")
    rom = meas[(meas.segment == "session") & meas.measure.str.match(r"wrist_(flexion|deviation)_rom$")]
    # this 7-s session moves 55° in a third of a second, three times faster than the 12-s
    # sessions of validation/palm.py, where the 2° goal is met; here the filter overshoots by
    # up to 3° at the fastest reversals
    assert len(rom) == 2 and (rom["error"].abs() <= 3.0).all(), rom
    assert "ukf-palm" in run_cli("info", folder, "--json").stdout


def test_fuse_ukf_palm_without_calibrate_is_one_line(tmp_path, palm_session):
    folder, _ = palm_session
    r = run_cli("fuse", folder, "--method", "ukf-palm", "--out", tmp_path)
    assert r.exit_code == 1
    assert r.stderr.startswith("error: ") and "camera.yaml" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_simulate_hide_needs_marker_start_duration(tmp_path):
    r = run_cli("simulate", tmp_path / "x", "--task", "wrist-rom", "--hide", "9:1:1")
    assert r.exit_code == 2 and "MARKER:START:DURATION" in r.stderr
