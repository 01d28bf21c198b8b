"""fuse/robust.py's guards of the compiled particle filters (fuse/pf_kernel.py): the χ² gate on
the predicted pixels, the re-acquisition's roughening, and pf-constraint's re-seeding on the two
points where the detection's ray meets the wrist's sphere, each drawing its normals from the
splitmix stream (filters/splitmix.py) in the numpy reference's order (tests/test_gating.py
holds kernel and reference equal with them at work)."""

from __future__ import annotations

import numpy as np
from numba import njit

from armtrack_cli.filters.splitmix import fill_normals
from armtrack_cli.fuse.pf_resample_kernel import SUMS
from armtrack_cli.fuse.projection_kernel import _camera_tuple, _dist_tuple, _pixel

# error_model="numpy" everywhere: x / 0 is inf as in numpy, not Python's ZeroDivisionError


@njit(cache=True, error_model="numpy", fastmath=SUMS)
def _pixel_mahalanobis2(px, w, z, r2):
    """robust.pixel_mahalanobis2: νᵀ S⁻¹ ν with ẑ = Σ wᵢ π(pᵢ), ν = z − ẑ,
    S = Σ wᵢ (π(pᵢ) − ẑ)(π(pᵢ) − ẑ)ᵀ + r2 I; px (2, N) the particles' pixels."""
    n = w.size
    mu, mv = 0.0, 0.0
    for i in range(n):
        mu += w[i] * px[0, i]
        mv += w[i] * px[1, i]
    suu, suv, svv = r2, 0.0, r2
    for i in range(n):
        du, dv = px[0, i] - mu, px[1, i] - mv
        suu += w[i] * du * du
        suv += w[i] * du * dv
        svv += w[i] * dv * dv
    a, b = z[0] - mu, z[1] - mv
    return (a * (svv * a - suv * b) + b * (suu * b - suv * a)) / (suu * svv - suv * suv)


@njit(cache=True, error_model="numpy")
def _gate_code(d2, gate, run_gated, reacquire):
    """robust.gate: (code, run) — 1 used, 2 gated, 3 re-acquired (then a grace, run < 0)."""
    if run_gated < 0:
        return 1, run_gated + 1
    if gate <= 0 or d2 <= gate:
        return 1, 0
    if run_gated < reacquire:
        return 2, run_gated + 1
    return 3, -reacquire


@njit(cache=True, error_model="numpy")
def _roughen(xs, sd, state, eps):
    """robust.roughen: x_ij ± sd_j for every particle (the re-acquisition's spread); eps (6, N)
    work, filled as the reference's (6, N)."""
    fill_normals(state, eps)
    for j in range(6):
        for i in range(xs.shape[1]):
            xs[j, i] += sd[j] * eps[j, i]


@njit(cache=True, error_model="numpy")
def _colour_loglik(xs, z, inv2s2, cam, dist, w_prior, lw):
    """lw_i = −|π(p_i) − z|² / 2σ² + log w_i (eq. 11), as pf_kernel._weigh."""
    ct, dt5 = _camera_tuple(cam), _dist_tuple(dist)
    for i in range(xs.shape[1]):
        u, v = _pixel(xs[0, i], xs[1, i], xs[2, i], ct, dt5)
        eu, ev = u - z[0], v - z[1]
        lw[i] = -inv2s2 * (eu * eu + ev * ev) + np.log(w_prior[i])


@njit(cache=True, inline="always")
def _nonneg(v):
    """np.maximum(v, 0.0): v where v ≥ 0 (−0 too) or NaN, else 0."""
    return v if (v >= 0.0 or v != v) else 0.0


@njit(cache=True, error_model="numpy")
def _ray_sphere_points(eye, d, centre, radius, out):
    """robust.ray_sphere_points for one frame, into out (2, 3): where the camera ray eye + s d
    (d unit, models.Projection.rays) meets the sphere |p − centre| = radius (eq. 15), nearer
    first, never behind the camera; where it misses, its point nearest the sphere, twice. The
    operations of models.ray_sphere in its order (numpy sums three terms in order), so the
    same numbers, made only for the frames that re-seed."""
    o0, o1, o2 = eye[0] - centre[0], eye[1] - centre[1], eye[2] - centre[2]
    b = d[0] * o0 + d[1] * o1 + d[2] * o2
    oc2 = o0 * o0 + o1 * o1 + o2 * o2
    root = np.sqrt(_nonneg(b * b - (oc2 - radius * radius)))
    near, far = _nonneg(-b - root), _nonneg(-b + root)
    for j in range(3):
        out[0, j] = eye[j] + near * d[j]
        out[1, j] = eye[j] + far * d[j]


@njit(cache=True, error_model="numpy")
def _reseed(xs, m, c, points, sigma, prior_m, state, seed_eps):
    """robust.branch_split and robust.reseed: particles 0..n0−1 onto points[0], the rest of
    the n_seed = seed_eps.shape[1] onto points[1], ± sigma; n0 from the predicted cloud's
    density at the two, its weighted mean m (6,) and covariance c (6, 6). seed_eps (3, n_seed)
    work."""
    n_seed = seed_eps.shape[1]
    C = c[:3, :3] + prior_m**2 * np.eye(3)
    q = np.empty(2)
    for b in range(2):
        v = points[b] - m[:3]
        q[b] = v @ np.linalg.solve(C, v)
    p0 = 1.0 / (1.0 + np.exp(min(0.5 * (q[0] - q[1]), 700.0)))
    n0 = int(np.floor(n_seed * p0 + 0.5))
    fill_normals(state, seed_eps)  # the reference's (3, n_seed)
    for j in range(3):
        for i in range(n_seed):
            xs[j, i] = points[0 if i < n0 else 1, j] + sigma * seed_eps[j, i]
