"""The measures of a long trajectory a window at a time (measures/windowed.py, issue 15)
against the whole span's measure_rows: every value to 1e-9 (the same segments, times and
"not computable" reasons), a one-window span the very cells, and the posterior SDs within
the Monte Carlo noise of the whole span's. Synthetic trajectories of known shape: repeated
reaches with rests (path lengths and counts known), a plane of elevation and a forearm
pronation that cross ±180°; windows shortened (WINDOW_S) to make many on short data."""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.core import windows as windows_mod
from armtrack_cli.core.windows import Window, windows
from armtrack_cli.measures import Inputs, measure_rows, path, peaks
from armtrack_cli.measures.base import Settings
from armtrack_cli.measures.segments import segments
from armtrack_cli.measures.stream import (
    OnsetOffset,
    OrderStats,
    PeakSketch,
    Runs,
    interior_maxima,
    lerp,
    percentile_index,
)
from armtrack_cli.measures.windowed import measure_rows_windowed
from armtrack_cli.pipeline import kinematics

S = Settings()
FIELDS = ("t", "wrist", "elbow", "q_WB", "wrist_sd", "angles_sd", "wrist_angles")


def reaches(minutes: float, fps: float = 30.0, seed: int = 1, noise: float = 5e-4,
            long_rest_at: float | None = None) -> Inputs:
    """Reaches of 1.2 s out and back (a minimum-jerk arc, 0.25 m forward), 1.5 s holds and
    rests of 1.5-4.5 s; optionally one rest of 150 s (longer than a read span) from
    ``long_rest_at`` s. The forearm turns 3.5 rad with each reach (its pronation crosses
    ±180°), the humerus sweeps its plane of elevation from 150° to 220° at 60° elevation."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(minutes * 60 * fps)) / fps
    out = np.zeros(t.size)
    cur = 2.0
    while cur < t[-1] - 10:
        if long_rest_at is not None and cur <= long_rest_at < cur + 8:
            cur += 150.0
        for go in (True, False):
            m = (t >= cur) & (t < cur + 1.2)
            tau = (t[m] - cur) / 1.2
            s = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
            out[m] = s if go else 1 - s
            cur += 1.2
            out[(t >= cur) & (t < cur + 1.5)] = 1.0 if go else 0.0
            cur += 1.5 + (0 if go else rng.uniform(0, 3))
    wrist = np.c_[0.3 + 0.25 * out, 0.2 + 0.05 * np.sin(np.pi * out), 0.1 + 0.08 * out]
    wrist += rng.normal(0, noise, wrist.shape)
    plane, elev = np.radians(150 + 70 * out), np.radians(60)  # the plane through 180°
    u = np.c_[-np.sin(elev) * np.cos(plane), -np.sin(elev) * np.sin(plane),
              -np.cos(elev) + 0 * plane]  # the humerus in W (thorax X = −y_W, Y = z_W, Z = −x_W)
    elbow = np.array([0.3, 0.55, 0.35]) + 0.28 * u
    ang = 0.8 * np.sin(2 * np.pi * t / 37.0) + 3.5 * out
    q = np.c_[np.cos(ang / 2), np.sin(ang / 2), np.zeros(t.size), np.zeros(t.size)]
    return Inputs(t=t, wrist=wrist, task="reach", side="right", elbow=elbow,
                  shoulder=np.array([0.3, 0.55, 0.35]), q_WB=q, forearm_axis=np.array([1.0, 0, 0]),
                  wrist_sd=np.full((t.size, 3), 0.003))


def reader(inp: Inputs):
    """read(w): the Inputs of the frames in [w.start, w.stop] (slices of the whole)."""
    def read(w: Window) -> Inputs:
        sl = w.read(inp.t)
        cols = {f: None if getattr(inp, f) is None else getattr(inp, f)[sl] for f in FIELDS}
        return Inputs(task=inp.task, side=inp.side, shoulder=inp.shoulder,
                      forearm_axis=inp.forearm_axis, **cols)
    return read


def by_key(rows):
    return {(r["measure"], r["segment"]): r for r in rows}


def assert_same_values(whole, win, tol=1e-9):
    """The same rows in the same order, every value to tol, the same reasons and times."""
    A, B = by_key(whole), by_key(win)
    assert list(A) == list(B)
    for k, a in A.items():
        b = B[k]
        assert (a["t_start"], a["t_end"], a["unit"]) == (b["t_start"], b["t_end"], b["unit"]), k
        if isinstance(a["value"], str) or isinstance(b["value"], str):
            assert a["value"] == b["value"], k
        else:
            assert b["value"] == pytest.approx(a["value"], abs=tol, rel=0), k


def test_one_window_is_the_whole_span_cells(monkeypatch):
    """A span of one window: kinematics_cells itself (the same text in every cell)."""
    inp = reaches(4)
    table = {"t": inp.t, **{f"wrist_{a}": inp.wrist[:, i] for i, a in enumerate("xyz")},
             **{f"elbow_{a}": inp.elbow[:, i] for i, a in enumerate("xyz")}}

    class Sess:
        class meta:
            task, side = "reach", "right"
        arm = imu = None

    assert len(windows(inp.t[0], inp.t[-1])) == 1
    calls = []

    def read(w):
        calls.append(w)
        sl = w.read(inp.t)
        return {k: v[sl] for k, v in table.items()}

    got = kinematics.kinematics_cells_windowed(read, inp.t[0], inp.t[-1], Sess)
    assert repr(got) == repr(kinematics.kinematics_cells(table, Sess)) and len(calls) == 1


@pytest.mark.parametrize("minutes,window_s", [(13, 300.0), (5, 60.0)])
def test_windowed_values_equal_the_whole_span(minutes, window_s):
    """Several windows (13 minutes in 3; 5 minutes in 5 of 60 s): every value of the session
    row and of each of the ~200 segments' rows to 1e-9 of measure_rows; the segments count
    the reaches and returns."""
    inp = reaches(minutes)
    wins = windows(inp.t[0], inp.t[-1], window_s, 20.0)
    assert len(wins) >= 3
    whole = measure_rows(inp)
    win = measure_rows_windowed(reader(inp), wins)
    assert_same_values(whole, win)
    n_moves = int(np.sum(np.diff(np.r_[0.0, np.round(inp.wrist[:, 0] > 0.425)]) != 0))
    assert by_key(win)[("segments", "session")]["value"] == pytest.approx(n_moves, abs=1)


def test_segment_across_windows_and_a_long_rest(monkeypatch):
    """A 150 s rest (longer than a 45 s window and its margins): the segment before it runs
    half into it, across window seams; its samples gathered from several windows give the
    whole span's values; its SD is left empty (its owner's read span does not hold it)."""
    inp = reaches(6, long_rest_at=100.0)
    monkeypatch.setattr(windows_mod, "WINDOW_S", 45.0)
    wins = kinematics._measure_windows(inp.t[0], inp.t[-1])
    assert len(wins) >= 6
    whole, win = measure_rows(inp), measure_rows_windowed(reader(inp), wins)
    assert_same_values(whole, win)
    long = [r for r in win if r["segment"] != "session" and r["t_end"] - r["t_start"] > 70]
    assert long and all(np.isnan(r["sd"]) for r in long)


def test_ground_truth_on_the_estimates_segments():
    """measure_rows_windowed given the estimate's segment windows (compare's truth): the
    whole span's values on those windows, and its own segment count."""
    est, truth = reaches(11, seed=3), reaches(11, seed=3, noise=1e-3)
    win_est = [(r["t_start"], r["t_end"]) for r in measure_rows(est)
               if r["segment"] != "session" and r["measure"] == "wrist_peak_speed"]
    wins = windows(truth.t[0], truth.t[-1])
    assert_same_values(measure_rows(truth, windows=win_est),
                       measure_rows_windowed(reader(truth), wins, windows=win_est))


