"""The particle filters of ``methods.run_particles`` compiled with numba: the same steps, in
the same order, drawing the same random numbers from the same generator.

The random numbers come from filters/splitmix.py's counter-based stream, state (key, counter)
uint64 (2,), drawn many at once in SIMD; the numpy reference draws the same numbers from the
same stream (eps (12, N) per frame, (6, N) for the plain PF, then the resampling uniforms), so
kernel and reference differ only by the order of floating-point sums (tests/test_fuse_filters.py
holds them equal to 1e-12). Every work array is allocated once per run. ``cache=True``: the
compile happens once per install and is loaded from ``__pycache__`` afterwards.

Shapes: particles x (N, 6) = (p, v) in W (m, m/s), held inside as its transpose xs (6, N) so
that every pass over the particles runs along contiguous rows (SIMD); the normals likewise as
eps (12, N), the reference's draws in its order; z (n_frames, 2) px, NaN = no detection.
The gate, roughening and re-seeding of fuse/robust.py (fuse/pf_guard_kernel.py) draw their
normals after eps, in the reference's order too (tests/test_gating.py holds kernel and
reference equal with them active). The resampling schemes are in fuse/pf_resample_kernel.py,
the camera's projection π in fuse/projection_kernel.py.
"""

from __future__ import annotations

import functools

import numpy as np
from numba import njit

from armtrack_cli.filters.fast_exp import exp_nonpositive
from armtrack_cli.filters.splitmix import fill_normals_with, normals_work
from armtrack_cli.fuse.pf_guard_kernel import (
    _colour_loglik,
    _gate_code,
    _pixel_mahalanobis2,
    _ray_sphere_points,
    _reseed,
    _roughen,
)
from armtrack_cli.fuse.pf_resample_kernel import RESAMPLING, SUMS, _resample, _total
from armtrack_cli.fuse.projection_kernel import _camera_tuple, _dist_tuple, _pixel

__all__ = ["RESAMPLING", "exp_nonpositive", "fill_normals_with", "load_passes", "normals_work",
           "run"]

# error_model="numpy" everywhere: x / 0 is inf as in numpy, not Python's ZeroDivisionError,
# whose check keeps LLVM from vectorising any loop that divides

@njit(cache=True, error_model="numpy")
def _max(lw):
    """max(lw) by four running maxima (no chain of dependent compares); a NaN in lw either
    makes it NaN or is caught by the sum in _normalise."""
    m0 = m1 = m2 = m3 = -np.inf
    n = lw.size
    for i in range(0, n - 3, 4):
        m0, m1, m2, m3 = max(m0, lw[i]), max(m1, lw[i + 1]), max(m2, lw[i + 2]), max(m3, lw[i + 3])
    for i in range(n - n % 4, n):
        m0 = max(m0, lw[i])
    return max(max(m0, m1), max(m2, m3))


@njit(cache=True, error_model="numpy")
def _normalise(lw, w):
    """w ∝ exp(lw), normalised (Tao & Hu eq. 14 in log form) as particles.weights: × 1 / Σ,
    not ÷ Σ (a multiply, where a divide is eight times slower); uniform if every lw = −inf,
    or if one is NaN (as the reference, whose max is then NaN). Returns Σ w_i² (1 / ESS)."""
    m = _max(lw)
    n = lw.size
    if np.isfinite(m):
        exp_nonpositive(lw, m, w)
        s = _total(w)
        if np.isfinite(s):
            return _scale_sum_sq(w, 1.0 / s)
    w[:] = 1.0 / n
    return _sum_sq(w)


@njit(cache=True, error_model="numpy", fastmath=SUMS)
def _scale_sum_sq(w, c):
    """w ← c w; returns Σ w_i²."""
    ss = 0.0
    for i in range(w.size):
        w[i] *= c
        ss += w[i] * w[i]
    return ss


