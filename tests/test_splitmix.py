"""filters/splitmix.py, the counter-based stream the particle filters draw from: SplitMix64's
published outputs, the kernels' draws equal to the numpy reference's (what makes the compiled
filters equal their reference), and the normals and uniforms distributed as they must be."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from armtrack_cli.filters import splitmix

# SplitMix64 seeded with 1234567: its first five outputs, as published with the reference C
# code (Vigna, prng.di.unimi.it/splitmix64.c) and used as its test vector
SPLITMIX_1234567 = [6457827717110365317, 3203168211198807973, 9817491932198370423,
                    4593380528125082431, 16408922859458223821]


def test_raw_draws_are_splitmix64():
    s = np.array([1234567, 0], np.uint64)
    assert splitmix._raw_np(s, 5).tolist() == SPLITMIX_1234567
    assert s[1] == 5


@pytest.mark.parametrize("key", [0, 2**64 - 12345])
def test_kernel_normals_are_the_references(key):
    """2.4 million draws, so about 30,000 take the ziggurat's slow path and a few hundred its
    tail: the fast path's normals bit for bit, the slow path's within 2 ulp (the kernel's exp
    and log1p are libm's, numpy's its own), the stream advanced alike."""
    a, b = np.array([key, 3], np.uint64), np.array([key, 3], np.uint64)
    out = np.empty((12, 200_000))
    splitmix.fill_normals(a, out)
    ref = splitmix.normals(b, (12, 200_000))
    np.testing.assert_array_equal(a, b)
    assert np.all(np.abs(out - ref) <= 2 * np.spacing(np.abs(ref)))
    assert (out == ref).mean() > 0.999
    assert (np.abs(ref) > splitmix._R).sum() > 100  # the tail was exercised
    odd = np.empty(13)  # not a multiple of the kernel's blocks of 8
    splitmix.fill_normals(a, odd)
    np.testing.assert_array_equal(odd, splitmix.normals(b, 13))


def test_kernel_uniforms_are_the_references():
    a, b = np.array([7, 0], np.uint64), np.array([7, 0], np.uint64)
    out = np.empty(100_001)
    splitmix.fill_random(a, out)
    assert np.array_equal(out, splitmix.uniforms(b, 100_001))
    assert splitmix.random(a) == splitmix.Stream(b).random()
    np.testing.assert_array_equal(a, b)


def test_uniforms_float_conversion_is_exact_at_its_edges():
    """fill_random's float of a 53-bit integer from its two 32-bit halves' bits equals
    Python's exact int → float where random draws seldom go: 0, the halves' carries, 2⁵² and
    the largest 53-bit value."""
    edges = [0, 1, 2**32 - 1, 2**32, 2**32 + 1, 2**52 - 1, 2**52, 2**52 + 1, 2**53 - 2,
             2**53 - 1, 0x15555555555555]
    for v in edges:
        assert splitmix._exact_float(np.uint64(v)) == float(v), v


def test_normals_are_standard_normal():
    """Against the closed form: 1.2 million draws, mean, variance, skewness and excess
    kurtosis within 5 standard errors, the mass beyond ±1, ±2, ±3 and ±4 within 5 binomial SDs
    of the normal's, and a KS test."""
    x = splitmix.normals(np.array([2026, 0], np.uint64), 1_200_000)
    n = x.size
    assert abs(x.mean()) < 5 / np.sqrt(n)
    assert abs(x.var() - 1) < 5 * np.sqrt(2 / n)
    assert abs(stats.skew(x)) < 5 * np.sqrt(6 / n)
    assert abs(stats.kurtosis(x)) < 5 * np.sqrt(24 / n)
    for t in (1.0, 2.0, 3.0, 4.0):
        p = 2 * stats.norm.sf(t)
        assert abs((np.abs(x) > t).mean() - p) < 5 * np.sqrt(p * (1 - p) / n), t
    assert stats.kstest(x, "norm").pvalue > 1e-3


