"""The posterior draws a block at a time (measures/draws.py, uncertainty.draw_blocks,
peaks.count_peaks_rows) against the one-signal functions they batch, draw by draw: the same
draws exactly, every measure of every draw to 1e-12, and the SDs of measure_rows to 1e-12 of
the draw-by-draw loop over table.values that they replaced."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter1d

from armtrack_cli.measures import Inputs, Settings, measure_rows, peaks
from armtrack_cli.measures.draws import PathDraws, peak_spacing, window_values
from armtrack_cli.measures.signal import speed_profile
from armtrack_cli.measures.table import _path_values, values
from armtrack_cli.measures.uncertainty import draw_blocks, spread

S = Settings()
pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")  # masked rows stay silent


def laps(n_laps=4, fs=30.0, seed=0, rest=0.6):
    """(t, (N, 3)) circles of 0.12 m radius, 2 s each, with rests of ``rest`` s between, and
    1 mm noise: the segments, onsets and peaks of a real session."""
    rng = np.random.default_rng(seed)
    period = 2.0 + rest
    t = np.arange(0, n_laps * period + rest, 1 / fs)
    s = np.clip((t % period - rest) / 2.0, 0, 1)
    ang = 2 * np.pi * (10 * s**3 - 15 * s**4 + 6 * s**5)
    p = np.c_[0.12 * np.cos(ang), 0.12 * np.sin(ang), 0.3 + 0 * t]
    return t, p + 0.001 * rng.standard_normal(p.shape)


def test_draw_blocks_are_the_draws_drawn_one_by_one():
    """The reference: one (N, d) block of standard normals per draw from one seeded stream,
    each smoothed by its own gaussian_filter1d, as the loop drew them."""
    t = np.arange(500) / 30.0
    sd = np.abs(np.random.default_rng(1).standard_normal((500, 3))) * 0.01
    rng = np.random.default_rng(S.seed)
    sigma = 0.5 * S.draw_corr_s / float(np.median(np.diff(t)))
    delta = np.zeros(500)
    delta[0] = 1.0
    gain = np.sqrt(np.sum(gaussian_filter1d(delta, sigma, mode="wrap") ** 2))
    want = np.stack([gaussian_filter1d(rng.standard_normal((500, 3)), sigma, axis=0,
                                       mode="wrap") / gain * sd for _ in range(S.draws)])
    for block in (1, 7 * 500, 10**9):
        got = np.concatenate(list(draw_blocks(t, sd, S, block_samples=block)))
        assert np.array_equal(got, want)


@pytest.mark.parametrize("reach", [False, True])
def test_window_values_are_each_draws_path_values(reach):
    t, p = laps(seed=2)
    rng = np.random.default_rng(3)
    c = 12
    draws = p[None] + np.cumsum(0.002 * rng.standard_normal((c, *p.shape)), axis=1)
    draws[-1] = p[0]  # a wrist that never moves: every measure not computable
    one = [speed_profile(t, d, S) for d in draws]
    tu, pu, vu = one[0][0], np.stack([o[1] for o in one]), np.stack([o[2] for o in one])
    fs = 1 / (tu[1] - tu[0])
    for a, b in [(0, tu.size), (5, 90), (60, 130), (0, 2), (100, 109)]:
        rows = np.zeros(c, int)  # each draw's window, the samples after it as padding
        got = window_values(tu, rows + a, rows + b - a, pu[:, a:], vu[:, a:],
                            rows + peak_spacing(tu[a:b], S), fs, reach, S)
        for i in range(c):
            want = _path_values(tu[a:b], pu[i, a:b], vu[i, a:b], fs, reach, S) if b - a >= 3 \
                else {}
            for m, x in got.items():
                w = want.get(m, "not computable")
                if isinstance(w, str):
                    assert np.isnan(x[i]), (m, a, b, i)
                else:
                    assert x[i] == pytest.approx(w, rel=1e-12, abs=1e-15), (m, a, b, i)


def test_count_peaks_rows_is_find_peaks_row_by_row():
    """Continuous values (no two peaks of exactly one height), flat tops included."""
    rng = np.random.default_rng(4)
    for trial in range(300):
        R, W = int(rng.integers(1, 30)), int(rng.integers(1, 300))
        x = [rng.standard_normal((R, W)),
             np.repeat(rng.standard_normal((R, W // 3 + 1)), 3, axis=1)[:, :W],
             np.abs(np.sin(np.arange(W) / rng.uniform(2, 20))) + 0.05 * rng.standard_normal((R, W))
             ][trial % 3]
        start = rng.integers(0, W, R)
        length = np.minimum(rng.integers(0, W + 1, R), W - start)
        prom, dist = float(rng.choice([0.0, 0.02, 0.3, 1.0])), int(rng.integers(1, 12))
        got = peaks.count_peaks_rows(x, start, length, prominence=prom, distance=dist)
        want = [peaks.find_peaks(x[r, start[r]:start[r] + length[r]], prominence=prom,
                                 distance=dist).size for r in range(R)]
        assert got.tolist() == want


def test_path_draws_keep_missing_frames_and_windows():
    t, p = laps(seed=5)
    p[200:205] = np.nan  # a bridged gap, the same in every draw
    e = 0.003 * np.random.default_rng(6).standard_normal((3, *p.shape))
    ref, windows = values(Inputs(t=t, wrist=p), S)
    got = PathDraws(t, windows, False, S)(p[None] + e)
    assert {k for k, v in ref.items() if not isinstance(v, str) and k[0] != "segments"} == \
        set(got)
    for i in range(3):
        want = values(Inputs(t=t, wrist=p + e[i]), S, windows)[0]
        for k, x in got.items():
            w = want[k]
            assert (np.isnan(x[i]) if isinstance(w, str) else x[i] == pytest.approx(w, rel=1e-12))


@pytest.mark.parametrize("task", ["circle", "reach"])
def test_measure_sds_are_the_draw_by_draw_loops(task):
    """The reference: table.values on each draw of smooth_draws, as _uncertainty ran before."""
    from armtrack_cli.measures.uncertainty import smooth_draws

    t, p = laps(seed=7)
    sd = np.full_like(p, 0.004)
    sd[:, 2] = np.nan  # a column without SD: no error on it
    elbow = p + np.array([0.0, -0.25, 0.0])
    inp = Inputs(t=t, wrist=p, elbow=elbow, shoulder=np.array([0.0, -0.3, 0.6]), task=task,
                 wrist_sd=sd)
    rows = measure_rows(inp)
    windows = [(r["t_start"], r["t_end"]) for r in rows
               if r["segment"] not in ("session",) and r["measure"] == "wrist_peak_speed"]
    draws = [values(replace(inp, wrist=p + e, elbow=elbow + e), S, windows or None)[0]
             for e in smooth_draws(t, sd, S)]
    assert len(windows) == 4
    for r in rows:
        k = (r["measure"], r["segment"])
        want = spread([d.get(k, "") for d in draws]) if not isinstance(r["value"], str) and \
            k[0] != "segments" else float("nan")
        if np.isnan(want):
            assert np.isnan(r["sd"]), k
        else:
            assert r["sd"] == pytest.approx(want, rel=1e-12), k


def test_angle_draws_are_each_draws_angle_values():
    """angle_draws (a block of draws at once) against table.angle_values one draw at a time:
    an elbow hanging near the plane of elevation's gimbal lock (each draw's plane NaN on
    frames of its own, unwrapped on its own), one draw held below it throughout (no plane:
    not computable), a missing stretch, and wrist angles with a posterior of their own."""
    from armtrack_cli.measures.angle_draws import angle_draws
    from armtrack_cli.measures.table import angle_values

    t = np.arange(300) / 30.0
    rng = np.random.default_rng(8)
    shoulder = np.array([0.1, -0.2, 1.2])
    swing = np.radians(12.0) * np.sin(2 * np.pi * t / 4)[:, None]  # elevation ~0-12°
    az = np.radians(200.0) * t[:, None] / t[-1]  # plane of elevation through ±180°
    u = np.c_[np.sin(swing[:, 0]) * np.cos(az[:, 0]), np.sin(swing[:, 0]) * np.sin(az[:, 0]),
              -np.cos(swing[:, 0])]
    elbow = shoulder + 0.3 * u
    wrist = elbow + np.array([0.0, -0.27, 0.05])
    elbow[100:104] = wrist[100:104] = np.nan
    wa = np.c_[20 * np.sin(t), 10 * np.cos(t), 5 * t]
    inp = Inputs(t=t, wrist=wrist, elbow=elbow, shoulder=shoulder, wrist_angles=wa,
                 q_WB=np.tile([1.0, 0, 0, 0], (300, 1)), forearm_axis=np.array([0, 1.0, 0]))
    c = 6
    ew = 0.01 * np.cumsum(rng.standard_normal((c, 300, 3)), axis=1) / 10
    ew[-1] = shoulder + [0.0, 0.0, -0.3] - elbow  # the elbow straight down: no plane
    ew[-1, 100:104] = 0.0
    ea = 0.5 * rng.standard_normal((c, 300, 3))
    for e_w, e_a in [(ew, ea), (ew, None), (None, ea)]:
        got = angle_draws(inp, e_w, e_a, S)
        for i in range(c):
            d = replace(inp, q_WB=None)
            if e_w is not None:
                d = replace(d, wrist=wrist + e_w[i], elbow=elbow + e_w[i])
            if e_a is not None:
                d = replace(d, wrist_angles=wa + e_a[i])
            want = angle_values(d, S)
            assert set(got) == set(want) - {k for k in want if k[0].startswith("forearm")}
            for k, x in got.items():
                if isinstance(want[k], str):
                    assert np.isnan(x[i]), (k, i)
                else:
                    assert x[i] == pytest.approx(want[k], rel=1e-12, abs=1e-12), (k, i)
    plane = angle_draws(inp, ew, None, S)[("shoulder_plane_rom", "session")]
    assert np.isnan(plane[-1]) and np.isfinite(plane[:-1]).all()
    assert (plane[:-1] > 180).all()  # unwrapped through ±180°


def test_spread_rows_is_spread_row_by_row():
    """Rows without a NaN through one np.std call, the others alone: spread's values exactly
    (rows of every scale; a few NaN; more than half NaN: none)."""
    from armtrack_cli.measures.uncertainty import spread_rows

    rng = np.random.default_rng(9)
    x = rng.standard_normal((300, 40)) * 10.0 ** rng.uniform(-6, 3, (300, 1)) + \
        rng.uniform(-100, 100, (300, 1))
    x[5, 3] = np.nan
    x[6, :25] = np.nan
    x[7] = np.nan
    got = spread_rows(x)
    want = np.array([spread(r) for r in x])
    np.testing.assert_array_equal(got, want)
    assert np.isfinite(got[5]) and np.isnan(got[6]) and np.isnan(got[7])
    assert np.isnan(spread_rows(x[:, :1])).all()