@njit(cache=True, error_model="numpy", fastmath=SUMS)
def _moments(xs, w, mean, cov, d):
    """Weighted mean Σ w_i x_i (6,) and covariance Σ w_i d_i d_iᵀ (6, 6), d_i = x_i − mean,
    into mean, cov (as particles.moments): two passes over the particles, the 21 distinct
    sums of the second in one loop (SIMD, one core, no BLAS). d (6, N) work, unused."""
    n = w.size
    m0 = m1 = m2 = m3 = m4 = m5 = 0.0
    for i in range(n):
        wi = w[i]
        m0 += wi * xs[0, i]
        m1 += wi * xs[1, i]
        m2 += wi * xs[2, i]
        m3 += wi * xs[3, i]
        m4 += wi * xs[4, i]
        m5 += wi * xs[5, i]
    mean[0], mean[1], mean[2], mean[3], mean[4], mean[5] = m0, m1, m2, m3, m4, m5
    c00 = c01 = c02 = c03 = c04 = c05 = c11 = c12 = c13 = c14 = c15 = 0.0
    c22 = c23 = c24 = c25 = c33 = c34 = c35 = c44 = c45 = c55 = 0.0
    for i in range(n):
        wi = w[i]
        d0, d1, d2 = xs[0, i] - m0, xs[1, i] - m1, xs[2, i] - m2
        d3, d4, d5 = xs[3, i] - m3, xs[4, i] - m4, xs[5, i] - m5
        e0, e1, e2, e3, e4 = wi * d0, wi * d1, wi * d2, wi * d3, wi * d4
        c00 += e0 * d0
        c01 += e0 * d1
        c02 += e0 * d2
        c03 += e0 * d3
        c04 += e0 * d4
        c05 += e0 * d5
        c11 += e1 * d1
        c12 += e1 * d2
        c13 += e1 * d3
        c14 += e1 * d4
        c15 += e1 * d5
        c22 += e2 * d2
        c23 += e2 * d3
        c24 += e2 * d4
        c25 += e2 * d5
        c33 += e3 * d3
        c34 += e3 * d4
        c35 += e3 * d5
        c44 += e4 * d4
        c45 += e4 * d5
        c55 += wi * d5 * d5
    c = (c00, c01, c02, c03, c04, c05, c11, c12, c13, c14, c15, c22, c23, c24, c25, c33,
            c34, c35, c44, c45, c55)
    t = 0
    for a in range(6):
        for b in range(a, 6):
            cov[a, b] = cov[b, a] = c[t]
            t += 1



@njit(cache=True, error_model="numpy")
def _predict(xs, eps, k, dt, dp, dv, ace):
    """Step 1, x_k ~ N(F x + b, Q) (eq. 10) with Q = L Lᵀ ⊗ I₃ from eps rows 0-5, in place."""
    a, c, e = ace[k, 0], ace[k, 1], ace[k, 2]
    for j in range(3):
        dtk, dpj, dvj = dt[k], dp[k, j], dv[k, j]
        for i in range(xs.shape[1]):
            p, v = xs[j, i], xs[3 + j, i]
            xs[j, i] = p + v * dtk + dpj + a * eps[j, i]
            xs[3 + j, i] = v + dvj + c * eps[j, i] + e * eps[3 + j, i]


@njit(cache=True, error_model="numpy")
def _gather_predict(xs, idx, shift, eps, k, dt, dp, dv, ace, out):
    """The last frame's resampled particles gathered (out = xs[:, idx], velocities moved by
    shift (3,) where it is not zero) and predicted (step 1, as _predict) in one pass: the
    gathered particle is not stored and read back."""
    a, c, e = ace[k, 0], ace[k, 1], ace[k, 2]
    for j in range(3):
        dtk, dpj, dvj, sj = dt[k], dp[k, j], dv[k, j], shift[j]
        for i in range(idx.size):
            p, v = xs[j, idx[i]], xs[3 + j, idx[i]]
            if sj != 0.0:
                v = v + sj
            out[j, i] = p + v * dtk + dpj + a * eps[j, i]
            out[3 + j, i] = v + dvj + c * eps[j, i] + e * eps[3 + j, i]


