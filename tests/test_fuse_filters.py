"""The fuse loops against references written here: run_gaussian and rts_smooth against a
textbook Kalman filter / RTS smoother on a linear-Gaussian model, run_particles against the
same KF within Monte-Carlo error; the compiled kernels against the numpy reference (1e-12,
same random draws); one EKF and UKF step against FilterPy 2.0 from the same prior (1e-12)."""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.core.streams import CameraModel
from armtrack_cli.filters import gaussian
from armtrack_cli.fuse.methods import Inputs, run_gaussian, run_particles, smooth
from armtrack_cli.fuse.models import Arm, Projection, Steps
from armtrack_cli.fuse.settings import FuseSettings
from tests.test_filters import kalman_step


class LinearCamera:
    """A linear 'projection' u = f x + cx, v = f y + cy: makes the arm model linear-Gaussian
    (for the numpy loops, which only call the projection and its Jacobian)."""

    f, c = 800.0, np.zeros(2)

    def __call__(self, p: np.ndarray) -> np.ndarray:
        return self.f * p[..., :2] + self.c

    def jacobian(self, p: np.ndarray) -> np.ndarray:
        return np.array([[self.f, 0.0, 0.0], [0.0, self.f, 0.0]])


H_LIN = np.c_[np.array([[800.0, 0, 0], [0, 800.0, 0]]), np.zeros((2, 3))]


def _problem(n_frames=40, seed=0, missing=(5, 6, 17)):
    """Random steps (Δ ≈ 1/30 s, IMU increments dp, dv) and detections simulated from the
    linear model with σ = 4 px; frames in ``missing`` have no detection."""
    rng = np.random.default_rng(seed)
    dt = np.r_[0.0, rng.uniform(0.03, 0.037, n_frames - 1)]
    steps = Steps(dt, rng.normal(0, 1e-3, (n_frames, 3)), rng.normal(0, 1e-2, (n_frames, 3)),
                  0.05)
    steps.dp[0] = steps.dv[0] = 0.0
    F, b, Q = steps.stacked()
    x = np.r_[0.3, 0.2, 0.4, 0.0, 0.1, 0.0]
    z = np.empty((n_frames, 2))
    for k in range(n_frames):
        if k:
            x = F[k] @ x + b[k] + rng.multivariate_normal(np.zeros(6), Q[k])
        z[k] = H_LIN @ x + rng.normal(0, 4.0, 2)
    z[list(missing)] = np.nan
    q = np.tile([1.0, 0, 0, 0], (n_frames, 1))
    x0 = np.r_[0.3, 0.2, 0.4, 0.0, 0.1, 0.0]
    P0 = np.diag([0.03**2] * 3 + [0.05**2] * 3)
    return Inputs(steps, z, q), x0, P0, (F, b, Q)


def _textbook(inp, x0, P0, FbQ, R):
    F, b, Q = FbQ
    x, P = x0, P0
    xs, Ps = [], []
    for k in range(inp.z.shape[0]):
        z = None if np.isnan(inp.z[k]).any() else inp.z[k]
        if k == 0:  # no prediction into the first frame
            x, P = kalman_step(x, P, z, np.eye(6), np.zeros(6), np.zeros((6, 6)), H_LIN, R)
        else:
            x, P = kalman_step(x, P, z, F[k], b[k], Q[k], H_LIN, R)
        xs.append(x)
        Ps.append(P)
    return np.array(xs), np.array(Ps)


@pytest.mark.parametrize("method", ["ekf", "ukf"])
def test_run_gaussian_is_the_kalman_filter_on_a_linear_model(method):
    inp, x0, P0, FbQ = _problem()
    s = FuseSettings(method=method, pixel_sigma=4.0)
    est = run_gaussian(inp, x0, P0, LinearCamera(), s, method, compiled=False)
    x_ref, P_ref = _textbook(inp, x0, P0, FbQ, 16.0 * np.eye(2))
    np.testing.assert_allclose(est.mean, x_ref, rtol=0, atol=1e-10)
    np.testing.assert_allclose(est.cov, P_ref, rtol=0, atol=1e-12)


