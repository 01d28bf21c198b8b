"""The shared models: projection (vs OpenCV), its Jacobian, the composite IMU steps, and the
start on the arm sphere."""

from __future__ import annotations

import cv2
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from armtrack_cli.core import quaternion as Q
from armtrack_cli.core.streams import CameraModel
from armtrack_cli.fuse import models
from armtrack_cli.simulate import kinematics
from armtrack_cli.simulate.camera import default_camera

CAM = default_camera()
PROJ = models.Projection(CamModel := CameraModel(CAM.K, np.array([-0.12, 0.03, 0.001, -0.0008, 0.01]),
                                                 640, 480, CAM.R_WC, CAM.T_WC))
coord = st.floats(-0.3, 0.6)


@settings(max_examples=200)
@given(coord, coord, st.floats(-0.05, 0.3))
def test_projection_is_opencvs(x, y, z):
    P = np.array([x, y, z])
    ref = cv2.projectPoints(P[None], cv2.Rodrigues(CamModel.R_WC)[0], CamModel.T_WC, CamModel.K,
                            CamModel.dist)[0].reshape(2)
    np.testing.assert_allclose(PROJ(P), ref, atol=1e-8)


@settings(max_examples=100)
@given(coord, coord, st.floats(-0.05, 0.3))
def test_jacobian_matches_central_differences(x, y, z):
    P = np.array([x, y, z])
    h = 1e-6
    num = np.stack([(PROJ(P + h * e) - PROJ(P - h * e)) / (2 * h) for e in np.eye(3)], -1)
    np.testing.assert_allclose(PROJ.jacobian(P), num, rtol=1e-5, atol=1e-3)


def test_composite_steps_equal_sequential_integration():
    """Folding the IMU samples between frames into one step gives what integrating every held
    acceleration in turn gives (to 1e-12), including dropped samples and uneven frames."""
    rng = np.random.default_rng(0)
    t_imu = np.sort(rng.uniform(0, 2, 150))
    a = rng.normal(0, 1, (150, 3))
    t_f = np.r_[0.05, np.sort(rng.uniform(0.06, 1.9, 40))]
    steps = models.composite_steps(t_imu, a, t_f, accel_noise=0.5, imu_period=0.01)
    x = np.r_[0.1, 0.2, 0.3, 0.01, -0.02, 0.03]
    seq = x.copy()
    for k in range(1, t_f.size):
        x = steps.apply(k, x)
        grid = np.union1d(t_imu[(t_imu > t_f[k - 1]) & (t_imu < t_f[k])], [t_f[k - 1], t_f[k]])
        for s0, s1 in zip(grid[:-1], grid[1:]):
            j = np.searchsorted(t_imu, s0, side="right") - 1
            acc = a[j] if j >= 0 else np.zeros(3)
            tau = s1 - s0
            seq[:3] += seq[3:] * tau + 0.5 * acc * tau**2
            seq[3:] += acc * tau
        np.testing.assert_allclose(x, seq, atol=1e-12)
    Qk = steps.Q(5)
    d = steps.dt[5]
    np.testing.assert_allclose(Qk[0, 0], 0.25 * 0.01 * d**3 / 3)
    assert np.all(np.linalg.eigvalsh(Qk) > 0)


def test_start_picks_the_intersection_near_the_table():
    """From the first detection's ray and the arm model alone (no truth) the start lands on
    the true wrist; the other intersection of the ray with the arm sphere is far away."""
    arm_geo = kinematics.ArmGeometry(np.array([0.12, 0.58, 0.30]), 0.31, 0.27)
    for name in kinematics.TASKS:
        task = kinematics.Task(name, 12.0, np.array([0.26, 0.25, 0.07]), 0.1)
        s = kinematics.arm_state(arm_geo, task, np.array([0.0]))
        arm = models.Arm(shoulder=arm_geo.shoulder, L1=0.31, L2=0.27,
                         forearm_B=np.array([0.0, 1.0, 0.0]))
        uv = PROJ(s.wrist[0])
        p, how = models.initial_wrist(PROJ, uv, arm=arm, q_WB=s.q_WB[0], plane_height_m=0.07)
        assert np.linalg.norm(p - s.wrist[0]) < 1e-6, (name, p, s.wrist[0])
        centre = arm.shoulder + arm.L2 * Q.rotate(s.q_WB[0], arm.forearm_B)
        d = PROJ.ray(uv)
        oc = PROJ.eye - centre
        b = d @ oc
        roots = [PROJ.eye + (-b + sg * np.sqrt(b * b - (oc @ oc - arm.L1**2))) * d for sg in (-1, 1)]
        other = max(roots, key=lambda r: np.linalg.norm(r - s.wrist[0]))
        assert 0.05 < np.linalg.norm(other - s.wrist[0]) < 0.6  # a real, distant ambiguity


def test_ray_sphere_closed_forms():
    """models.ray_sphere against geometry done by hand: a ray through the centre meets the
    sphere at |o − c| ∓ r; a tangent ray touches it once (near = far = the foot of the
    perpendicular, miss 0); a ray passing at distance h > r misses it by h − r, near = far =
    the ray's nearest point; one call handles all three at once (vectorised over rays)."""
    o = np.array([0.1, -0.2, 0.9])
    c = np.array([0.4, 0.2, 0.0])
    r = 0.3
    L = float(np.linalg.norm(c - o))
    u = (c - o) / L
    perp = np.cross(u, [0.0, 0.0, 1.0])
    perp /= np.linalg.norm(perp)
    # the tangent ray from o touches the sphere at angle asin(r / L) off the axis
    a = np.arcsin(r / L)
    tangent = np.cos(a) * u + np.sin(a) * perp
    h = 0.5  # a ray whose line passes h from the centre: the axis tilted by asin(h / L)
    b = np.arcsin(h / L)
    missing = np.cos(b) * u - np.sin(b) * perp
    d = np.stack([u, tangent, missing])
    near, far, miss = models.ray_sphere(o, d, np.tile(c, (3, 1)), r)
    np.testing.assert_allclose([near[0], far[0], miss[0]], [L - r, L + r, 0.0], atol=1e-12)
    t = np.sqrt(L**2 - r**2)  # tangent length
    np.testing.assert_allclose([near[1], far[1], miss[1]], [t, t, 0.0], atol=1e-6)
    foot = L * np.cos(b)
    np.testing.assert_allclose([near[2], far[2], miss[2]], [foot, foot, h - r], atol=1e-12)
    # one ray against several spheres, and the scalar case, broadcast alike
    n1, f1, m1 = models.ray_sphere(o, u, c, r)
    assert np.shape(n1) == () and abs(n1 - (L - r)) < 1e-12 and m1 == 0.0


def test_rays_pass_through_their_pixels():
    """Projection.rays: a point at any depth along the ray of pixel z projects back to z."""
    uv = np.array([[100.0, 80.0], [320.0, 240.0], [600.0, 420.0]])
    d = PROJ.rays(uv)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-12)
    for depth in (0.3, 1.0):
        np.testing.assert_allclose(PROJ(PROJ.eye + depth * d), uv, atol=1e-6)
    np.testing.assert_allclose(PROJ.ray(uv[1]), d[1], atol=1e-15)