@njit(cache=True, error_model="numpy")
def _weigh(xs, z, inv2s2, cam, dist, w, uniform, lw, px):
    """Step 2, lw_i = −|π(p_i) − z|² / 2σ² + log w_i (eq. 11) if z is seen, the pixels π(p_i)
    kept in px (2, N) for the gate. Returns whether z is seen."""
    n = xs.shape[1]
    if not (np.isfinite(z[0]) and np.isfinite(z[1])):
        return False
    ct, dt5, z0, z1 = _camera_tuple(cam), _dist_tuple(dist), z[0], z[1]  # in registers
    log_w0 = np.log(w[0])  # a uniform prior: one log for all, in the same pass
    for i in range(n):
        u, v = _pixel(xs[0, i], xs[1, i], xs[2, i], ct, dt5)
        px[0, i], px[1, i] = u, v
        eu, ev = u - z0, v - z1
        lw[i] = -inv2s2 * (eu * eu + ev * ev) + log_w0
    if not uniform:
        for i in range(n):  # (plain pf between resamplings): log w_i each
            eu, ev = px[0, i] - z0, px[1, i] - z1
            lw[i] = -inv2s2 * (eu * eu + ev * ev) + np.log(w[i])
    return True




@njit(cache=True, error_model="numpy")
def _walk(xs, eps, walk):
    """Step 4, the random-walk layer p² (eqs. 17, 18) from eps rows 6-11, in place."""
    for j in range(6):
        for i in range(xs.shape[1]):
            xs[j, i] = xs[j, i] + eps[6 + j, i] * walk[j]


@njit(cache=True, error_model="numpy")
def _gather_walk(xs, idx, eps, walk, out):
    """Step 3's resampled particles gathered (out = xs[:, idx]) and walked (step 4, as _walk)
    in one pass: 2.26 → 2.05 µs with _constrain after it, 500 particles, the same numbers."""
    for j in range(6):
        wj = walk[j]
        for i in range(idx.size):
            out[j, i] = xs[j, idx[i]] + eps[6 + j, i] * wj


@njit(cache=True, error_model="numpy")
def _constrain(xs, centre, L1, inv2c2, lw):
    """Step 5, lw_i = −r_i² / 2σ² with r_i = |p_i − centre| − L1 (eq. 15 on the upper-arm
    length, see methods.py): a loop of its own, in SIMD."""
    for i in range(xs.shape[1]):
        d0, d1, d2 = xs[0, i] - centre[0], xs[1, i] - centre[1], xs[2, i] - centre[2]
        r = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2) - L1
        lw[i] = -inv2c2 * r * r







@njit(cache=True, error_model="numpy")
def _guarded_colour(xs, state, k, z, inv2s2, cam, dist, w, lw, px, codes, run_gated, guard,
                    constrained, sphere, w_prior, xr, seed_eps, m6, c6, pts):
    """methods.run_particles' step 2 after the gate (fuse/robust.py): the χ² gate on the
    predicted pixels px, then (unless gated) w ∝ w⁻ p(z | x), roughened first if it
    re-acquires, and (constrained) pf-constraint's re-seeding on the points where z's ray meets
    the wrist's sphere = (centre (3,), radius). Returns (whether z is used, run_gated, Σ w²)."""
    rays, eye, r2, gate, reacquire, n_seed, reseed_ess, reseed_sigma, prior_m, rough = guard
    after_blind = run_gated >= reacquire  # the first detection after a card: re-seed too
    codes[k], run_gated = _gate_code(_pixel_mahalanobis2(px, w, z, r2), gate, run_gated,
                                     reacquire)
    if codes[k] == 2:
        return False, run_gated, 0.0
    w_prior[:] = w
    if codes[k] == 3:  # re-acquired: spread the cloud first (xr: work)
        _roughen(xs, rough, state, xr)
        _colour_loglik(xs, z, inv2s2, cam, dist, w_prior, lw)
    ss = _normalise(lw, w)
    N = w.size
    if constrained and n_seed > 0 and (codes[k] == 3 or after_blind
                                       or 1.0 / ss < reseed_ess * N):
        _moments(xs, w_prior, m6, c6, xr)  # the predicted cloud, before the colour weights
        _ray_sphere_points(eye, rays[k], sphere[0], sphere[1], pts)
        _reseed(xs, m6, c6, pts, reseed_sigma, prior_m, state, seed_eps)
        codes[k] = 4 if codes[k] == 1 else codes[k]
        _colour_loglik(xs, z, inv2s2, cam, dist, w_prior, lw)
        ss = _normalise(lw, w)
    return True, run_gated, ss


