"""Every Gaussian filter equals the Kalman filter on a linear-Gaussian model; the particle
filter matches it within Monte-Carlo error; resampling schemes are unbiased."""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.filters import gaussian
from armtrack_cli.filters.particles import ess, gaussian_cloud, moments, resample_below, weights
from armtrack_cli.filters.resampling import SCHEMES


def _linear_model(seed=0, n=4, m=2, steps=60, stable=False):
    rng = np.random.default_rng(seed)
    F = np.eye(n) + 0.1 * rng.normal(size=(n, n))
    if stable:  # spectral radius 0.9: the posterior stays of a fixed size
        F *= 0.9 / np.max(np.abs(np.linalg.eigvals(F)))
    b = rng.normal(size=n) * 0.1
    H = rng.normal(size=(m, n))
    A = rng.normal(size=(n, n))
    Q = 0.05 * A @ A.T + 0.01 * np.eye(n)
    R = np.diag(rng.uniform(0.1, 0.5, m))
    x = rng.normal(size=n)
    zs = []
    for k in range(steps):
        x = F @ x + b + rng.multivariate_normal(np.zeros(n), Q)
        z = H @ x + rng.multivariate_normal(np.zeros(m), R)
        zs.append(None if k % 7 == 3 else z)  # some measurements missing
    return F, b, H, Q, R, zs


def kalman_step(x, P, z, F, b, Q, H, R):
    """The textbook Kalman filter, written here independently of filters/gaussian.py (explicit
    inverse, the short covariance form (I − KH) P): predict x⁻ = F x + b, P⁻ = F P Fᵀ + Q;
    update K = P⁻ Hᵀ (H P⁻ Hᵀ + R)⁻¹, x = x⁻ + K (z − H x⁻), P = (I − K H) P⁻."""
    x, P = F @ x + b, F @ P @ F.T + Q
    if z is None:
        return x, P
    K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
    return x + K @ (z - H @ x), (np.eye(x.size) - K @ H) @ P


def test_kf_ekf_and_ukf_equal_the_textbook_kalman_filter():
    F, b, H, Q, R, zs = _linear_model()
    n = F.shape[0]
    s0 = gaussian.Gaussian(np.zeros(n), np.eye(n))
    kf = ekf = ukf = s0
    x_ref, P_ref = s0.x, s0.P
    sp = gaussian.SigmaPoints(n, alpha=0.7, beta=2.0, kappa=1.0)
    f = lambda X: X @ F.T + b  # noqa: E731  (vectorised over sigma points)
    h = lambda X: X @ H.T  # noqa: E731
    for z in zs:
        kf = gaussian.kf_update(gaussian.kf_predict(kf, F, Q, b), z, H, R)
        ekf = gaussian.ekf_update(gaussian.kf_predict(ekf, F, Q, b), z, h, lambda x: H, R)
        ukf = gaussian.ukf_update(gaussian.ukf_predict(ukf, f, Q, sp), z, h, R, sp)
        x_ref, P_ref = kalman_step(x_ref, P_ref, z, F, b, Q, H, R)
        for s in (kf, ekf, ukf):
            np.testing.assert_allclose(s.x, x_ref, rtol=0, atol=1e-10)
            np.testing.assert_allclose(s.P, P_ref, rtol=0, atol=1e-10)


def test_missing_measurement_leaves_the_state_alone():
    s = gaussian.Gaussian(np.ones(2), np.eye(2))
    assert gaussian.kf_update(s, None, np.eye(2), np.eye(2)) is s
    assert gaussian.ukf_update(s, None, lambda X: X, np.eye(2), gaussian.SigmaPoints(2)) is s


def test_particle_filter_matches_the_kalman_filter():
    """Bootstrap PF with 20,000 particles (fixed seed) on a stable linear-Gaussian model: after
    every step its posterior mean is within a tenth of the KF's posterior standard deviation of
    the KF mean, and its spread within 15 % of the KF's (resampling thins it a little). The
    Monte-Carlo error of the mean is about σ/√ESS ≈ 0.01σ per step; it accumulates over steps,
    hence the wider bound."""
    F, b, H, Q, R, zs = _linear_model(seed=1, steps=30, stable=True)
    n = F.shape[0]
    rng = np.random.default_rng(7)
    N = 20000
    kf_x, kf_P = np.zeros(n), np.eye(n)
    x = rng.multivariate_normal(np.zeros(n), np.eye(n), N)
    w = np.full(N, 1.0 / N)
    Lq = np.linalg.cholesky(Q)
    Rinv = np.linalg.inv(R)
    for z in zs:
        kf_x, kf_P = kalman_step(kf_x, kf_P, z, F, b, Q, H, R)
        x = x @ F.T + b + rng.standard_normal((N, n)) @ Lq.T
        if z is not None:
            d = z - x @ H.T
            w = weights(-0.5 * np.einsum("ni,ij,nj->n", d, Rinv, d), w)
        if ess(w) < N / 2:
            x, w = x[SCHEMES["systematic"](w, rng)], np.full(N, 1.0 / N)
        mean, cov = moments(x, w)
        sd = np.sqrt(np.diag(cov))
        sigma = np.sqrt(np.diag(kf_P))
        assert np.all(np.abs(mean - kf_x) < 0.1 * sigma), (mean - kf_x) / sigma
        np.testing.assert_allclose(sd, sigma, rtol=0.15)