def test_posterior_sds_within_monte_carlo_noise():
    """The SDs from each window's own draws against the whole span's, both over 3 seeds:
    each segment measure's mean SD over the segments within 10 %, the session's peak speed
    and angle extremes within 30 % (40 draws give an SD to ±11 % (1 SE); a mean of 3 to
    ±7 %); the session's sums have none (docs/measures.md)."""
    inp = reaches(12)
    wins = windows(inp.t[0], inp.t[-1])
    whole, win = [], []
    for seed in range(3):
        s = Settings(seed=seed)
        whole.append(by_key(measure_rows(inp, s)))
        win.append(by_key(measure_rows_windowed(reader(inp), wins, s)))
    ratios: dict[str, list] = {}
    for k in whole[0]:
        a = np.mean([w[k]["sd"] for w in whole])
        b = np.mean([w[k]["sd"] for w in win])
        if not np.isfinite(a) or a == 0:
            continue
        if k[1] == "session":
            if k[0] == "wrist_peak_speed" or k[0].endswith(("_min", "_max", "_rom")):
                assert b == pytest.approx(a, rel=0.30), k
            else:
                assert np.isnan(b), k  # not windowed (docs/measures.md)
        else:
            ratios.setdefault(k[0], []).append((a, b))
    assert len(ratios) >= 6
    for m, r in ratios.items():
        a, b = np.mean(r, axis=0)  # over the ~200 segments: ±2 % of Monte Carlo noise
        if m == "movement_units":  # a count: one draw in 40 off by one now and then
            assert abs(b - a) < 0.05
        else:
            assert b == pytest.approx(a, rel=0.10), m


