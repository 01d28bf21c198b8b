"""compare a window at a time (issue 15's flat memory) against compare whole: a sample session
cut into ten windows (WINDOW_S 2 s, MARGIN_S 6 s) gives errors.csv's numbers to 1e-9 and
measures.csv byte for byte (with 3 s margins its last digits moved: the 1 Hz filter had not
decayed; core/windows' 20 s are far past that); the windowed low-pass equals the whole-run
filter; the spilled tables' search equals np.searchsorted."""

from __future__ import annotations

import csv
import shutil

import numpy as np
import pytest

from armtrack_cli import pipeline
from armtrack_cli.compare.lowpass_windows import denoised_rows, plan
from armtrack_cli.compare.score import Truth, denoised
from armtrack_cli.compare.spilled import SpilledTable
from armtrack_cli.core import windows as win
from armtrack_cli.pipeline.compare_windows import sync_span
from armtrack_cli.session.spill import Spill

from .conftest import REPO


@pytest.fixture(scope="module")
def fused(tmp_path_factory):
    """circle-01 (22 s of truth with two gaps) fused with the default method."""
    folder = tmp_path_factory.mktemp("flatcmp") / "circle-01"
    shutil.copytree(REPO / "sample_sessions" / "circle-01", folder)
    pipeline.run(folder, through="fuse")
    return folder


def _rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def _close(a: str, b: str, tol: float) -> bool:
    try:
        x, y = float(a), float(b)
    except ValueError:
        return a == b
    return (np.isnan(x) and np.isnan(y)) or abs(x - y) <= tol * max(1.0, abs(y))


def test_several_windows_give_the_one_window_numbers(fused, tmp_path, monkeypatch):
    whole = pipeline.compare(fused, out=fused / "armtrack")
    ref_err, ref_meas = (_rows(fused / "armtrack" / f) for f in ("errors.csv", "measures.csv"))
    out = tmp_path / "w"
    shutil.copytree(fused / "armtrack", out)
    monkeypatch.setattr(win, "WINDOW_S", 2.0)
    monkeypatch.setattr(win, "MARGIN_S", 6.0)
    tab_t = np.loadtxt(out / "trajectory-arm-smoother.csv", delimiter=",", skiprows=1,
                       usecols=0)
    assert len(win.windows(tab_t[0], tab_t[-1], 2.0, 6.0)) >= 4
    got = pipeline.compare(fused, out=out)
    assert got["excluded_frames"] == whole["excluded_frames"]
    assert got["groundtruth_offset_s"]["value"] == whole["groundtruth_offset_s"]["value"]
    errs = _rows(out / "errors.csv")
    assert [r["n"] for r in errs] == [r["n"] for r in ref_err]
    for a, b in zip(errs, ref_err):  # written with 6 decimals: equal but for the last digit
        assert all(_close(a[k], b[k], 2e-6) for k in a), (a, b)
    for a, b in zip(_rows(out / "measures.csv"), ref_meas):
        assert all(_close(a[k], b[k], 1e-5) for k in a), (a, b)
    assert not list(out.glob(".spill-*"))  # the spills removed


def test_pooled_window_errors_equal_the_whole_to_1e_9(fused, monkeypatch):
    """The numbers themselves (not the CSV's 6 decimals): compare's rows a window at a time."""
    whole = pipeline.compare(fused, out=fused / "armtrack")["rows"]
    monkeypatch.setattr(win, "WINDOW_S", 2.0)
    monkeypatch.setattr(win, "MARGIN_S", 6.0)
    rows = pipeline.compare(fused, out=fused / "armtrack")["rows"]
    assert len(rows) == len(whole)
    for a, b in zip(rows, whole):
        assert (a["method"], a["joint"], a["axis"], a["n"]) == \
            (b["method"], b["joint"], b["axis"], b["n"])
        for k in ("mean_cm", "std_cm", "rmse_cm", "max_abs_cm", "within_5cm_pct"):
            assert abs(a[k] - b[k]) <= 1e-9 * max(1.0, abs(b[k])), (k, a, b)
    pipeline.compare(fused, out=fused / "armtrack")  # the folder's outputs as before


