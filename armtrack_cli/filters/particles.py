"""A particle set as an (N, d) array with log-weights; ESS; resampling returning ancestors."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armtrack_cli.filters.resampling import scheme


@dataclass(frozen=True)
class Particles:
    x: np.ndarray  # (N, d)
    logw: np.ndarray  # (N,), normalised so that logsumexp(logw) = 0

    @property
    def n(self) -> int:
        return self.x.shape[0]

    def weights(self) -> np.ndarray:
        return np.exp(self.logw)


def normalise(logw: np.ndarray) -> np.ndarray:
    m = np.max(logw)
    if not np.isfinite(m):  # every particle impossible: fall back to uniform
        return np.full(logw.size, -np.log(logw.size))
    return logw - (m + np.log(np.sum(np.exp(logw - m))))


def reweight(p: Particles, loglik: np.ndarray) -> Particles:
    """Bayes' rule on the weights: w ∝ w · p(z | x) (Tao & Hu eq. 14)."""
    return Particles(p.x, normalise(p.logw + loglik))


def ess(p: Particles) -> float:
    """Effective sample size 1 / Σ w²."""
    return float(1.0 / np.sum(np.exp(2 * p.logw)))


def resample(p: Particles, name: str, rng: np.random.Generator) -> tuple[Particles, np.ndarray]:
    """(equally weighted set, ancestor indices)."""
    idx = scheme(name)(p.weights(), rng)
    return Particles(p.x[idx], np.full(p.n, -np.log(p.n))), idx


def moments(p: Particles) -> tuple[np.ndarray, np.ndarray]:
    """Weighted mean (d,) and covariance (d, d)."""
    w = p.weights()
    mean = w @ p.x
    d = p.x - mean
    return mean, (w[:, None] * d).T @ d