def pieces_of(x, cuts):
    """x in consecutive pieces (k0, piece) cut at the given indices."""
    edges = [0, *cuts, x.size]
    return [(a, x[a:b]) for a, b in zip(edges[:-1], edges[1:])]


@pytest.mark.parametrize("seed", range(4))
def test_stream_pieces_against_the_whole_signal(seed):
    """OnsetOffset, Runs, PeakSketch over pieces of a speed-like signal against
    path.onset_offset, segments' runs and peaks.find_peaks on the whole."""
    rng = np.random.default_rng(seed)
    n = 3000
    v = np.abs(np.convolve(rng.standard_normal(n + 40), np.hanning(41), "valid"))[:n]
    v[rng.integers(0, n, 30)] = 0.0
    cuts = sorted(rng.choice(np.arange(5, n - 5), 6, replace=False).tolist())
    vk = float(v.max())
    oo, runs = OnsetOffset(S.onset_fraction * vk, S.min_segment_peak * vk, n), Runs(0.1 * vk)
    for k0, x in pieces_of(v, cuts):
        oo.add(k0, x)
        runs.add(k0, x)
    a, b = path.onset_offset(v, S)
    assert oo.span() == (a, b)
    above = v >= 0.1 * vk
    edges = np.flatnonzero(np.diff(np.r_[0, above.astype(int), 0]))
    assert [(r0, r1) for r0, r1, _ in runs.finish(n)] == list(zip(edges[::2], edges[1::2]))
    sk = PeakSketch(a, b)
    for k0, x in pieces_of(v, [c for c in cuts if a < c <= b]):
        lo, hi = max(k0, a), min(k0 + x.size, b + 1)
        if hi > lo:
            m = interior_maxima(v, lo, hi)
            sk.add(lo, v[lo:hi], m[(m > a) & (m < b)] - lo)
    for prom, dist in ((0.02, 5), (0.0, 1), (0.3, 12)):
        want = peaks.find_peaks(v[a:b + 1], prominence=prom, distance=dist).size
        assert sk.count(prom, dist) == want


