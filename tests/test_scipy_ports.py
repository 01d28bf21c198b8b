"""The numpy forms compare uses instead of scipy (so that it starts without importing scipy)
held to scipy's own functions, the independent reference: the zero-phase Butterworth
(core/butter.py) to round-off, PCHIP (measures/pchip.py), find_peaks (measures/peaks.py) and
the bounded scalar minimum (core/bounded_min.py) exactly; and Winter's residual analysis with
its early stop (compare/residual.py), a column at a time or a marker's columns side by side,
against the whole-grid form it replaced."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import PchipInterpolator
from scipy.optimize import minimize_scalar
from scipy.signal import butter, find_peaks, sosfiltfilt

from armtrack_cli.compare.residual import MIN_HZ, winter_lowpass, winter_lowpass_columns
from armtrack_cli.core.bounded_min import bounded_min
from armtrack_cli.core.butter import butter_sections, fast_len, zero_phase
from armtrack_cli.measures import peaks
from armtrack_cli.measures.pchip import pchip


def _signals(n: int, fs: float, rng) -> np.ndarray:
    t = np.arange(n) / fs
    return np.stack([0.3 * np.sin(2 * np.pi * 0.5 * t) + 0.5 + 1e-3 * rng.standard_normal(n),
                     rng.standard_normal(n), 0.01 * np.cumsum(rng.standard_normal(n))])


@pytest.mark.parametrize("fs", [30.0, 100.0, 250.0])
def test_zero_phase_butterworth_is_scipys_sosfiltfilt(fs):
    rng = np.random.default_rng(int(fs))
    for fc in (1.0, 2.25, 6.0, 0.3 * fs / 2, 0.45 * fs / 2, 0.44 * fs):
        assert np.abs(butter_sections(fc, fs) - butter(4, fc, fs=fs, output="sos")).max() < 1e-14
        for n in (16, 40, 700, 5000):
            x = _signals(n, fs, rng)
            want = sosfiltfilt(butter(4, fc, fs=fs, output="sos"), x, axis=1)
            got = next(zero_phase(x, fs, [fc]))
            assert np.abs(got - want).max() <= 1e-11 * np.abs(x).max(), (fc, n)


def test_zero_phase_many_cutoffs_one_transform():
    x = _signals(3000, 100.0, np.random.default_rng(1))
    cut = [1.0, 3.5, 20.0]
    for fc, got in zip(cut, zero_phase(x, 100.0, cut)):
        want = sosfiltfilt(butter(4, fc, fs=100.0, output="sos"), x, axis=1)
        assert np.abs(got - want).max() < 1e-12
    assert [fast_len(n) for n in (1, 7, 60031)] == [1, 8, 60750]


def test_pchip_is_scipys_bit_for_bit():
    rng = np.random.default_rng(2)
    for trial in range(200):
        n = int(rng.integers(2, 200))
        x = np.cumsum(rng.uniform(0.001, 0.05, n))
        y = np.cumsum(rng.standard_normal((n, 3)), axis=0)
        if trial % 3 == 0:
            y[rng.integers(0, n, n // 3)] = 0.5  # flat runs and turns
        xi = np.linspace(x[0], x[-1] + 1e-9, int(rng.integers(1, 300)))
        want = PchipInterpolator(x, y, axis=0)(xi)
        assert np.array_equal(pchip(x, y, xi), want)
        # a block of points at a time: each block's slopes from a window of the knots
        assert np.array_equal(pchip(x, y, xi, block=int(rng.integers(1, 40))), want)
    x = np.cumsum(rng.uniform(0.001, 0.05, 5000))  # beyond the knots, and a block of one
    y = np.cumsum(rng.standard_normal((5000, 2)), axis=0)
    xi = np.r_[x[0] - 0.3, np.sort(rng.uniform(x[0], x[-1], 3000)), x[-1] + 0.2]
    want = PchipInterpolator(x, y, axis=0)(xi)
    for block in (1, 2, 3, 999, 4096):
        assert np.array_equal(pchip(x, y, xi, block=block), want)


@pytest.mark.parametrize("grid_max, table_max", [(200_000, peaks.TABLE_MAX), (0, peaks.TABLE_MAX),
                                                 (0, 0)])  # on one grid, on tables, one by one
def test_find_peaks_is_scipys(grid_max, table_max, monkeypatch):
    monkeypatch.setattr(peaks, "GRID_MAX", grid_max)
    monkeypatch.setattr(peaks, "TABLE_MAX", table_max)
    rng = np.random.default_rng(3)
    for trial in range(1500):
        n = int(rng.integers(1, 300))
        x = [rng.standard_normal(n), np.round(2 * rng.standard_normal(n)) / 2,
             np.abs(np.sin(np.arange(n) / rng.uniform(2, 20))) + 0.05 * rng.standard_normal(n)
             ][trial % 3]
        prom, dist = float(rng.choice([0.0, 0.02, 0.3, 1.0])), int(rng.integers(1, 12))
        want = find_peaks(x, prominence=prom, distance=dist)[0]
        assert np.array_equal(peaks.find_peaks(x, prominence=prom, distance=dist), want)


def test_bounded_minimum_is_scipys():
    rng = np.random.default_rng(4)
    for trial in range(200):
        c, w = rng.uniform(-1, 1), rng.uniform(0.01, 2)
        f = [lambda x, c=c: (x - c) ** 2, lambda x, w=w: np.cos(3 * x / w) + 0.1 * x,
             lambda x, c=c: abs(x - c) ** 0.5,
             lambda x, c=c, w=w: (x - c) ** 4 - w * (x - c) ** 2][trial % 4]
        lo = rng.uniform(-2, 0)
        hi = lo + rng.uniform(0.001, 3)
        r = minimize_scalar(f, bounds=(lo, hi), method="bounded", options={"xatol": 1e-5})
        assert bounded_min(f, lo, hi, xatol=1e-5) == (r.x, r.fun)


def _winter_whole_grid(x, fs, max_hz):
    """compare/residual.py before the early stop: R over the whole grid, with scipy."""
    def res(cut):
        return np.array([np.sqrt(np.mean((x - sosfiltfilt(butter(4, fc, fs=fs, output="sos"), x))
                                         ** 2)) for fc in cut])
    nyq = fs / 2
    band = np.linspace(0.3 * nyq, 0.45 * nyq, 8)
    _, a = np.polyfit(band, res(band), 1)
    grid = np.arange(MIN_HZ, max_hz + 1e-9, 0.25)
    below = np.flatnonzero(res(grid) <= a)
    fc = float(grid[below[0]]) if below.size else max_hz
    return fc, sosfiltfilt(butter(4, fc, fs=fs, output="sos"), x)


@pytest.mark.parametrize("speed_hz", [0.1, 0.6, 2.0])
def test_winter_cutoff_and_its_filtered_copy_are_the_whole_grids(speed_hz):
    rng = np.random.default_rng(5)
    t = np.arange(0, 8, 0.01)
    x = 0.2 * np.sin(2 * np.pi * speed_hz * t) + 3e-4 * rng.standard_normal(t.size)
    fc, y = winter_lowpass(x, 100.0, max_hz=6.0)
    fc_ref, y_ref = _winter_whole_grid(x, 100.0, 6.0)
    assert fc == fc_ref
    assert np.abs(y - y_ref).max() < 1e-12


def test_winter_columns_are_each_columns_own_whole_grid():
    """A marker's coordinates side by side (compare/score.py), each filter's spectrum shared:
    each column's cut-off and filtered copy are the whole grid's with scipy (1e-12), and
    bit for bit what the column gets alone; a column that stops early, one that never reaches
    its noise level (max_hz) and one whose noise fit fails (a straight line: max_hz)."""
    rng = np.random.default_rng(8)
    t = np.arange(0, 8, 0.01)
    X = np.stack([0.2 * np.sin(2 * np.pi * 0.1 * t) + 3e-4 * rng.standard_normal(t.size),
                  0.2 * np.sin(2 * np.pi * 2.0 * t) + 3e-4 * rng.standard_normal(t.size),
                  0.05 * rng.standard_normal(t.size), 0.3 + 0.01 * t], axis=1)
    got = winter_lowpass_columns(X, 100.0, max_hz=6.0)
    assert len({fc for fc, _ in got}) >= 2
    assert got[-1][0] == 6.0
    for j, (fc, y) in enumerate(got):
        fc_ref, y_ref = _winter_whole_grid(X[:, j], 100.0, 6.0)
        assert fc == fc_ref, j
        assert np.abs(y - y_ref).max() < 1e-12
        alone = winter_lowpass_columns(X[:, j:j + 1], 100.0, max_hz=6.0)[0]
        assert alone[0] == fc and np.array_equal(alone[1], y)


def test_prominences_of_a_long_signal_are_scipys():
    """A signal longer than the sparse tables take as it stands (a 60-minute session's speed:
    108,000 samples) is cut down to its maxima and valleys first: the same prominences as
    scipy's, exactly, with flat runs and ties."""
    from scipy.signal import peak_prominences

    rng = np.random.default_rng(5)
    for trial in range(6):
        n = int(rng.integers(peaks.TABLE_MAX + 1, 120_000))
        t = np.arange(n) / 30.0
        x = [np.abs(np.sin(t / rng.uniform(0.5, 3))) + 0.02 * rng.standard_normal(n),
             np.round(2 * rng.standard_normal(n)) / 2, rng.standard_normal(n)][trial % 3]
        pk = peaks.local_maxima(x)
        assert np.array_equal(peaks.prominences(x, pk), peak_prominences(x, pk)[0])
        assert np.array_equal(peaks.find_peaks(x, prominence=0.02, distance=5),
                              find_peaks(x, prominence=0.02, distance=5)[0])


def test_gaussian_wrap_is_scipys_gaussian_filter1d():
    """measures.uncertainty.gaussian_wrap: the posterior draws' smoothing without importing
    scipy.ndimage, bit for bit, short signals (wrapped more than once) and long, any SD."""
    from scipy.ndimage import gaussian_filter1d

    from armtrack_cli.measures.uncertainty import gaussian_wrap

    rng = np.random.default_rng(6)
    for trial in range(200):
        n = int(rng.integers(1, 400)) if trial else 18_000
        sigma = float(rng.choice([0.1, 0.37, 1.0, 2.5, 15.0, 50.0, rng.uniform(0.1, 80)]))
        x = rng.standard_normal((int(rng.integers(1, 4)), n, 3))
        assert np.array_equal(gaussian_wrap(x, sigma, axis=1),
                              gaussian_filter1d(x, sigma, axis=1, mode="wrap"))
        assert np.array_equal(gaussian_wrap(x[0, :, 0], sigma, axis=0),
                              gaussian_filter1d(x[0, :, 0], sigma, mode="wrap"))