def test_the_two_normals_of_a_draw_are_independent():
    """Each raw draw gives two normals (its 32-bit halves): 500,000 pairs, their correlation
    and that of their squares within 5 standard errors of 0 (1 / √n), and their joint law on a
    10 × 10 grid of the normal's deciles uniform (χ²)."""
    x = splitmix.normals(np.array([31, 0], np.uint64), 1_000_000)
    lo, hi = x[0::2], x[1::2]
    se = 1 / np.sqrt(lo.size)
    assert abs(np.corrcoef(lo, hi)[0, 1]) < 5 * se
    assert abs(np.corrcoef(lo**2, hi**2)[0, 1]) < 5 * se
    edges = stats.norm.ppf(np.linspace(0, 1, 11)[1:-1])
    cells = np.bincount(np.digitize(lo, edges) * 10 + np.digitize(hi, edges), minlength=100)
    assert stats.chisquare(cells).pvalue > 1e-3


def test_the_tail_is_the_normals_tail():
    """Words whose fast path lands in the base strip beyond R (layer 0): every one must give
    |x| > R, distributed as the normal's tail, P(|X| > R + s | |X| > R) (KS on 20,000): a
    failed exponential pair draws again in the tail, it does not start over (which gives
    values inside R and left the mass beyond R 7 % short). Kernel and reference alike."""
    rng = np.random.default_rng(8)
    n = 20_000
    ki0 = int(splitmix._KI[0])
    rabs = rng.integers(ki0, 2**23, n, dtype=np.uint64)
    w = (rabs << np.uint64(9)) | (rng.integers(0, 2, n, dtype=np.uint64) << np.uint64(8))
    key, h = rng.integers(0, 2**63, n, dtype=np.uint64), rng.integers(0, 2, n, dtype=np.uint64)
    x = splitmix._slow_np(key, h, w.copy())
    R = splitmix._R
    assert np.all(np.abs(x) > R)
    assert stats.kstest(np.abs(x), lambda v: 1 - stats.norm.sf(v) / stats.norm.sf(R)).pvalue > 1e-3
    assert abs(np.mean(x > 0) - 0.5) < 5 * np.sqrt(0.25 / n)
    kernel = [splitmix._slow(key[i], h[i], w[i]) for i in range(200)]
    assert np.all(np.abs(np.array(kernel) - x[:200]) <= 2 * np.spacing(np.abs(x[:200])))


def test_uniforms_are_uniform():
    u = splitmix.uniforms(np.array([99, 0], np.uint64), 1_000_000)
    assert u.min() >= 0.0 and u.max() < 1.0
    counts = np.bincount((u * 100).astype(int), minlength=100)
    assert stats.chisquare(counts).pvalue > 1e-3


def test_the_counter_is_the_only_state():
    """Draw c depends on c alone: drawing in two pieces gives the draws of one piece (each
    piece even: n normals take ⌈n / 2⌉ raw draws, two a draw)."""
    s = np.array([5, 0], np.uint64)
    whole = splitmix.normals(s.copy(), 1000)
    first = splitmix.normals(s, 400)
    assert s[1] == 200
    np.testing.assert_array_equal(np.r_[first, splitmix.normals(s, 600)], whole)
    splitmix.normals(s, 7)
    assert s[1] == 504


def test_work_arrays_reused_give_the_references_draws():
    """The kernel makes fill_normals' work once per run and reuses it every frame: what one
    call leaves in it must not change the next call's draws (2 × 60,000, ~800 slow paths)."""
    a, b = np.array([11, 0], np.uint64), np.array([11, 0], np.uint64)
    out = np.empty((12, 5000))
    work = splitmix.normals_work(out.size)
    for _ in range(2):
        splitmix.fill_normals_with(a, out, work)
        ref = splitmix.normals(b, out.shape)
        assert np.all(np.abs(out - ref) <= 2 * np.spacing(np.abs(ref)))
    np.testing.assert_array_equal(a, b)