@pytest.mark.parametrize("block", [7, 4096])
def test_rts_smooth_is_the_textbook_smoother(block):
    """RTS written here step by step with explicit inverses (Rauch, Tung & Striebel 1965);
    the gains computed in blocks of 7 steps or all at once."""
    inp, x0, P0, (F, b, Q) = _problem(n_frames=60)
    x, P = _textbook(inp, x0, P0, (F, b, Q), 16.0 * np.eye(2))
    xs, Ps = gaussian.rts_smooth(x, P, F, b, Q, block=block)
    x_ref, P_ref = x.copy(), P.copy()
    for k in range(x.shape[0] - 2, -1, -1):
        Pp = F[k + 1] @ P[k] @ F[k + 1].T + Q[k + 1]
        C = P[k] @ F[k + 1].T @ np.linalg.inv(Pp)
        x_ref[k] = x[k] + C @ (x_ref[k + 1] - (F[k + 1] @ x[k] + b[k + 1]))
        P_ref[k] = P[k] + C @ (P_ref[k + 1] - Pp) @ C.T
    np.testing.assert_allclose(xs, x_ref, rtol=0, atol=1e-10)
    np.testing.assert_allclose(Ps, P_ref, rtol=0, atol=1e-12)
    xm, none = gaussian.rts_smooth(x, P, F, b, Q, block=block, means_only=True)
    assert none is None and np.array_equal(xm, xs)  # the means need no smoothed covariance
    x_in = x.copy()  # written over in place: the same numbers, no second array
    xi, _ = gaussian.rts_smooth(x_in, P, F, b, Q, block=block, means_only=True, in_place=True)
    assert xi is x_in and np.array_equal(xi, xs)


def test_smooth_uses_the_steps_of_every_frame():
    inp, x0, P0, FbQ = _problem()
    s = FuseSettings(method="ekf")
    est = run_gaussian(inp, x0, P0, LinearCamera(), s, "ekf", compiled=False)
    x, P = gaussian.rts_smooth(est.mean, est.cov + 1e-12 * np.eye(6), FbQ[0], FbQ[1],
                               FbQ[2] + 1e-12 * np.eye(6))
    out = smooth(est, inp, s, "ekf")
    np.testing.assert_array_equal(out.mean, x)
    np.testing.assert_array_equal(out.cov, P)


def test_steps_stacked_are_the_per_frame_steps():
    inp, *_ = _problem()
    F, b, Q = inp.steps.stacked()
    for k in range(F.shape[0]):
        np.testing.assert_array_equal(F[k], inp.steps.F(k))
        np.testing.assert_array_equal(b[k], inp.steps.b(k))
        np.testing.assert_array_equal(Q[k], inp.steps.Q(k))


def test_smoothing_one_block_of_steps_at_a_time_is_smoothing_with_them_all():
    """rts_smooth fed F, b, Q a block at a time (Steps.stacked(lo, hi), as smooth() does to
    keep memory flat) gives what it gives with the whole arrays."""
    inp, x0, P0, FbQ = _problem(n_frames=60)
    x, P = _textbook(inp, x0, P0, FbQ, 16.0 * np.eye(2))
    whole = gaussian.rts_smooth(x, P, *inp.steps.stacked(), block=7)
    blocks = gaussian.rts_smooth(x, P, steps=inp.steps.stacked, block=7)
    for u, v in zip(whole, blocks):
        np.testing.assert_array_equal(u, v)


def test_run_particles_matches_the_kalman_filter():
    """Bootstrap PF (numpy reference), 80,000 particles, resampled every frame: its mean is
    within 0.3 of the KF's standard deviation of the KF mean, its spread within 15 %. (The
    bound is on the worst of 25 frames × 6 components; the worst is usually the unobserved
    height, whose Monte-Carlo error grows with every resampling: over seeds 0-5 of the
    splitmix stream the worst is 0.11-0.25 σ and the spread's worst 8-12 %.)"""
    inp, x0, P0, FbQ = _problem(n_frames=25)
    s = FuseSettings(method="pf", particles=80000, seed=3)
    est = run_particles(inp, x0, P0, LinearCamera(), s, None, constrained=False,
                        compiled=False)
    x_ref, P_ref = _textbook(inp, x0, P0, FbQ, 16.0 * np.eye(2))
    sd = np.sqrt(np.diagonal(P_ref, axis1=1, axis2=2))
    assert np.all(np.abs(est.mean - x_ref) < 0.3 * sd), np.max(np.abs(est.mean - x_ref) / sd)
    np.testing.assert_allclose(est.sd, sd, rtol=0.15)


