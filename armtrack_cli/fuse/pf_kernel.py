"""The particle filters of ``methods.run_particles`` compiled with numba: the same steps, in
the same order, drawing the same random numbers from the same generator.

numba draws from a ``np.random.Generator`` with numpy's own algorithms and advances the
generator's state, so for one seed the kernel and the numpy reference see identical draws
(eps (N, 12) per frame, then the resampling uniforms); they differ only by the order of
floating-point sums (tests/test_pf_kernel.py holds them equal to 1e-12). ``cache=True``: the
compile happens once per install and is loaded from ``__pycache__`` afterwards.

Shapes: particles x (N, 6) = (p, v) in W (m, m/s); z (n_frames, 2) px, NaN = no detection.
"""

from __future__ import annotations

import numpy as np
from numba import njit

RESAMPLING = {"residual": 0, "systematic": 1, "stratified": 2, "multinomial": 3}


@njit(cache=True)
def _search_sorted_keys(cdf, u, idx, start):
    """idx[start + j] = min(#{cdf ≤ u_j}, N − 1) for sorted u: searchsorted(side="right")
    by one merge walk."""
    n, i = cdf.size, 0
    for j in range(u.size):
        while i < n and cdf[i] <= u[j]:
            i += 1
        idx[start + j] = min(i, n - 1)


@njit(cache=True)
def _sorted_uniforms(rng, k):
    """np.sort(rng.random(k)) by bucket sort, O(k) for uniforms: the same array, faster."""
    u = rng.random(k)
    start = np.zeros(k + 1, np.int64)
    for v in u:
        start[int(v * k) + 1] += 1
    for b in range(k):
        start[b + 1] += start[b]
    out = np.empty(k)
    for v in u:
        b = int(v * k)
        out[start[b]] = v
        start[b] += 1
    for i in range(1, k):  # insertion sort: out of order only within a bucket
        v, j = out[i], i - 1
        while j >= 0 and out[j] > v:
            out[j + 1] = out[j]
            j -= 1
        out[j + 1] = v
    return out


@njit(cache=True)
def _resample(w, rng, scheme, idx):
    """Ancestor indices into idx (N,), as filters/resampling.py, drawing the same uniforms."""
    n = w.size
    if scheme == 0:  # residual: floor(N w_i) copies, then R leftovers (Liu & Chen 1998)
        nw = n * (w / w.sum())
        m = 0
        for i in range(n):
            c = np.int64(nw[i])
            for _ in range(c):
                idx[m] = i
                m += 1
        k = n - m
        if k == 0:
            return
        cdf = np.cumsum(nw - np.floor(nw))
        u = _sorted_uniforms(rng, k) * cdf[-1]
        _search_sorted_keys(cdf, u, idx, m)
        return
    c = np.cumsum(w)
    cdf = c / c[-1]
    if scheme == 1:  # systematic: one offset for N evenly spaced points
        u = (np.arange(n) + rng.random()) / n
    elif scheme == 2:  # stratified: one uniform in each of N strata
        u = (np.arange(n) + rng.random(n)) / n
    else:  # multinomial, sorted draws
        u = _sorted_uniforms(rng, n)
    _search_sorted_keys(cdf, u, idx, 0)


@njit(cache=True)
def _take(x, idx, out):
    """out = x[idx] (the resampled particles)."""
    for i in range(idx.size):
        for j in range(x.shape[1]):
            out[i, j] = x[idx[i], j]


@njit(cache=True)
def _normalise(lw, w):
    """w ∝ exp(lw), normalised (Tao & Hu eq. 14 in log form); uniform if every lw = −inf."""
    m = lw.max()
    n = lw.size
    if not np.isfinite(m):
        w[:] = 1.0 / n
        return
    s = 0.0
    for i in range(n):
        w[i] = np.exp(lw[i] - m)
        s += w[i]
    for i in range(n):
        w[i] /= s


@njit(cache=True)
def _moments(x, w, mean, cov):
    """Weighted mean Σ w_i x_i (6,) and covariance Σ w_i d_i d_iᵀ (6, 6), d_i = x_i − mean,
    into mean, cov (as particles.moments; plain loops, so one core and no BLAS threads)."""
    n, dim = x.shape
    m = np.zeros(dim)
    for i in range(n):
        for a in range(dim):
            m[a] += w[i] * x[i, a]
    c = np.zeros((dim, dim))
    d = np.empty(dim)
    for i in range(n):
        for a in range(dim):
            d[a] = x[i, a] - m[a]
        for a in range(dim):
            wa = w[i] * d[a]
            for b in range(a, dim):
                c[a, b] += wa * d[b]
    mean[:] = m
    for a in range(dim):
        for b in range(a, dim):
            cov[a, b] = cov[b, a] = c[a, b]


