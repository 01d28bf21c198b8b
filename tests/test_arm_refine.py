"""fuse/arm_refine.py: the arm as static states of the arm smoother, its log-likelihood and the
quadratic search on it, each against an independent closed form."""

from __future__ import annotations

import numpy as np
from scipy.stats import multivariate_normal

from armtrack_cli.core import quaternion as quat
from armtrack_cli.fuse import arm_refine, arm_smoother
from tests.test_arm_smoother import _camera, _linear_problem


def test_log_likelihood_is_the_joint_density_of_all_measurements():
    """The forward pass's Σ log N(innovation) = log N(z; mean, cov) of the stacked measurement
    vector of the linear-Gaussian model, written out as one multivariate normal."""
    x0, P0, F, b, Q, Hc, zc, use_c, rc, Hk, zk, use_k, rk = _linear_problem(
        np.random.default_rng(7), n=8, d=5)
    n, d = F.shape[0], x0.size
    # the states' joint mean and covariance: x_k = F_k x_{k−1} + b_k + w_k
    A = np.zeros((n * d, n * d))  # x = A (x0 + w stacked) + A b stacked
    for k in range(n):
        for j in range(k + 1):
            Mj = np.eye(d)
            for i in range(k, j, -1):
                Mj = Mj @ F[i]
            A[k * d:(k + 1) * d, j * d:(j + 1) * d] = Mj
    src_mean = np.r_[x0, b[1:].ravel()]
    src_cov = np.zeros((n * d, n * d))
    src_cov[:d, :d] = P0
    for k in range(1, n):
        src_cov[k * d:(k + 1) * d, k * d:(k + 1) * d] = Q[k]
    mx, Px = A @ src_mean, A @ src_cov @ A.T
    rows, z, r = [], [], []
    for k in range(n):
        if use_c[k]:
            for i in range(2):
                h = np.zeros(n * d)
                h[k * d:(k + 1) * d] = Hc[k, i]
                rows.append(h), z.append(zc[k, i]), r.append(rc)
        if use_k[k]:
            h = np.zeros(n * d)
            h[k * d:(k + 1) * d] = Hk[k]
            rows.append(h), z.append(zk[k]), r.append(rk)
    H = np.array(rows)
    expect = multivariate_normal(H @ mx, H @ Px @ H.T + np.diag(r)).logpdf(np.array(z))
    m = arm_refine.Model(F, b, Q, x0, P0)
    got = arm_refine.log_likelihood(m, Hc, zc, use_c, rc, Hk, zk, use_k, rk)
    assert abs(got - expect) < 1e-8 * max(1.0, abs(expect))


def test_arm_columns_match_finite_differences():
    """∂r/∂(S, L1, L2) of the arm row r = |p − L2 u(δθ) − S| − L1 (eq. 15 with eq. 2's elbow),
    and the row's right-hand side z' = H x̄ − r(x̄) over the whole augmented state."""
    rng = np.random.default_rng(5)
    proj, fa = _camera(), np.array([1.0, 0.0, 0.0])
    n, d = 4, 12
    theta = np.array([0.0, 0.3, 0.35, 0.30, 0.28])
    X = np.zeros((n, d + arm_refine.N_ARM))
    X[:, :3] = [0.25, 0.2, 0.1] + 0.03 * rng.standard_normal((n, 3))
    X[:, 6:9] = 0.01 * rng.standard_normal((n, 3))
    X[:, d:] = theta
    q = quat.normalize(rng.standard_normal((n, 4)))
    z = proj(X[:, :3]) + 1.0
    Hc, zc, Hk, zk = arm_refine.linearise(X, z, q, proj, fa)
    assert Hc.shape == (n, 2, d + 5) and not Hc[:, :, d:].any()

    def r(th):
        arm = arm_refine.arm_of(th, fa)
        u = arm_smoother.forearm(q, X[:, 6:9], arm)
        return np.linalg.norm(X[:, :3] - arm.L2 * u - arm.shoulder, axis=1) - arm.L1

    for j in range(5):
        e = np.zeros(5)
        e[j] = 1e-6
        assert np.allclose((r(theta + e) - r(theta - e)) / 2e-6, Hk[:, d + j], atol=1e-6)
    assert np.allclose(zk, np.einsum("kj,kj->k", Hk, X) - r(theta), atol=1e-12)


def test_quadratic_search_finds_a_quadratics_maximum_in_one_round():
    rng = np.random.default_rng(2)
    A = rng.standard_normal((3, 3))
    H = -(A @ A.T + 0.5 * np.eye(3))  # negative definite
    top = np.array([0.3, -0.2, 0.1])

    def f(x):
        return 5.0 + 0.5 * (x - top) @ H @ (x - top)

    L = np.linalg.cholesky(np.linalg.inv(-H))  # fun ≈ −½|y|² in the search's coordinates
    x, fx, Hfit = arm_refine.maximise_quadratic(f, np.zeros(3), L, rounds=1, max_step=10.0)
    np.testing.assert_allclose(x, top, atol=1e-9)
    assert abs(fx - 5.0) < 1e-9
    np.testing.assert_allclose(Hfit, H, atol=1e-8)


def test_quadratic_search_keeps_its_start_where_nothing_is_higher():
    def f(x):
        return -float(x @ x)

    x, fx, _ = arm_refine.maximise_quadratic(f, np.zeros(2), np.eye(2))
    assert (x == 0).all() and fx == 0.0


def test_quadratic_fit_without_a_step_stays_and_measures_the_curvature():
    H = np.array([[-2.0, 0.3], [0.3, -0.5]])

    def f(x):
        return 0.5 * (x - 1.0) @ H @ (x - 1.0)

    x, fx, Hfit = arm_refine.maximise_quadratic(f, np.zeros(2), 0.7 * np.eye(2), step=False)
    assert (x == 0).all() and fx == f(np.zeros(2))
    np.testing.assert_allclose(Hfit, H, atol=1e-9)
