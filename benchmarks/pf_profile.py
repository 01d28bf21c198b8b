"""Where the compiled layered PF spends a frame (make bench): each pass of fuse/pf_kernel.py
timed alone, many times over, on a cloud of N particles like circle-01's (1 cm, 5 cm/s), in
CPU µs per frame; the passes a pf-constraint frame with a detection makes, and their sum,
beside the whole kernel's time per frame measured in the same run. This is the profile that
bounds the kernel's speed: what a faster kernel would have to make cheaper."""

from __future__ import annotations

import numpy as np
from numba import njit
from timing import best_of  # noqa: I001  (benchmarks/ is on sys.path)

from armtrack_cli.filters.splitmix import fill_normals
from armtrack_cli.fuse import pf_guard_kernel as G
from armtrack_cli.fuse import pf_kernel as K


@njit
def _normals(r, s, eps, work):
    for _ in range(r):
        K.fill_normals_with(s, eps, work)


@njit
def _gather_predict(r, xs, idx, shift, eps, dt, d3, ace, out):
    for _ in range(r):
        K._gather_predict(xs, idx, shift, eps, 1, dt, d3, d3, ace, out)


@njit
def _weigh(r, xs, z, cam, dist, w, lw, px):
    for _ in range(r):
        K._weigh(xs, z, 1 / 32, cam, dist, w, True, lw, px)


@njit
def _normalise(r, lw, w):
    for _ in range(r):
        K._normalise(lw, w)


@njit
def _resample(r, w, s, idx, work, start):
    for _ in range(r):
        K._resample(w, s, 0, idx, work, start)


@njit
def _gather_walk(r, xs, idx, eps, walk, xr):
    for _ in range(r):
        K._gather_walk(xs, idx, eps, walk, xr)


@njit
def _gate(r, px, w, z):
    for _ in range(r):
        G._pixel_mahalanobis2(px, w, z, 16.0)


@njit
def _constrain(r, xs, centre, lw):
    for _ in range(r):
        K._constrain(xs, centre, 0.31, 5000.0, lw)


@njit
def _moments(r, xs, w, mean, cov, d):
    for _ in range(r):
        K._moments(xs, w, mean, cov, d)


def passes(n: int = 500, reps: int = 2000) -> list[tuple[str, int, float]]:
    """(pass, times per frame, µs per call) for a pf-constraint frame with a detection."""
    rng = np.random.default_rng(0)
    xs = np.ascontiguousarray(np.c_[rng.normal(0.3, 0.01, (n, 3)),
                                    rng.normal(0.0, 0.05, (n, 3))].T)
    s = np.array([2026, 0], np.uint64)  # a splitmix stream (key, counter)
    eps = np.empty((12, n))
    fill_normals(s, eps)
    cam = np.r_[1.0, 0, 0, 0, -1, 0, 0, 0, -1, -0.3, 0.2, 1.6, 600, 610, 320, 240]
    dist = np.array([0.1, -0.05, 0.001, -0.002, 0.01])
    dt, d3, ace = np.full(4, 1 / 30), np.zeros((4, 3)), np.full((4, 3), 1e-3)
    z, w, lw = np.array([320.0, 240.0]), np.full(n, 1 / n), -rng.uniform(0, 5, n)
    idx, xr = np.sort(rng.integers(0, n, n)), np.empty_like(xs)  # ancestors: ascending
    work, start = np.empty((3, n)), np.empty(2 * n + 2, np.int64)
    walk, centre = np.r_[np.full(3, 0.005), np.full(3, 0.01)], np.array([0.1, 0.45, 0.32])
    mean, cov = np.empty(6), np.empty((6, 6))
    px = np.ascontiguousarray(np.c_[rng.normal(320, 20, n), rng.normal(240, 20, n)].T)
    cases = [("12 standard normals per particle (SplitMix64, ziggurat)", 1, _normals,
              (s, eps, K.normals_work(eps.size))),
             ("gather the resampled particles and predict (eq. 10)", 1, _gather_predict,
              (xs, idx, np.full(3, 0.01), eps, dt, d3, ace, xr)),
             ("weigh by the detection (eq. 11)", 1, _weigh,
              (xs, z, cam, dist, w, np.empty(n), np.empty((2, n)))),
             ("normalise the weights (exp)", 2, _normalise, (lw, w)),
             ("residual resampling", 2, _resample, (w, s, idx, work, start)),
             ("χ² gate on the predicted pixels", 1, _gate, (px, w, z)),
             ("gather the resampled particles and random walk (eqs. 17, 18)", 1, _gather_walk,
              (xs, idx, eps, walk, xr)),
             ("arm constraint (eqs. 15, 16)", 1, _constrain, (xs, centre, np.empty(n))),
             ("weighted mean and covariance", 1, _moments, (xs, w, mean, cov, xr))]
    rows = []
    for name, times, fn, args in cases:
        fn(1, *args)  # compiled
        rows.append((name, times, best_of(lambda f=fn, a=args: f(reps, *a), runs=5) / reps * 1e6))
    return rows