def test_order_statistics_are_np_percentile():
    """OrderStats over pieces, with heavy ties and a narrow cluster, gives np.percentile."""
    rng = np.random.default_rng(5)
    x = np.r_[rng.normal(0, 50, 20000), np.full(9000, 12.5), 12.5 + 1e-9 * rng.random(3000)]
    x = rng.permutation(x)
    n = x.size
    ranks = [percentile_index(n, q) for q in (5, 95, 50)]
    o = OrderStats(float(x.min()), float(x.max()), [r for a, b, _ in ranks for r in (a, b)])
    passes = 0
    while True:
        o.begin()
        for _, piece in pieces_of(x, [5000, 17000, 30000]):
            o.add(piece)
        passes += 1
        if o.end():
            break
    got = [lerp(o.value(a), o.value(b), g) for a, b, g in ranks]
    assert got == list(np.percentile(x, [5, 95, 50]))
    assert passes <= 8  # 1e-9 wide cluster: bins of 1024 narrow it in 6 passes


def test_segments_of_the_stream_equal_segments():
    """The runs the windows find make segments.segments' windows (windowed.own_segments)."""
    from armtrack_cli.measures.clock import Clock
    from armtrack_cli.measures.windowed import own_segments

    inp = reaches(3)
    from armtrack_cli.measures.signal import speed_profile

    t, _, v = speed_profile(inp.t, inp.wrist, S)
    runs = Runs(S.segment_fraction * v.max())
    for k0, x in pieces_of(v, [700, 2000, 2001, 4100]):
        runs.add(k0, x)
    clock = Clock(float(t[0]), float(np.median(np.diff(inp.t))), t.size)
    assert own_segments(runs.finish(t.size), clock, float(v.max()), S) == segments(t, v, S)


def test_the_stage_interface_windows(monkeypatch):
    """kinematics_cells_windowed and measure_comparison_windowed over 5 windows of 60 s: the
    same cells (values' text) as kinematics_cells and measure_comparison on the whole."""
    inp, truth = reaches(5, seed=4), reaches(5, seed=4, noise=1e-3)
    table = {"t": inp.t, **{f"wrist_{a}": inp.wrist[:, i] for i, a in enumerate("xyz")},
             **{f"elbow_{a}": inp.elbow[:, i] for i, a in enumerate("xyz")}}

    class Sess:
        class meta:
            task, side = "reach", "right"

        class arm:
            shoulder_m = [0.3, 0.55, 0.35]
        imu = None

    monkeypatch.setattr(windows_mod, "WINDOW_S", 60.0)
    t0, t1 = inp.t[0], inp.t[-1]
    assert len(kinematics._measure_windows(t0, t1)) == 5

    def read(w):
        sl = w.read(inp.t)
        return {k: v[sl] for k, v in table.items()}

    est = kinematics.kinematics_cells_windowed(read, t0, t1, Sess)
    whole = kinematics.kinematics_cells(table, Sess)
    assert [(r["measure"], r["segment"], r["value"]) for r in est] == \
        [(r["measure"], r["segment"], r["value"]) for r in whole]
    got = kinematics.measure_comparison_windowed("m", est, reader(truth), t0, t1)
    want = kinematics.measure_comparison("m", est, truth)
    assert [(r["measure"], r["segment"], r["truth"]) for r in got] == \
        [(r["measure"], r["segment"], r["truth"]) for r in want]


def test_window_profiles_are_the_whole_speed_profile():
    """Each window's speed profile on its inner span: the whole span's clock to the bit, its
    positions and speeds (signal.speed_profile) to 1e-12."""
    from armtrack_cli.measures.clock import find_clock
    from armtrack_cli.measures.signal import speed_profile
    from armtrack_cli.measures.windowed import _own_frames, profiles

    inp = reaches(6)
    t, p, v = speed_profile(inp.t, inp.wrist, S)
    wins = windows(inp.t[0], inp.t[-1], 60.0, 20.0)
    clock = find_clock(_own_frames(reader(inp), wins), S)
    assert clock.n == t.size
    seen = 0
    for pr in profiles(reader(inp), wins, clock, S):
        k = np.arange(pr.k0 + pr.a, pr.k0 + pr.b)
        assert k[0] == seen and np.array_equal(pr.t[pr.a:pr.b], t[k])
        assert np.abs(pr.v[pr.a:pr.b] - v[k]).max() < 1e-12
        assert np.abs(pr.p[pr.a:pr.b] - p[k]).max() < 1e-12
        seen = k[-1] + 1
    assert seen == t.size