@njit(cache=True)
def _pixel(p0, p1, p2, cam, dist):
    """π(p): OpenCV's pinhole with k1 k2 p1 p2 k3 (models.Projection) at one point in W;
    cam = (R (3, 3) row-major, T, fx, fy, cx, cy) flattened (16,)."""
    k1, k2, t1, t2, k3 = dist[0], dist[1], dist[2], dist[3], dist[4]
    X = cam[0] * p0 + cam[1] * p1 + cam[2] * p2 + cam[9]
    Y = cam[3] * p0 + cam[4] * p1 + cam[5] * p2 + cam[10]
    Z = cam[6] * p0 + cam[7] * p1 + cam[8] * p2 + cam[11]
    nx, ny = X / Z, Y / Z
    r2 = nx * nx + ny * ny
    rad = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    dx, dy = nx * rad, ny * rad
    if t1 != 0.0 or t2 != 0.0:  # tangential terms
        xy2 = 2 * nx * ny
        dx += t1 * xy2 + t2 * (r2 + 2 * nx * nx)
        dy += t2 * xy2 + t1 * (r2 + 2 * ny * ny)
    return dx * cam[12] + cam[14], dy * cam[13] + cam[15]


@njit(cache=True)
def _predict_and_weigh(x, rng, k, dt, dp, dv, ace, z, inv2s2, cam, dist, w, uniform,
                       walk_eps, lw):
    """One pass over the particles: draw their 12 standard normals (the reference's eps row),
    keep the last 6 for the walk layer; step 1, x_k ~ N(F x + b, Q) (eq. 10) with Q = L Lᵀ ⊗ I₃;
    step 2, lw_i = −|π(p_i) − z|² / 2σ² + log w_i (eq. 11) if z is seen."""
    seen = np.isfinite(z[0]) and np.isfinite(z[1])
    a, c, e = ace[k, 0], ace[k, 1], ace[k, 2]
    log_w0 = np.log(w[0])  # a uniform prior: one log for all
    eps = np.empty(6)
    for i in range(x.shape[0]):
        for j in range(6):
            eps[j] = rng.standard_normal()
        for j in range(6):
            walk_eps[i, j] = rng.standard_normal()
        if k > 0:
            for j in range(3):
                p, v = x[i, j], x[i, 3 + j]
                x[i, j] = p + v * dt[k] + dp[k, j] + a * eps[j]
                x[i, 3 + j] = v + dv[k, j] + c * eps[j] + e * eps[3 + j]
        if seen:
            u, v = _pixel(x[i, 0], x[i, 1], x[i, 2], cam, dist)
            eu, ev = u - z[0], v - z[1]
            lw[i] = -inv2s2 * (eu * eu + ev * ev) + (log_w0 if uniform else np.log(w[i]))
    return seen


@njit(cache=True)
def _walk_and_constrain(x, walk_eps, walk, centre, L1, inv2c2, lw):
    """Step 4, the random-walk layer p² (eqs. 17, 18); step 5, lw_i = −r_i² / 2σ² with
    r_i = |p_i − centre| − L1 (eq. 15 on the upper-arm length, see methods.py)."""
    for i in range(x.shape[0]):
        s = 0.0
        for j in range(6):
            x[i, j] = x[i, j] + walk_eps[i, j] * walk[j]
        for j in range(3):
            d = x[i, j] - centre[j]
            s += d * d
        r = np.sqrt(s) - L1
        lw[i] = -inv2c2 * r * r


@njit(cache=True)
def _pixel_mahalanobis2(x, w, z, cam, dist, r2):
    """robust.pixel_mahalanobis2: νᵀ S⁻¹ ν with ẑ = Σ wᵢ π(pᵢ), ν = z − ẑ,
    S = Σ wᵢ (π(pᵢ) − ẑ)(π(pᵢ) − ẑ)ᵀ + r2 I."""
    n = x.shape[0]
    px = np.empty((n, 2))
    mu, mv = 0.0, 0.0
    for i in range(n):
        px[i, 0], px[i, 1] = _pixel(x[i, 0], x[i, 1], x[i, 2], cam, dist)
        mu += w[i] * px[i, 0]
        mv += w[i] * px[i, 1]
    suu, suv, svv = r2, 0.0, r2
    for i in range(n):
        du, dv = px[i, 0] - mu, px[i, 1] - mv
        suu += w[i] * du * du
        suv += w[i] * du * dv
        svv += w[i] * dv * dv
    a, b = z[0] - mu, z[1] - mv
    return (a * (svv * a - suv * b) + b * (suu * b - suv * a)) / (suu * svv - suv * suv)


@njit(cache=True)
def _reseed(x, w_prior, points, n_seed, sigma, prior_m, rng):
    """robust.branch_split and robust.reseed: particles 0..n0−1 onto points[0], the rest of
    the n_seed onto points[1], ± sigma; n0 from the predicted cloud's density at the two."""
    m = np.empty(6)
    c = np.empty((6, 6))
    _moments(x, w_prior, m, c)
    C = c[:3, :3] + prior_m**2 * np.eye(3)
    q = np.empty(2)
    for b in range(2):
        d = points[b] - m[:3]
        q[b] = d @ np.linalg.solve(C, d)
    p0 = 1.0 / (1.0 + np.exp(min(0.5 * (q[0] - q[1]), 700.0)))
    n0 = int(np.floor(n_seed * p0 + 0.5))
    for i in range(n_seed):
        b = 0 if i < n0 else 1
        for j in range(3):
            x[i, j] = points[b, j] + sigma * rng.standard_normal()