def _marker(seed: int, n: int, fs: float) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    x = np.stack([0.2 * np.sin(2 * np.pi * 0.3 * t + k) for k in range(3)], axis=1)
    x += rng.normal(0, 3e-4, x.shape)  # marker noise
    for a in (1234, 9000, 9100):  # gaps: a long run, a short one between, a long one
        x[a:a + 7] = np.nan
    return x


@pytest.mark.parametrize("seed", [0, 1])
def test_windowed_denoise_equals_the_whole_capture_filter(seed, tmp_path):
    fs, n = 100.0, 30_000  # 300 s
    x = _marker(seed, n, fs)
    ref = denoised(Truth(np.arange(n) / fs, {"w": x.copy()}, fs), 6.0).xyz["w"]
    inner, margin = 3000, 2000  # 30 s windows, 20 s margins: the long runs cut in windows

    def rows(lo, hi):
        return x[lo:hi]
    runs = plan(rows, n, fs, 6.0, inner, margin)
    assert any(r.cut is not None for r in runs) and any(r.cut is None for r in runs)
    got = np.full_like(x, np.nan)
    for lo in range(0, n, 2500):
        first, last, y = denoised_rows(rows, runs, lo, min(lo + 2500, n), fs, 6.0, margin)
        got[lo:lo + 2500] = y[lo - first:lo - first + 2500]
    assert np.array_equal(np.isnan(got), np.isnan(ref))
    ok = np.isfinite(ref)
    assert np.max(np.abs(got[ok] - ref[ok])) <= 1e-9  # metres


def test_spilled_table_search_and_rows(tmp_path):
    rng = np.random.default_rng(2)
    t = np.cumsum(rng.uniform(0.001, 0.02, 20_000))
    x = rng.normal(size=(t.size, 3))
    with Spill(tmp_path) as sp:
        cuts = [0, 1, 4096, 4097, 9000, 20_000]
        tab = SpilledTable(sp, ({"t": t[a:b], "x": x[a:b]} for a, b in zip(cuts, cuts[1:])))
        assert (len(tab), tab.first, tab.last) == (t.size, t[0], t[-1])
        for q in (*rng.uniform(t[0] - 1, t[-1] + 1, 200), *t[::997], t[0], t[-1]):
            for side in ("left", "right"):
                assert tab.search(q, side) == np.searchsorted(t, q, side)
        got = tab.span(t[5000], t[12_000], extra=2)
        assert np.array_equal(got["t"], t[4998:12_003]) and np.array_equal(got["x"],
                                                                           x[4998:12_003])


def test_the_offset_span_is_one_window_at_the_middle(tmp_path):
    with Spill(tmp_path) as sp:
        tab = SpilledTable(sp, [{"t": np.arange(0.0, 3600.0, 1 / 30)}])
        a, b = sync_span(tab)
        assert b - a == pytest.approx(win.WINDOW_S + 2 * win.MARGIN_S)
        assert (a + b) / 2 == pytest.approx((tab.first + tab.last) / 2)


def test_the_offset_span_is_where_the_truth_is(tmp_path):
    """A truth that covers the first 31 minutes of a 60-minute trajectory: the span is at the
    middle of what it covers, not of the trajectory."""
    with Spill(tmp_path) as sp:
        tab = SpilledTable(sp, [{"t": np.arange(0.0, 3600.0, 1 / 30)}])
        a, b = sync_span(tab, -5.0, 1860.0)
        assert (a + b) / 2 == pytest.approx(930.0, abs=0.1) and b <= 1860.0
        assert sync_span(tab, 4000.0, 5000.0) == sync_span(tab)  # they do not meet