# ------------------------------------------------------ compiled kernels = numpy reference

def _camera_problem(n_frames=30):
    """The same steps seen by a real pinhole camera with distortion, 1.2 m away."""
    inp, x0, P0, _ = _problem(n_frames)
    K = np.array([[600.0, 0, 320], [0, 610.0, 240], [0, 0, 1]])
    R = np.array([[1.0, 0, 0], [0, -1.0, 0], [0, 0, -1.0]])  # looking down at the table
    cam = CameraModel(K, np.array([0.1, -0.05, 0.001, -0.002, 0.01]), 640, 480, R,
                      np.array([-0.3, 0.2, 1.6]))
    proj = Projection(cam)
    rng = np.random.default_rng(1)
    z = proj(x0[:3] + rng.normal(0, 0.01, (n_frames, 3))) + rng.normal(0, 4, (n_frames, 2))
    z[[4, 5, 11]] = np.nan
    arm = Arm(shoulder=np.r_[0.1, 0.45, 0.32], L1=0.31, L2=0.27,
              forearm_B=np.r_[0.0, 1.0, 0.0])
    return Inputs(inp.steps, z, inp.q_WB), x0, P0, proj, arm


@pytest.mark.parametrize("method", ["inertial", "ekf", "ukf"])
def test_gaussian_kernel_equals_the_numpy_reference(method):
    inp, x0, P0, proj, _ = _camera_problem()
    s = FuseSettings(method=method)
    a = run_gaussian(inp, x0, P0, proj, s, method, compiled=True)
    b = run_gaussian(inp, x0, P0, proj, s, method, compiled=False)
    for u, v in ((a.mean, b.mean), (a.cov, b.cov)):  # 1e-12 of the largest entry
        np.testing.assert_allclose(u, v, rtol=0, atol=1e-12 * np.abs(v).max())


@pytest.mark.parametrize("scheme", ["residual", "systematic", "stratified", "multinomial"])
@pytest.mark.parametrize("constrained", [True, False])
def test_particle_kernel_equals_the_numpy_reference(scheme, constrained):
    """Same seed, so the same draws: the kernel and numpy agree to 1e-12 (relative)."""
    inp, x0, P0, proj, arm = _camera_problem()
    s = FuseSettings(particles=300, resampling=scheme, seed=5,
                     pf_resample_ess=1.0 if constrained else 0.6)
    a = run_particles(inp, x0, P0, proj, s, arm, constrained=constrained, compiled=True)
    b = run_particles(inp, x0, P0, proj, s, arm, constrained=constrained, compiled=False)
    for u, v in ((a.mean, b.mean), (a.cov, b.cov), (a.ess, b.ess)):
        np.testing.assert_allclose(u, v, rtol=0, atol=1e-12 * np.abs(v).max())


@pytest.mark.parametrize("constrained", [True, False])
def test_packed_covariances_are_the_upper_triangles_to_the_bit(constrained):
    """The kernel's covariances kept as their upper triangles (packed, the arm smoother's
    first pass) are the whole ones' numbers, and the means the same; unpacked, the whole."""
    inp, x0, P0, proj, arm = _camera_problem()
    s = FuseSettings(particles=300, seed=5, pf_resample_ess=1.0 if constrained else 0.6)
    a = run_particles(inp, x0, P0, proj, s, arm, constrained=constrained, packed=True)
    b = run_particles(inp, x0, P0, proj, s, arm, constrained=constrained)
    iu = np.triu_indices(6)
    assert a.cov.shape == (inp.z.shape[0], 21) and b.cov.shape == (inp.z.shape[0], 6, 6)
    np.testing.assert_array_equal(a.cov, b.cov[:, iu[0], iu[1]])
    np.testing.assert_array_equal(gaussian.unpacked(a.cov, 6), b.cov)
    for u, v in ((a.mean, b.mean), (a.ess, b.ess), (a.codes, b.codes)):
        np.testing.assert_array_equal(u, v)