@njit(cache=True)
def _colour_loglik(x, z, inv2s2, cam, dist, w_prior, lw):
    """lw_i = −|π(p_i) − z|² / 2σ² + log w_i (eq. 11), as in _predict_and_weigh."""
    for i in range(x.shape[0]):
        u, v = _pixel(x[i, 0], x[i, 1], x[i, 2], cam, dist)
        eu, ev = u - z[0], v - z[1]
        lw[i] = -inv2s2 * (eu * eu + ev * ev) + np.log(w_prior[i])


@njit(cache=True)
def _gate_code(d2, limit, run_gated, reacquire):
    """robust.gate: (code, run) — 1 used, 2 gated, 3 re-acquired (then a grace, run < 0)."""
    if run_gated < 0:
        return 1, run_gated + 1
    if d2 <= limit:
        return 1, 0
    if run_gated < reacquire:
        return 2, run_gated + 1
    return 3, -reacquire


@njit(cache=True)
def _roughen(x, sd, rng):
    """robust.roughen: x_ij ± sd_j for every particle (the re-acquisition's spread)."""
    for i in range(x.shape[0]):
        for j in range(6):
            x[i, j] += sd[j] * rng.standard_normal()


@njit(cache=True)
def run(x, rng, z, dt, dp, dv, ace, centres, cam, dist, walk, inv2s2, inv2c2, L1,
        constrained, scheme, resample_ess, guard):
    """methods.run_particles: steps 1-7 of Tao & Hu III-E (constrained) or the bootstrap PF
    (eqs. 12-14). x (N, 6) the initial particles (overwritten); ``guard`` = (points
    (n_frames, 2, 3), r2, gate, reacquire, n_seed, reseed_ess, reseed_sigma, prior_m, rough
    (6,)): the
    gate and the re-seeding of fuse/robust.py. Returns mean (n_frames, 6), cov
    (n_frames, 6, 6), ess (n_frames,), codes (n_frames,)."""
    points, r2, gate, reacquire, n_seed, reseed_ess, reseed_sigma, prior_m, rough = guard
    n_frames, N = z.shape[0], x.shape[0]
    mean = np.empty((n_frames, 6))
    cov = np.empty((n_frames, 6, 6))
    n_eff = np.empty(n_frames)
    codes = np.zeros(n_frames, np.int8)
    w = np.full(N, 1.0 / N)
    w_prior = np.empty(N)
    lw = np.empty(N)
    walk_eps = np.empty((N, 6))
    idx = np.empty(N, np.int64)
    xr = np.empty_like(x)
    uniform = True  # every w_i is exactly 1/N
    limit = gate if gate > 0 else np.inf
    run_gated = 0
    for k in range(n_frames):
        seen = _predict_and_weigh(x, rng, k, dt, dp, dv, ace, z[k], inv2s2, cam, dist, w,
                                  uniform, walk_eps, lw)
        if seen:  # the χ² gate
            codes[k], run_gated = _gate_code(_pixel_mahalanobis2(x, w, z[k], cam, dist, r2),
                                             limit, run_gated, reacquire)
            seen = codes[k] != 2
        if seen:
            w_prior[:] = w
            if codes[k] == 3:  # re-acquired: spread the cloud first
                _roughen(x, rough, rng)
                _colour_loglik(x, z[k], inv2s2, cam, dist, w_prior, lw)
            _normalise(lw, w)
            if constrained and n_seed > 0 and (codes[k] == 3 or 1.0 / (w @ w) < reseed_ess * N):
                _reseed(x, w_prior, points[k], n_seed, reseed_sigma, prior_m, rng)
                codes[k] = 4 if codes[k] == 1 else codes[k]
                _colour_loglik(x, z[k], inv2s2, cam, dist, w_prior, lw)
                _normalise(lw, w)
            uniform = False
        n_eff[k] = 1.0 / (w @ w)
        if constrained:
            if seen:  # step 3 (without a detection the weights are still equal)
                _resample(w, rng, scheme, idx)
                _take(x, idx, xr)
                x, xr = xr, x
            _walk_and_constrain(x, walk_eps, walk, centres[k], L1, inv2c2, lw)  # steps 4, 5
            _normalise(lw, w)
            _moments(x, w, mean[k], cov[k])
            _resample(w, rng, scheme, idx)  # step 6
        else:
            _moments(x, w, mean[k], cov[k])
            if n_eff[k] >= resample_ess * N:
                continue
            _resample(w, rng, scheme, idx)
        _take(x, idx, xr)
        x, xr = xr, x
        w[:] = 1.0 / N
        uniform = True
    return mean, cov, n_eff, codes
