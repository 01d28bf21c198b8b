"""Pooling compare's per-session rows equals computing the statistics over all frames."""

from __future__ import annotations

import numpy as np

from armtrack_cli.compare.errors import error_rows, pooled


def test_pooled_rows_equal_the_rows_of_the_concatenated_frames():
    rng = np.random.default_rng(4)
    sessions = []
    for n, bias in ((120, 0.01), (300, -0.02), (7, 0.05)):
        truth = rng.normal(size=(n, 3))
        est = truth + bias + rng.normal(scale=0.03, size=(n, 3))
        est[rng.random(n) < 0.1] = np.nan  # gaps are left out of both
        sessions.append((est, truth))
    per_session = [r for est, truth in sessions for r in error_rows("m", "wrist", est, truth)]
    everything = error_rows("m", "wrist", np.vstack([e for e, _ in sessions]),
                            np.vstack([t for _, t in sessions]))
    for got, want in zip(pooled(per_session), everything):
        assert got["axis"] == want["axis"] and got["n"] == want["n"]
        for k in ("mean_cm", "std_cm", "rmse_cm", "max_abs_cm", "within_5cm_pct"):
            assert abs(got[k] - want[k]) <= 1e-9 * max(1.0, abs(want[k])), (k, got, want)
