"""The particle kernel's own arithmetic against numpy: its SIMD exp against np.exp (to 2 ulp),
its normalisation of log-weights against filters.particles.weights (the reference's),
including the degenerate cases (every weight impossible, a NaN)."""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.filters.particles import weights
from armtrack_cli.fuse import pf_kernel


def test_exp_is_numpys_to_two_ulp():
    rng = np.random.default_rng(0)
    x = np.r_[-rng.uniform(0, 700, 200_000), -rng.uniform(0, 1, 1000), 0.0, -1e-300, -np.log(2)]
    out = np.empty_like(x)
    pf_kernel.exp_nonpositive(x, 0.0, out)
    ref = np.exp(x)
    assert np.all(np.abs(out - ref) <= 2 * np.spacing(ref))


def test_exp_edges():
    x = np.array([-745.5, -800.0, -np.inf, np.nan, 3.0])
    out = np.empty_like(x)
    pf_kernel.exp_nonpositive(x, 3.0, out)  # exp(x − 3)
    assert out[0] == out[1] == out[2] == 0.0
    assert np.isnan(out[3])
    assert out[4] == 1.0


@pytest.mark.parametrize("case", ["spread", "one dominates", "all impossible", "some impossible",
                                  "a nan", "n not a multiple of 4"])
def test_normalise_is_the_references_weights(case):
    rng = np.random.default_rng(1)
    lw = -rng.uniform(0, 40, 503 if case == "n not a multiple of 4" else 500)
    if case == "one dominates":
        lw[17] = 5.0
    elif case == "all impossible":
        lw[:] = -np.inf
    elif case == "some impossible":
        lw[::3] = -np.inf
    elif case == "a nan":
        lw[250] = np.nan
    w = np.empty_like(lw)
    pf_kernel._normalise(lw, w)
    np.testing.assert_allclose(w, weights(lw), rtol=1e-14, atol=0)  # NaN: uniform, as there


def _weights(case, n, rng):
    if case == "spread":
        w = rng.gamma(0.5, size=n)
    elif case == "one dominates":
        w = np.full(n, 1e-9)
        w[n // 3] = 1.0
    elif case == "many zero":
        w = rng.gamma(0.5, size=n) * (rng.random(n) < 0.1)
        w[n // 2] += 0.1  # not all zero
    else:  # "ties": exact multiples of 1/n, every fractional part zero but a few
        w = rng.integers(0, 3, n).astype(float)
        w[:3] += 0.25
    return w / w.sum()


@pytest.mark.parametrize("scheme", list(pf_kernel.RESAMPLING))
@pytest.mark.parametrize("case", ["spread", "one dominates", "many zero", "ties"])
def test_resampling_kernel_is_the_references(scheme, case):
    """The kernel's ancestor indices are filters/resampling.py's, index for index, for the
    same stream of uniforms (residual's counted draws too), and the stream ends alike. (Not
    for weights whose N w_i fall on integers up to round-off, e.g. all equal: there the
    kernel's sum of the weights, in another order, may floor one the other way.)"""
    from armtrack_cli.filters import splitmix
    from armtrack_cli.filters.resampling import SCHEMES
    from armtrack_cli.fuse.pf_resample_kernel import _resample

    rng = np.random.default_rng(4)
    for n in (10, 333, 2000):
        w = _weights(case, n, rng)
        a, b = np.array([n, 11], np.uint64), np.array([n, 11], np.uint64)
        idx, work, start = np.empty(n, np.int64), np.empty((3, n)), np.empty(2 * n + 2, np.int64)
        _resample(w, a, pf_kernel.RESAMPLING[scheme], idx, work, start)
        np.testing.assert_array_equal(idx, SCHEMES[scheme](w, splitmix.Stream(b)))
        np.testing.assert_array_equal(a, b)


def test_each_layer_needs_six_normals_per_particle():
    """Why a pf-constraint frame draws 12 normals per particle: no draw of lower rank has the
    same law. The prediction's Q = L Lᵀ ⊗ I₃ is the closed form q [[Δ³/3, Δ²/2], [Δ²/2, Δ]] of
    white-noise acceleration over Δ (each axis), whose determinant q² Δ⁴ / 12 > 0: rank 2 per
    axis, 6 in all (the paper's eq. 6 drives 3-D noise through [Δ³/6, Δ²], rank 3, but that is
    not the model the filters share); the random walk (eqs. 17, 18) is diagonal, rank 6."""
    from armtrack_cli.fuse.models import Steps

    q, dt = 0.3, np.array([0.0, 1 / 30, 1 / 25])
    st = Steps(dt, np.zeros((3, 3)), np.zeros((3, 3)), q)
    for d, (a, c, e) in zip(dt[1:], st.noise_factors()[1:], strict=True):
        L = np.array([[a, 0.0], [c, e]])
        np.testing.assert_allclose(L @ L.T, q * np.array([[d**3 / 3, d**2 / 2], [d**2 / 2, d]]),
                                   rtol=1e-12)
        assert np.isclose(np.linalg.det(L @ L.T), q**2 * d**4 / 12, rtol=1e-9)
        assert np.linalg.matrix_rank(np.kron(L @ L.T, np.eye(3)), tol=1e-12 * q * d) == 6