@njit(cache=True, error_model="numpy", nogil=True)  # threads beside it (issue 15)
def run(x, state, z, dt, dp, dv, ace, centres, cam, dist, walk, inv2s2, inv2c2, L1,
        constrained, scheme, resample_ess, guard, v_ref, v_gain, cov):
    """methods.run_particles: steps 1-7 of Tao & Hu III-E (constrained) or the bootstrap PF
    (eqs. 12-14). x (N, 6) the initial particles; state (2,) the splitmix stream (advanced);
    ``guard`` = (rays (n_frames, 3), eye (3,), r2, gate, reacquire, n_seed, reseed_ess,
    reseed_sigma, prior_m, rough (6,)): the gate and the re-seeding of fuse/robust.py, the
    detections' unit rays from the camera's centre eye (models.Projection.rays; read only
    where pf-constraint re-seeds, so the plain PF's may be (0, 3)); v_ref
    (n_frames, 3), v_gain: pf-constraint's cloud moved by v_gain (v_ref_k − its mean velocity)
    after step 6 (methods.run_particles; v_ref is read only where v_gain > 0); cov
    (n_frames, 36) or (n_frames, 21): where each frame's covariance is written, whole (row
    by row) or its upper triangle (row by row: _store), the 21 numbers it has.
    Returns mean (n_frames, 6), cov, ess (n_frames,), codes (n_frames,)."""
    n_frames, N = z.shape[0], x.shape[0]
    mean = np.empty((n_frames, 6))
    c66 = np.empty((6, 6))  # a frame's covariance, then stored into cov[k]
    n_eff = np.empty(n_frames)
    xs, xr = np.ascontiguousarray(x.T), np.empty((6, N))
    w, lw = np.full(N, 1.0 / N), np.empty(N)
    eps = np.empty((12 if constrained else 6, N))
    nwork = normals_work(eps.size)
    codes = np.zeros(n_frames, np.int8)
    w_prior, px = np.empty(N), np.empty((2, N))
    seed_eps, m6, c6 = np.empty((3, guard[5])), np.empty(6), np.empty((6, 6))
    pts = np.empty((2, 3))  # a re-seeding frame's ray-sphere points
    idx, shift = np.empty(N, np.int64), np.zeros(3)
    work, start = np.empty((3, N)), np.empty(2 * N + 2, np.int64)
    uniform = True  # every w_i is exactly 1/N
    gather = False  # the last frame's resampling (idx, shift) not yet gathered
    run_gated, ss = 0, 0.0
    for k in range(n_frames):
        fill_normals_with(state, eps, nwork)  # the reference's eps (12, N)
        if gather:  # step 1 (k > 0) on the particles the last frame resampled
            _gather_predict(xs, idx, shift, eps, k, dt, dp, dv, ace, xr)
            xs, xr = xr, xs
            gather = False
        elif k > 0:
            _predict(xs, eps, k, dt, dp, dv, ace)
        seen = _weigh(xs, z[k], inv2s2, cam, dist, w, uniform, lw, px)
        if seen:  # the χ² gate, roughening and re-seeding
            seen, run_gated, ss = _guarded_colour(xs, state, k, z[k], inv2s2, cam, dist, w, lw,
                                                  px, codes, run_gated, guard, constrained,
                                                  (centres[k], L1),
                                                  w_prior, xr, seed_eps, m6, c6, pts)
        elif run_gated >= 0:  # no detection: as a gated one (robust.blind)
            run_gated += 1
        if seen:
            uniform = False
        n_eff[k] = 1.0 / (ss if seen else _sum_sq(w))  # Σ w² from the normalisation
        if constrained:
            if seen:  # step 3 (without a detection the weights are still equal), step 4
                _resample(w, state, scheme, idx, work, start)
                _gather_walk(xs, idx, eps, walk, xr)
                xs, xr = xr, xs
            else:
                _walk(xs, eps, walk)
            _constrain(xs, centres[k], L1, inv2c2, lw)  # step 5
            _normalise(lw, w)
            _moments(xs, w, mean[k], c66, xr)
            _store(c66, cov[k])
            _resample(w, state, scheme, idx, work, start)  # step 6
            for j in range(3):  # the velocity the cloud is given (methods.run_particles)
                shift[j] = v_gain * (v_ref[k, j] - mean[k, 3 + j]) if v_gain > 0.0 else 0.0
        else:
            _moments(xs, w, mean[k], c66, xr)
            _store(c66, cov[k])
            if n_eff[k] >= resample_ess * N:
                continue
            _resample(w, state, scheme, idx, work, start)
        gather = True  # in the next frame's prediction
        w[:] = 1.0 / N
        uniform = True
    return mean, cov, n_eff, codes