def test_smoothed_means_from_packed_covariances_are_the_same():
    """rts_smooth's means-only pass from the upper triangles: the numbers it gives from the
    whole covariances, bit for bit (in place and not), a block at a time or not."""
    inp, x0, P0, FbQ = _problem(n_frames=60)
    x, P = _textbook(inp, x0, P0, FbQ, 16.0 * np.eye(2))
    P = 0.5 * (P + np.swapaxes(P, 1, 2))  # symmetric to the bit, as the kernels' are
    iu = np.triu_indices(6)
    tri = P[:, iu[0], iu[1]]
    for block in (7, 4096):
        whole, _ = gaussian.rts_smooth(x, P, steps=inp.steps.stacked, block=block,
                                       means_only=True, P_add=1e-12 * np.eye(6))
        packed, none = gaussian.rts_smooth(x.copy(), tri, steps=inp.steps.stacked,
                                           block=block, means_only=True,
                                           P_add=1e-12 * np.eye(6), in_place=True)
        assert none is None
        np.testing.assert_array_equal(packed, whole)
    with pytest.raises(ValueError):
        gaussian.rts_smooth(x, tri, steps=inp.steps.stacked)


# ------------------------------------------------------------------------ FilterPy 2.0

def test_one_step_equals_filterpy():
    """One predict + update from the same prior, on the arm model, to 1e-12: the EKF and the
    UKF (FilterPy's sigma points redrawn from (x⁻, P⁻) before the update, the standard UKF)."""
    fp = pytest.importorskip("filterpy.kalman")
    inp, x0, P0, proj, _ = _camera_problem()
    R = 16.0 * np.eye(2)
    k, z = 3, inp.z[3]
    hx = lambda x: proj(x[:3])  # noqa: E731
    Hj = lambda x: np.hstack([proj.jacobian(x[:3]), np.zeros((2, 3))])  # noqa: E731
    ekf = fp.ExtendedKalmanFilter(6, 2)
    ekf.x, ekf.P, ekf.R, ekf.F, ekf.Q, ekf.B = x0.copy(), P0.copy(), R, inp.steps.F(k), \
        inp.steps.Q(k), np.eye(6)
    ekf.predict(u=inp.steps.b(k))
    ekf.update(z, Hj, hx)
    ours = gaussian.ekf_update(gaussian.kf_predict(gaussian.Gaussian(x0, P0), inp.steps.F(k),
                                                   inp.steps.Q(k), inp.steps.b(k)), z, hx, Hj, R)
    np.testing.assert_allclose(ours.x, ekf.x, rtol=1e-12)
    np.testing.assert_allclose(ours.P, ekf.P, rtol=0, atol=1e-12 * np.abs(ekf.P).max())
    pts = fp.MerweScaledSigmaPoints(6, alpha=0.5, beta=2.0, kappa=0.0)
    ukf = fp.UnscentedKalmanFilter(6, 2, dt=1.0, hx=hx, fx=lambda x, dt: x, points=pts)
    ukf.x, ukf.P, ukf.R, ukf.Q = x0.copy(), P0.copy(), R, inp.steps.Q(k)
    ukf.predict(fx=lambda x, dt: inp.steps.apply(k, x))
    ukf.sigmas_f = pts.sigma_points(ukf.x, ukf.P)
    ukf.update(z)
    sp = gaussian.SigmaPoints(6, alpha=0.5, beta=2.0, kappa=0.0)
    ours = gaussian.ukf_update(gaussian.ukf_predict(gaussian.Gaussian(x0, P0),
                                                    lambda X: inp.steps.apply(k, X),
                                                    inp.steps.Q(k), sp),
                               z, lambda X: proj(X[:, :3]), R, sp)
    np.testing.assert_allclose(ours.x, ukf.x, rtol=1e-12)
    np.testing.assert_allclose(ours.P, ukf.P, rtol=0, atol=1e-12 * np.abs(ukf.P).max())



@pytest.mark.parametrize("method", ["inertial", "ekf", "ukf", "pf", "pf-constraint",
                                    "arm-smoother"])
def test_kernels_load_before_a_timed_run(method):
    from armtrack_cli.fuse.kernel_setup import load_kernels

    load_kernels(method)  # runs on a two-frame problem without error
