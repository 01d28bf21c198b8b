"""fuse/drift_ls.py (the IMU offset fit's banded drift columns) against the dense least
squares it replaces: the same design built densely from scipy's spline basis and solved by
numpy's lstsq, and the lazy pipeline package's imports."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from scipy.interpolate import BSpline

from armtrack_cli.fuse import drift_ls
from armtrack_cli.fuse.drift_ls import (
    Drift,
    SplineRows,
    banded_solver,
    fit_bordered,
    normal_parts,
)


def _problem(n=400, seed=3):
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0, 20, n))
    k = 4
    inner = np.linspace(t[0], t[-1], 11)
    knots = np.r_[[inner[0]] * k, inner, [inner[-1]] * k]
    B = BSpline.design_matrix(t, knots, k).tocsr()
    J = rng.normal(0, 300, (n, 2, 3))
    v, y = rng.normal(0, 1, (n, 2)), rng.normal(0, 1, (n, 2))
    dense = np.hstack([(J[:, :, a, None] * B.toarray()[:, None, :]).reshape(2 * n, -1)
                       for a in range(3)])  # columns axis-major: a·m + j
    return SplineRows.from_csr(B, k + 1), J, v, y, dense, B.shape[1]


CHUNKS = [drift_ls.CHUNK, 37]  # one chunk, and the frames 37 at a time (the products' sums)


@pytest.mark.parametrize("chunk", CHUNKS)
def test_products_and_gram_equal_the_dense_design(chunk, monkeypatch):
    monkeypatch.setattr(drift_ls, "CHUNK", chunk)
    rows, J, v, y, dense, m = _problem()
    D = Drift(rows, J)
    perm = np.array([a * m + j for j in range(m) for a in range(3)])  # to column 3j + a
    Dd = dense[:, perm]
    assert np.allclose(D.t(y), Dd.T @ y.ravel(), rtol=1e-12, atol=1e-9)
    theta = np.random.default_rng(1).normal(size=3 * m)
    assert np.allclose(D.times(theta).ravel(), Dd @ theta, rtol=1e-12, atol=1e-9)
    ab, Dy, yy = normal_parts(D, y)
    G = Dd.T @ Dd
    U = ab.shape[0] - 1
    for i in range(3 * m):  # the upper band holds G; G is zero beyond it
        for j in range(i, 3 * m):
            assert abs((ab[U + i - j, j] if j - i <= U else 0.0) - G[i, j]) <= 1e-9 * abs(G).max()
    x = banded_solver(ab)(Dy)
    assert np.allclose((G + 1e-9 * np.eye(3 * m)) @ x, Dy, rtol=1e-9, atol=1e-9 * abs(Dy).max())
    assert yy == np.sum(y * y)


@pytest.mark.parametrize("chunk", CHUNKS)
def test_fit_with_scale_is_the_least_squares_residual(chunk, monkeypatch):
    monkeypatch.setattr(drift_ls, "CHUNK", chunk)
    rows, J, v, y, dense, m = _problem()
    X = np.hstack([v.reshape(-1, 1), dense])
    theta, *_ = np.linalg.lstsq(X, y.ravel(), rcond=None)
    r = fit_bordered(Drift(rows, J), v[:, :, None], y)  # the scale's one column
    assert np.allclose(r.ravel(), y.ravel() - X @ theta, atol=1e-7)
    E = np.random.default_rng(5).normal(0, 1, (v.shape[0], 2, 3))  # three dense columns
    X = np.hstack([E.reshape(-1, 3), dense])
    theta, *_ = np.linalg.lstsq(X, y.ravel(), rcond=None)
    r = fit_bordered(Drift(rows, J), E, y)
    assert np.allclose(r.ravel(), y.ravel() - X @ theta, atol=1e-7)
    used = np.random.default_rng(6).random(v.shape[0]) > 0.3  # on some frames: their rows
    X = np.hstack([E[used].reshape(-1, 3), dense.reshape(-1, 2, dense.shape[1])[used].reshape(
        -1, dense.shape[1])])
    theta, *_ = np.linalg.lstsq(X, y[used].ravel(), rcond=None)
    r = fit_bordered(Drift(rows, J, used), E[used], y[used])
    assert np.allclose(r.ravel(), y[used].ravel() - X @ theta, atol=1e-7)


def test_frame_sets_add_up():
    """normal_parts over a set of frames is the sum over any split of it (the grid's update)."""
    rows, J, v, y, _, _ = _problem()
    a = np.arange(rows.start.size) % 3 == 0
    whole, first, second = (normal_parts(Drift(rows, J, m), y[m])
                            for m in (np.ones_like(a), a, ~a))
    for w, f, s in zip(whole, first, second):
        assert np.allclose(w, f + s, rtol=1e-12, atol=1e-6)


def test_a_stage_imports_only_its_own_libraries():
    """armtrack_cli.pipeline loads each stage on first use: loading detect brings no numba
    (its detectors import their compiled kernels when made), no scipy.signal, no matplotlib
    (each stage in its own process holds only its own)."""
    code = ("import sys; from armtrack_cli import pipeline; pipeline.detect; pipeline.calibrate; "
            "print(' '.join(m for m in ('numba', 'scipy.signal', 'matplotlib') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""
    code = ("from armtrack_cli.pipeline.fuse import prepare; from armtrack_cli import pipeline; "
            "print(callable(pipeline.fuse) and pipeline.fuse.__module__)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "armtrack_cli.pipeline.fuse"  # the stage, not its module


def test_the_fuse_stage_loads_its_table_and_fitting_libraries_on_use():
    """Importing the fuse stage loads neither pandas (read and written tables only) nor
    scipy's interpolate, optimize and signal (the IMU offset check only): a process holds
    each library only from the step that needs it (issue 15)."""
    code = ("import sys; from armtrack_cli import pipeline; pipeline.fuse; print(' '.join(m for m "
            "in ('pandas', 'scipy.interpolate', 'scipy.optimize', 'scipy.signal') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""