@njit(cache=True, error_model="numpy")
def _store(c, row):
    """The covariance c (6, 6) into row: all 36 numbers (a (36,) row) or, a (21,) row, its
    upper triangle row by row (np.triu_indices(6)'s order): copies, the same bits."""
    t = 0
    for a in range(6):
        for b in range(a if row.size == 21 else 0, 6):
            row[t] = c[a, b]
            t += 1


@njit(cache=True, error_model="numpy", fastmath=SUMS)
def _sum_sq(w):
    s = 0.0
    for i in range(w.size):  # by index: LLVM vectorises this, not numba's array iterator
        s += w[i] * w[i]
    return s


@functools.cache
def load_passes() -> None:
    """Load the passes ``run`` calls, each from its own compiled library, before ``run`` (once a
    process; callers: methods.run_particles, kernel_setup). numba links every callee into the
    caller's library and optimises the whole again; loaded from the cache, run calls those
    copies, which run slower than the passes' own code (pf-constraint, 500 particles,
    circle-01: 28,400 against 32,300 frames/s, the same numbers), and it calls the passes' own
    code where theirs is loaded first, as after a fresh compile, which makes the callees first.
    Each is called here on a tiny problem with the argument types run gives it (other types
    would load another specialisation, and run would call its copies again)."""
    n = 8
    state, k, f = np.zeros(2, np.uint64), 1, 1.0
    xs, xr, eps, px = np.zeros((6, n)), np.zeros((6, n)), np.zeros((12, n)), np.zeros((2, n))
    w, lw, v3, v6 = np.full(n, 1.0 / n), np.zeros(n), np.zeros(3), np.zeros(6)
    idx, work, start = np.zeros(n, np.int64), np.zeros((3, n)), np.zeros(2 * n + 2, np.int64)
    d3, cam = np.zeros((2, 3)), np.r_[np.eye(3).ravel(), 0.0, 0.0, 10.0, 1.0, 1.0, 0.0, 0.0]
    fill_normals_with(state, eps, normals_work(eps.size))
    _gather_predict(xs, idx, v3, eps, k, v3, d3, d3, d3, xr)
    _predict(xs, eps, k, v3, d3, d3, d3)
    _weigh(xs, v3[:2], f, cam, np.zeros(5), w, True, lw, px)
    _pixel_mahalanobis2(px, w, v3[:2], f)
    _normalise(lw, w)
    _sum_sq(w)
    _resample(w, state, k, idx, work, start)
    _gather_walk(xs, idx, eps, v6, xr)
    _walk(xs, eps, v6)
    _constrain(xs, v3, f, f, lw)
    _moments(xs, w, v6, np.zeros((6, 6)), xr)
    _store(np.zeros((6, 6)), np.zeros(21))