@pytest.mark.parametrize("name", sorted(SCHEMES))
def test_resampling_is_unbiased(name):
    """E[offspring of i] = N · w_i. Over T = 4000 draws the mean count of every particle is
    within 4.5 standard errors of N · w_i (a per-particle z-test; 50 particles, so the chance
    of a false alarm is about 50 × 7e-6)."""
    rng = np.random.default_rng(123)
    N, T = 50, 4000
    w = rng.gamma(0.5, size=N)
    w[::7] *= 0.01  # some nearly dead particles
    w /= w.sum()
    counts = np.stack([np.bincount(SCHEMES[name](w, rng), minlength=N) for _ in range(T)])
    assert (counts.sum(axis=1) == N).all()
    mean = counts.mean(axis=0)
    # a nearly dead particle may never be drawn in T trials: floor the variance at the
    # Bernoulli variance N w (1 − N w) it would have
    nw = N * w
    var = np.maximum(counts.var(axis=0, ddof=1), nw * np.clip(1 - nw, 0, 1))
    z = (mean - nw) / np.sqrt(var / T + 1e-18)
    assert np.all(np.abs(z) < 4.5), (name, z[np.abs(z) >= 4.5])


def test_residual_keeps_the_integer_part_exactly():
    w = np.array([0.5, 0.25, 0.125, 0.125])
    idx = SCHEMES["residual"](w, np.random.default_rng(0))
    assert np.bincount(idx, minlength=4).tolist() == [2, 1, 0, 1] or np.bincount(
        idx, minlength=4).tolist() == [2, 1, 1, 0]


def test_weights_survive_impossible_and_tiny_likelihoods():
    np.testing.assert_allclose(weights(np.array([-np.inf, -np.inf, -np.inf])), 1 / 3)
    np.testing.assert_allclose(weights(np.array([-1e4, -1e4 - np.log(3)])), [0.75, 0.25])


@pytest.mark.parametrize("n", [7, 300, 500, 5000, 50000])
def test_equal_weights_are_never_resampled_for_round_off(n):
    """With pf_resample_ess = 1 a PF resamples every frame whose weights differ; equal weights
    (a frame without a detection) have ESS = N only to the last bits of Σ w², which a BLAS
    build or a CPU may put on either side of N: resample_below keeps them above the line."""
    for w in (np.full(n, 1.0 / n), np.full(n, 1.0) * (1.0 / n)):
        assert ess(w) >= resample_below(1.0) * n
        assert abs(ess(w) - n) < 1e-10 * n
    w = np.full(n, 1.0 / n)
    w[: n // 2] *= 1.01  # weights a detection made (here ESS/N = 1 − 2.5e-5) are resampled
    assert ess(w / w.sum()) < resample_below(1.0) * n


@pytest.mark.parametrize("cov", ["diagonal", "full", "singular"])
def test_gaussian_cloud_is_numpys_multivariate_normal(cov):
    """The particle filters' initial cloud: numpy's multivariate_normal, number for number,
    from generators in the same state, and left in the same state (what is drawn after it,
    the splitmix stream's key, is the same too)."""
    rng = np.random.default_rng(3)
    mean = rng.normal(size=6)
    A = rng.normal(size=(6, 6))
    P = {"diagonal": np.diag(rng.uniform(0.01, 0.1, 6) ** 2), "full": A @ A.T * 1e-3,
         "singular": A[:, :4] @ A[:, :4].T * 1e-3}[cov]
    for seed in range(5):
        a, b = np.random.default_rng(seed), np.random.default_rng(seed)
        np.testing.assert_array_equal(gaussian_cloud(a, mean, P, 500),
                                      b.multivariate_normal(mean, P, size=500))
        assert a.bit_generator.random_raw() == b.bit_generator.random_raw()
