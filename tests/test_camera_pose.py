"""The camera pose's correction (fuse/camera_pose.py) against independent answers: the board's
corners against OpenCV's board, the pose Jacobians and the arm smoother's camera rows against
finite differences of the moved projection, the board's covariance against the spread of
OpenCV's own PnP solutions on noisy corners."""

from __future__ import annotations

import cv2
import numpy as np

from armtrack_cli.core import quaternion as quat
from armtrack_cli.core.streams import CameraModel
from armtrack_cli.fuse import arm_smoother, arm_state, camera_pose, models
from armtrack_cli.vision.charuco import B_TO_W, make_board


def _camera() -> models.Projection:
    """A camera 0.9 m from the board, looking down at about 65°, with lens distortion."""
    K = np.array([[560.0, 0, 322.7], [0, 560.0, 237.4], [0, 0, 1]])
    R = np.array([[1.0, 0, 0], [0, -0.906, -0.423], [0, 0.423, -0.906]])
    R = np.linalg.svd(R)[0] @ np.linalg.svd(R)[2]  # orthonormal
    return models.Projection(CameraModel(K, np.array([-0.12, 0.03, 0.001, -0.001, 0.0]), 640,
                                         480, R, np.array([-0.14, 0.12, 0.85])))


def test_board_corners_are_opencvs_in_w():
    board = make_board((7, 5), 0.04, 0.03, "DICT_4X4_50")
    ours = camera_pose.board_corners_W((7, 5), 0.04)
    theirs = board.getChessboardCorners().astype(float) @ B_TO_W.T
    assert ours.shape == (24, 3)
    assert np.allclose(np.sort(ours, axis=0), np.sort(theirs, axis=0), atol=1e-12)


def test_pose_jacobians_match_finite_differences_of_the_moved_projection():
    proj = _camera()
    p = np.array([[0.1, 0.2, 0.1], [0.3, 0.4, 0.25], [0.0, 0.1, 0.0]])
    J = camera_pose.pose_jacobians(proj, p)
    for j in range(camera_pose.POSE):
        dc = np.zeros(camera_pose.POSE)
        dc[j] = 1e-7
        num = (camera_pose.moved(proj, dc)(p) - camera_pose.moved(proj, -dc)(p)) / 2e-7
        assert np.allclose(num, J[:, :, j], rtol=1e-5, atol=1e-3)


def test_board_covariance_is_the_spread_of_opencvs_pose_on_noisy_corners():
    proj = _camera()
    corners = camera_pose.board_corners_W((7, 5), 0.04)
    sigma = 0.3
    cov = camera_pose.board_covariance(proj, corners, sigma)
    cam = proj.cam
    rng = np.random.default_rng(0)
    obj = corners @ B_TO_W.T  # the board's own frame, where OpenCV solves
    R_bC = cam.R_WC @ B_TO_W
    clean = proj(corners)
    draws = []
    for _ in range(300):
        px = clean + sigma * rng.standard_normal(clean.shape)
        ok, rvec, tvec = cv2.solvePnP(obj, px, cam.K, cam.dist, cv2.Rodrigues(R_bC)[0],
                                      cam.T_WC.reshape(3, 1).copy(),  # OpenCV writes in it
                                      useExtrinsicGuess=True, flags=cv2.SOLVEPNP_ITERATIVE)
        assert ok
        R = cv2.Rodrigues(rvec)[0] @ B_TO_W  # R_WC solved
        rot = R @ cam.R_WC.T  # exp([φ]×)
        phi = cv2.Rodrigues(rot)[0].ravel()
        draws.append(np.r_[phi, tvec.ravel() - rot @ cam.T_WC])
    emp = np.cov(np.array(draws).T)
    sd, sd_emp = np.sqrt(np.diag(cov)), np.sqrt(np.diag(emp))
    assert np.all(np.abs(sd_emp / sd - 1) < 0.15)  # 300 draws: an SD's SE is ~4 %
    corr, corr_emp = cov / np.outer(sd, sd), emp / np.outer(sd_emp, sd_emp)
    assert np.abs(corr - corr_emp).max() < 0.1


def test_camera_rows_with_the_pose_correction_match_finite_differences():
    rng = np.random.default_rng(5)
    proj = _camera()
    arm = models.Arm(shoulder=np.array([0.15, 0.6, 0.33]), L1=0.3, L2=0.26,
                     forearm_B=np.array([0.0, 1.0, 0.0]))
    n, d = 4, 15 + camera_pose.POSE + arm_state.DRIFT  # (p, v, δθ, b_a, b_g, c, ℓ, S)
    cs = arm_state.camera_slice(d, True)
    X = np.zeros((n, d))
    X[:, :3] = [0.15, 0.3, 0.15] + 0.03 * rng.standard_normal((n, 3))
    X[:, cs] = np.r_[np.deg2rad([0.4, -0.3, 0.1]), [0.005, -0.004, 0.002]]  # static
    X[:, arm_state.shoulder_slice(d)] = arm.shoulder
    q = quat.normalize(rng.standard_normal((n, 4)))
    z = proj(X[:, :3]) + 1.0
    Hc, zc, _, _ = arm_smoother.linearise(X, z, q, proj, arm, None, camera=True)

    def pixels(Y):
        return np.stack([camera_pose.moved(proj, Y[k, cs])(Y[k, :3]) for k in range(n)])

    assert np.abs(zc - (z - pixels(X) + np.einsum("kij,kj->ki", Hc, X))).max() < 1e-9
    for j in [*range(3), *range(cs.start, cs.stop)]:
        dX = np.zeros_like(X)
        dX[:, j] = 1e-7
        num = (pixels(X + dX) - pixels(X - dX)) / 2e-7
        assert np.allclose(num, Hc[:, :, j], rtol=1e-5, atol=1e-3)
    other = np.setdiff1d(np.arange(d), [*range(3), *range(cs.start, cs.stop)])
    assert not Hc[:, :, other].any()
