"""Particle-set arithmetic on plain arrays: particles are (N, d), weights (N,) sum to 1.

These are the primitives every particle filter here is made of (fuse/methods.py) and that the
tests check against the Kalman filter; resampling schemes are in ``resampling``.
"""

from __future__ import annotations

import numpy as np


def resample_below(share: float) -> float:
    """The ESS share under which a particle filter resamples: ``share`` less round-off, so that
    equal weights never count as degenerate (their ESS is N only to the last bits of Σ w²,
    which differ between BLAS builds and CPUs: with share 1 a coin flip per frame)."""
    return share * (1.0 - 1e-9)


def gaussian_cloud(rng: np.random.Generator, mean: np.ndarray, cov: np.ndarray,
                   n: int) -> np.ndarray:
    """n draws (n, d) of N(mean, cov): rng.multivariate_normal(mean, cov, size=n), the same
    numbers by the same arithmetic (numpy's SVD method: standard normals times u √s, plus the
    mean; tests/test_particles.py holds them equal), without its check that cov is positive
    semi-definite (a 6 × 6 product and an allclose, most of its 0.12 ms): a filter's initial
    covariance is one by construction (FuseSettings' variances on the diagonal)."""
    z = rng.standard_normal((n, mean.shape[0]))
    u, s, _ = np.linalg.svd(np.asarray(cov, dtype=float))
    return mean + z @ (u * np.sqrt(s)).T


def weights(loglik: np.ndarray, prior: np.ndarray | None = None) -> np.ndarray:
    """Bayes' rule on the weights, w ∝ w_prior · p(z | x) (Tao & Hu eq. 14), normalised;
    computed from log-likelihoods so tiny likelihoods do not underflow. If every particle is
    impossible the weights fall back to uniform."""
    lw = loglik if prior is None else loglik + np.log(prior)
    m = np.max(lw)
    if not np.isfinite(m):
        return np.full(lw.size, 1.0 / lw.size)
    w = np.exp(lw - m)
    return w * (1.0 / w.sum())  # a multiply, as the compiled kernel's (fuse/pf_kernel.py)


def ess(w: np.ndarray) -> float:
    """Effective sample size 1 / Σ w²."""
    return float(1.0 / (w @ w))


def moments(x: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weighted mean (d,) and covariance (d, d)."""
    mean = w @ x
    d = x - mean
    return mean, (w[:, None] * d).T @ d
