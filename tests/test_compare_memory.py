"""compare's lean forms (issue 15: a 60-minute session's compare held less at once) against
the forms they replaced, bit for bit: the truth's interpolation and the clock-offset cost
computed in place, the zero-phase filter keeping only the ends of its extension, Winter's
analysis writing each coordinate where it goes (into the marker itself, too)."""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.compare import sync
from armtrack_cli.compare.errors import truth_at
from armtrack_cli.compare.residual import winter_lowpass_columns, winter_lowpass_into
from armtrack_cli.core import butter
from armtrack_cli.core.butter import PAD, ZeroPhase, _response


def _truth_at_old(t, t_truth, xyz, rate_hz):
    """compare/errors.truth_at before: the interpolation as one expression."""
    out = np.full((t.size, 3), np.nan)
    i = np.searchsorted(t_truth, t, side="right")
    ok = (i > 0) & (i < t_truth.size)
    i0, i1 = np.clip(i - 1, 0, t_truth.size - 1), np.clip(i, 0, t_truth.size - 1)
    span = t_truth[i1] - t_truth[i0]
    ok &= span <= 1.5 / rate_hz
    ok &= np.isfinite(xyz[i0]).all(axis=1) & np.isfinite(xyz[i1]).all(axis=1)
    f = np.where(span > 0, (t - t_truth[i0]) / np.where(span > 0, span, 1), 0.0)[:, None]
    out[ok] = (xyz[i0] * (1 - f) + xyz[i1] * f)[ok]
    return out


def _truth(seed: int, m: int = 3000):
    rng = np.random.default_rng(seed)
    t_truth = np.arange(m) / 100.0
    t_truth = np.delete(t_truth, rng.choice(m, 40, replace=False))  # clock gaps
    xyz = np.cumsum(rng.normal(0, 1e-3, (t_truth.size, 3)), axis=0)
    xyz[rng.choice(t_truth.size, 150, replace=False)] = np.nan  # marker gaps
    t = np.sort(rng.uniform(-1.0, 31.0, 900))
    est = np.interp(t, t_truth, np.nan_to_num(xyz[:, 0]))[:, None] + rng.normal(0, 0.01, (900, 3))
    return t, t_truth, xyz, est


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_truth_at_in_place_is_the_expressions_bit_for_bit(seed):
    t, t_truth, xyz, _ = _truth(seed)
    got, ref = truth_at(t, t_truth, xyz, 100.0), _truth_at_old(t, t_truth, xyz, 100.0)
    assert np.isnan(ref).any() and np.isfinite(ref).any()
    assert np.array_equal(got, ref, equal_nan=True)


def _cost_old(delta, t, est, truth_t, truth_xyz, rate_hz, n_est, rays=None):
    """compare/sync._cost before: new arrays at every step."""
    tr = _truth_at_old(t, truth_t + delta, truth_xyz, rate_hz)
    ok = np.isfinite(est).all(axis=1) & np.isfinite(tr).all(axis=1)
    r = est[ok] - tr[ok]
    if ok.sum() < sync.MIN_OVERLAP * n_est:
        return np.inf
    r = r - r.mean(axis=0)
    if rays is not None:
        r = r - np.sum(r * rays[ok], axis=1, keepdims=True) * rays[ok]
    return float(np.mean(np.sum(r**2, axis=1)))


@pytest.mark.parametrize("seed", [0, 3])
def test_offset_cost_in_place_is_the_old_one_bit_for_bit(seed):
    t, t_truth, xyz, est = _truth(seed)
    rays = est - np.array([0.1, -0.4, 1.5])
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    kept = rays.copy()
    n = int(np.isfinite(est).all(axis=1).sum())
    for delta in (-0.3, -0.004, 0.0, 0.0217, 0.5):
        for r in (None, rays):
            assert sync._cost(delta, t, est, t_truth, xyz, 100.0, n, r) == _cost_old(
                delta, t, est, t_truth, xyz, 100.0, n, r)
    assert np.array_equal(rays, kept)  # the caller's rays untouched


def _at_old(x, fs, fc):
    """core/butter.ZeroPhase.at before, with the whole odd extension kept."""
    ext = np.concatenate([2 * x[:, :1] - x[:, PAD:0:-1], x,
                          2 * x[:, -1:] - x[:, -2:-(PAD + 2):-1]], axis=1)
    ne = ext.shape[1]
    h, R, zi = _response(fc, fs, ne)
    L = len(h)
    nfft = butter.fast_len(ne + L)
    H = np.fft.rfft(h, nfft)
    y = np.fft.irfft(np.fft.rfft(ext, nfft) * (H.real**2 + H.imag**2), nfft)[:, :ne]
    g = h[::-1]
    z1 = (ext[:, :1] * zi) @ R.T
    for i in range(len(x)):
        if L > 1:
            tail = np.convolve(h, ext[i, ne - L + 1:])[L - 1:2 * L - 2]
            y[i, ne - L + 1:] -= np.convolve(g, tail)[:L - 1]
        y[i, :L] += np.convolve(g, z1[i])[L - 1:2 * L - 1]
    last = ext[:, ne - L:][:, ::-1] @ h + z1[:, -1] * (L == ne)
    y[:, ne - L:] += ((last[:, None] * zi) @ R.T)[:, ::-1]
    return y[:, PAD:ne - PAD]


