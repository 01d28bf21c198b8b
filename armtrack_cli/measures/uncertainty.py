"""A measure's uncertainty by sampling the filter's posterior.

Each draw adds to the estimate an error with the posterior SD of every frame (the *_sd
columns) that is correlated in time as an AR(1) process with correlation time s.draw_corr_s
(the columns give the spread of each frame, not how errors of nearby frames go together: the
correlation time is our stated assumption). The measure's uncertainty is the SD of its values
over s.draws draws (seeded, so reruns give the same numbers)."""

from __future__ import annotations

import numpy as np

from armtrack_cli.measures.base import Settings


def ar1_draws(t: np.ndarray, sd: np.ndarray, s: Settings) -> np.ndarray:
    """(draws, N, d) zero-mean errors, marginal SD sd (N, d) (NaN -> 0), AR(1) in time."""
    rng = np.random.default_rng(s.seed)
    sd = np.nan_to_num(np.asarray(sd, float), nan=0.0)
    n, d = sd.shape
    dt = np.diff(t, prepend=t[0])
    dt = np.where(np.isfinite(dt), dt, 0.0)
    phi = np.exp(-dt / s.draw_corr_s)[:, None]  # e_k = φ e_{k−1} + √(1 − φ²) w_k
    w = rng.standard_normal((s.draws, n, d))
    e = np.empty_like(w)
    e[:, 0] = w[:, 0]
    for k in range(1, n):
        e[:, k] = phi[k] * e[:, k - 1] + np.sqrt(1 - phi[k] ** 2) * w[:, k]
    return e * sd[None]


def spread(samples: list[float]) -> float:
    """SD of the computable draws; NaN when fewer than half of them gave a value."""
    x = np.array([v for v in samples if isinstance(v, float) and np.isfinite(v)])
    return float(np.std(x, ddof=1)) if x.size >= 2 and 2 * x.size >= len(samples) else float("nan")