@pytest.mark.parametrize("n", [20, 300, 5000])
def test_zero_phase_with_the_extensions_ends_only_is_the_old_one(n):
    """Short signals too, whose impulse response is cut at the extension's length (L = ne)."""
    rng = np.random.default_rng(n)
    x = np.cumsum(rng.normal(0, 1e-3, (2, n)), axis=1)
    cut = [6.0, 1.0, 2.5]
    ready = ZeroPhase(x, 100.0, cut)
    for fc in cut:
        ref = _at_old(x, 100.0, fc)
        if ready.nfft == butter.fast_len(ready.ne + len(_response(fc, 100.0, ready.ne)[0])):
            assert np.array_equal(ready.at(fc), ref)  # the same transform length: the same bits
        assert np.abs(ready.at(fc) - ref).max() < 1e-12
    if len(_response(0.2, 100.0, ready.ne)[0]) > ready.tail.shape[1]:
        with pytest.raises(ValueError):
            ready.at(0.2)  # a longer response than any made ready


def test_winter_written_into_the_marker_itself_is_the_columns_copy():
    rng = np.random.default_rng(8)
    t = np.arange(0, 8, 0.01)
    X = np.stack([0.2 * np.sin(2 * np.pi * 0.1 * t) + 3e-4 * rng.standard_normal(t.size),
                  0.2 * np.sin(2 * np.pi * 2.0 * t) + 3e-4 * rng.standard_normal(t.size),
                  0.3 + 0.01 * t], axis=1)
    ref = winter_lowpass_columns(X, 100.0, max_hz=6.0)
    own = X.copy()
    cut = winter_lowpass_into(own, 100.0, 6.0, own)
    assert cut == [fc for fc, _ in ref]
    for j, (_, y) in enumerate(ref):
        assert np.array_equal(own[:, j], y)


def _marker_truth(seed: int):
    from armtrack_cli.compare.score import Truth

    rng = np.random.default_rng(seed)
    t = np.arange(3000) / 100.0
    xyz = {j: np.cumsum(rng.normal(0, 1e-3, (t.size, 3)), axis=0) for j in ("elbow", "wrist")}
    xyz["wrist"][1200:1260] = np.nan  # a gap: two runs, each its own cut-offs
    xyz["elbow"][2800:2850] = np.nan  # its last run (1.5 s) too short for the analysis
    return Truth(t, xyz, 100.0)


def test_truth_filtered_in_place_is_the_copys_bit_for_bit():
    from armtrack_cli.compare.score import denoised

    ref = denoised(_marker_truth(4), 6.0)
    own = _marker_truth(4)
    got = denoised(own, 6.0, own=True)
    for j, x in ref.xyz.items():
        assert got.xyz[j] is own.xyz[j]  # no copy
        assert np.array_equal(got.xyz[j], x, equal_nan=True)


def test_truth_markers_taken_are_the_same():
    from armtrack_cli.compare.score import truth_markers

    truth = _marker_truth(5)
    t = np.arange(0.013, 29.0, 1 / 30)
    ref = truth_markers(t, truth)
    got = truth_markers(t, truth, take=True)
    assert not truth.xyz and list(got) == list(ref)
    assert all(np.array_equal(got[k], ref[k], equal_nan=True) for k in ref)


def test_the_offset_check_first_on_a_long_truth_gives_the_same_files(tmp_path, monkeypatch):
    """A truth longer than BESIDE_MAX_SAMPLES is checked before the scoring instead of beside
    it (and every joint then filtered in place): the same bytes, the same warning."""
    import importlib
    import shutil
    import warnings

    from armtrack_cli import pipeline

    from .conftest import REPO

    pc = importlib.import_module("armtrack_cli.pipeline.compare")
    s = tmp_path / "s"
    shutil.copytree(REPO / "sample_sessions" / "circle-01", s)
    toml = s / "session.toml"
    toml.write_text(toml.read_text().replace("groundtruth_offset_s = -1.5",
                                             "groundtruth_offset_s = -1.2"))
    pipeline.run(s, through="fuse")
    files = ("errors.csv", "measures.csv", "errors.meta.json", "measures.meta.json")
    got = {}
    for most in (pc.BESIDE_MAX_SAMPLES, 0):
        monkeypatch.setattr(pc, "BESIDE_MAX_SAMPLES", most)
        with warnings.catch_warnings(record=True) as seen:
            warnings.simplefilter("always")
            pipeline.compare(s)
        assert [w for w in seen if "not the declared -1.200 s" in str(w.message)]
        got[most] = [(s / "armtrack" / f).read_bytes() for f in files]
    assert got[0] == got[pc.BESIDE_MAX_SAMPLES]


def test_truth_read_without_copies_is_the_old_forms_bit_for_bit():
    """pipeline/groundtruth.read_truth: a one-marker joint no longer copied through a mean, and
    carried into W with the offset added in place: the numbers of the old expressions."""
    from armtrack_cli.pipeline.groundtruth import read_truth
    from armtrack_cli.session.config import load_session
    from armtrack_cli.session.groundtruth import read_markers

    from .conftest import REPO

    session = load_session(REPO / "sample_sessions" / "circle-01")
    gt = session.groundtruth
    traj = read_markers(gt.file)
    got = read_truth(session, offset_s=0.25)
    assert np.array_equal(got.t, traj.t + 0.25)
    for role, name in gt.markers.items():
        mean = np.mean([traj.marker(name)], axis=0)
        ref = mean @ gt.to_world[:3, :3].T + gt.to_world[:3, 3]
        assert got.xyz[role].flags.c_contiguous
        assert np.array_equal(got.xyz[role], ref, equal_nan=True), role
