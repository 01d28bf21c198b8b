"""The IMU's clock offset, estimated from the data ([sync] imu_offset_s = "auto"): the δ, with
session time = IMU time + δ, that lines the IMU's motion up with the wrist patch's image
motion, and its standard deviation.

Velocities, not accelerations: the image velocity is exactly u̇ = J v (J = ∂π/∂p, eq. 7),
while the image acceleration also holds −2 (Ż/Z) u̇, which a time shift would absorb. So the
patch's image velocity u̇_k (a cubic Savitzky–Golay derivative of the detections) is fitted
by c V_k(δ) + J_k d(t_k), where V_k(δ) = J_k v(t_k − δ) is the IMU's integrated world
acceleration (eq. 4; a cubic Hermite curve through the integral, so smooth in δ) projected
into the image and smoothed alike; c > 0 absorbs the approximate range; d is the
integration's drift, a quartic spline with knots KNOT_S apart, plus J_k (∫R_WB dt) β for the
accelerometer's bias β in B (it turns with the forearm, so its drift is not smooth). The
orientation is the gyro-anchored one (fuse/gyro_orientation.py, done by the caller): the
reported orientation's ~1° error wanders at 0.02–0.2 Hz, and its gravity leak (up to
0.17 m/s²) drifts the integral at the very frequencies of a slow circle's motion, which a
spline loose enough to absorb it absorbs too (a circle's timing was lost to 25 ms); with the
gyro, the leak is one constant, and a stiff spline keeps the motion's timing.
J_k is taken where the detection's ray meets the
arm's sphere (eq. 15, the IMU's orientation at t_k − δ). Cost: the fit's mean squared
residual over the frames both cover. A grid at one frame period over the search window (scored
every COARSE periods, then at every period about the best of those) finds
the basin; a bounded scalar search over ± REFINE_FRAMES periods refines it on fixed frames,
stopping within XATOL_S. A session of ROUGH_MIN_S or more has the grid's coarse pass scored on
ROUGH_WINDOWS windows spread over it (two minutes in all: the basin is as clear there), the
fine pass and the refinement on every frame.
SD: from the curvature of the residual sum of squares (profiled over c and d; the three sums
from the cost's normal equations, one factorisation), inflated by
(1 + ρ)/(1 − ρ) for the residuals' lag-1 autocorrelation ρ (compare/sync.py does the same).
The drift's columns have K = DRIFT_DEGREE + 1 non-zeros per frame and axis, so the fits are
banded least squares (fuse/drift_ls.py), linear in the session's length in time. Memory: the
columns at δ, the rays, their Jacobians and every product are formed CHUNK frames at a time
(the sums WᵀW, Wᵀy, DᵀW, DᵀD carried across chunks); what is kept whole is ∫a dt and ∫R dt at
the IMU's samples (96 bytes a sample) and the Jacobians, image velocities and drift rows at the
frames (about 110 bytes a frame): 45 MB at 60 minutes, where the whole-session temporaries
peaked near 160 MB (issue 15). A declared offset's check on a long session scores only its
most informative windows (fuse/sync_windows.py): the problem is then cut into stretches
(SyncProblem.frame_cuts, imu_cuts), each with its own smoothing, drift spline, integrals and
chain of rays, sharing δ, the scale and the bias; its cost and memory are the windows'.

Missing detections are missing: lost runs up to BRIDGE_S are bridged for the derivative
only, a window holding a longer loss gives no image velocity; an IMU gap longer than GAP_S
gives no IMU velocity. Measured in docs/validation-sync.md.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from armtrack_cli.core import quaternion as quat
from armtrack_cli.core.bounded_min import bounded_min
from armtrack_cli.core.curves import bspline_rows, hermite
from armtrack_cli.core.grid_search import coarse_to_fine
from armtrack_cli.fuse import models
from armtrack_cli.fuse.drift_ls import (
    CHUNK,
    RIDGE,
    Drift,
    SplineRows,
    banded_solver,
    fit_bordered,
    normal_parts,
)
from armtrack_cli.fuse.imu_fold import rotation_integral
from armtrack_cli.fuse.sync_rays import ray_jacobians, wrist_on_rays  # noqa: F401 (tests')
from armtrack_cli.fuse.sync_signal import bridge, joined, savgol_cut, stretches

WINDOW_S = 0.5  # Savitzky–Golay window (cubic): keeps motion below ~2 Hz
KNOT_S = 6.0  # s between the drift spline's knots: the gyro-anchored orientation's leak is
#               nearly constant; the motion's timing (a circle's lap: ~6 s) lies above
DRIFT_DEGREE = 4  # quartic: the integral of a cubic spline acceleration error
GAP_S = 0.1  # an IMU gap longer than this is missing, not interpolated across
BRIDGE_S = 0.1  # detections lost for at most this long are bridged for the derivative
MIN_OVERLAP = 0.5  # share of the frames with an image acceleration that must be scored
MIN_FRAMES = 30
COARSE = 3  # the grid is scored every COARSE frame periods, then finely about the best
REFINE_FRAMES = 3  # the refinement searches the grid's best ± this many frame periods
XATOL_S = 1e-4  # … and stops with δ within this (Brent's xatol): a fifth of the smallest SD
#                 seen (0.56 ms, the 10-minute bench session); 1e-5 took four more costs
ROUGH_MIN_S = 240.0  # a session this long has the grid's coarse pass scored on
ROUGH_WINDOWS = 8  # … this many windows
ROUGH_WINDOW_S = 15.0  # … of this length, evenly spread (2 minutes in all)
REPREPARE = 3  # at most this many refinements, each with the depths and bias columns at its δ


@dataclass(frozen=True)
class ImuOffset:
    estimate_s: float  # δ: session time = IMU time + δ
    sd_s: float
    frames: int  # frames scored at the estimate


@dataclass(frozen=True)
class SyncProblem:
    """The IMU on its own clock and the camera on the session clock."""

    t_imu: np.ndarray  # (M,) s, IMU clock, valid samples only
    a_W: np.ndarray  # (M, 3) m/s², gravity removed (eq. 4)
    q_WB: np.ndarray  # (M, 4), (w, x, y, z) B into W
    t_frames: np.ndarray  # (n,) s, session clock
    uv: np.ndarray  # (n, 2) px, NaN = no detection
    proj: models.Projection
    arm: models.Arm | None
    frame_cuts: tuple[int, ...] = ()  # frames where a new stretch starts (a check's windows,
    #                                  fuse/sync_windows.py): smoothing, bridging and the drift's
    #                                  spline stop there; () = one stretch
    imu_cuts: tuple[int, ...] = ()  # IMU samples where a new stretch starts: its integrals
    #                                (velocity, ∫R dt) start again from zero there


@dataclass(frozen=True)
class _Prepared:
    vel_img: np.ndarray  # (n, 2) px/s, the detections' velocity (NaN = none)
    J: np.ndarray  # (n, 2, 3) px/m
    drift: SplineRows  # (n, m) the drift's spline basis at the frames
    rint: np.ndarray  # (M, 3, 3) s: ∫R_WB dt on the IMU's clock (a bias in B's velocity)
    v_imu: np.ndarray  # (M, 3) m/s, ∫ a_W dt at the IMU's samples (trapezoidal); between
    #                    them the cubic Hermite curve with dv/dt = a_W (``hermite``)
    dt: float  # frame period, s
    window: int


def _prepare(p: SyncProblem, delta: float, like: _Prepared | None = None) -> _Prepared:
    """The fit's parts at δ; given ``like`` (another δ's), only the Jacobians (the rays'
    depths move with δ), the rest shared with it: one copy of the per-sample arrays."""
    J = ray_jacobians(p, delta)
    if like is not None:
        return replace(like, J=J)
    dt = float(np.median(np.diff(p.t_frames)))
    window, most = max(5, int(round(WINDOW_S / dt)) | 1), int(round(BRIDGE_S / dt))
    frames, samples = stretches(p.frame_cuts, p.t_frames.size), stretches(p.imu_cuts, p.t_imu.size)
    vel = savgol_cut(joined([bridge(p.uv[a:b], most) for a, b in frames]), p.frame_cuts,
                      window, 1, dt)
    v_imu = joined([np.vstack([np.zeros((1, 3)), np.cumsum(
        0.5 * (p.a_W[a + 1:b] + p.a_W[a:b - 1]) * np.diff(p.t_imu[a:b])[:, None], axis=0)])
        for a, b in samples])
    rint = joined([rotation_integral(p.t_imu[a:b], p.q_WB[a:b]) for a, b in samples])
    return _Prepared(vel, J, _spline_basis(p.t_frames, frames), rint, v_imu, dt, window)


def _spline_basis(t: np.ndarray, frames: list[tuple[int, int]]) -> SplineRows:
    """(n, m) quartic B-splines, knots KNOT_S apart over each stretch of t (``frames``), a
    stretch's functions its own: the integrals of cubic splines (plus a constant), i.e. the
    velocity drift of a smoothly varying acceleration error."""
    k, m, rows = DRIFT_DEGREE, 0, []
    for a, b in frames:
        u = t[a:b]
        inner = np.linspace(u[0], u[-1], max(2, int(np.ceil((u[-1] - u[0]) / KNOT_S)) + 1))
        knots = np.r_[[inner[0]] * k, inner, [inner[-1]] * k]
        # k + 1 non-zeros a row, kept as such (fuse/drift_ls.py): dense, a 60-minute
        # session's basis would be 1.6 GB
        start, w = bspline_rows(np.clip(u, inner[0], inner[-1]), knots, k)
        rows.append((start + m, w))
        m += knots.size - k - 1
    return SplineRows(joined([r[0] for r in rows]), joined([r[1] for r in rows]), m)


def _imu_covers(p: SyncProblem, t: np.ndarray) -> np.ndarray:
    """(k,) bool: IMU times t inside the recording and not across a gap longer than GAP_S."""
    j = np.clip(np.searchsorted(p.t_imu, t, side="right"), 1, p.t_imu.size - 1)
    return (t >= p.t_imu[0]) & (t <= p.t_imu[-1]) & (p.t_imu[j] - p.t_imu[j - 1] <= GAP_S)


def _lerp(t: np.ndarray, y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """y (M, …) linearly interpolated at x (k,) inside [t[0], t[-1]] (np.interp's formula, on
    every column at once)."""
    j = np.clip(np.searchsorted(t, x, side="right") - 1, 0, t.size - 2)
    f = ((x - t[j]) / (t[j + 1] - t[j])).reshape((-1,) + (1,) * (y.ndim - 1))
    return y[j] + f * (y[j + 1] - y[j])


def columns(p: SyncProblem, pre: _Prepared, delta: float, sl: slice = slice(None)
            ) -> np.ndarray:
    """W(δ) (k, 2, 4) px/s at the frames ``sl``, smoothed as the image side is (within each
    stretch: SyncProblem.frame_cuts): V(δ) = J_k
    v(t_k − δ), the IMU's integrated velocity at t_k − δ (smooth in δ; NaN outside the
    recording or across a gap longer than GAP_S) projected by J_k (eq. 7's Jacobian: u̇ = J v
    exactly); and J_k ∫R_WB dt per unit accelerometer bias β in B at t_k − δ (eq. 4: a bias
    in B turns with the forearm, so its velocity error is not a smooth drift)."""
    t = p.t_frames[sl] - delta
    v = hermite(p.t_imu, pre.v_imu, p.a_W, t)
    v[~_imu_covers(p, t)] = np.nan
    at = _lerp(p.t_imu, pre.rint, np.clip(t, p.t_imu[0], p.t_imu[-1]))  # (k, 3, 3)
    W = pre.J[sl] @ np.concatenate([v[:, :, None], at], axis=2)  # (k, 2, 4)
    a, b, _ = sl.indices(p.t_frames.size)
    cuts = tuple(k - a for k in p.frame_cuts if a < k < b)
    return savgol_cut(W.reshape(-1, 8), cuts, pre.window, 0, pre.dt).reshape(-1, 2, 4)


def _chunks(p: SyncProblem, pre: _Prepared, delta: float, spans=None):
    """(a, b, W, usable) for CHUNK frames a … b − 1 at a time (or for each (a, b) of ``spans``):
    W (b − a, 2, 4) the IMU's columns at δ, V(δ) and the bias's three, and the frames
    scorable. Each chunk is formed with the smoothing's half window either side, so its values
    are the whole session's (its stretch's: SyncProblem.frame_cuts): memory bounded however
    long the session (issue 15)."""
    n, h = p.t_frames.size, pre.window // 2
    for a, b in spans or quat.row_spans(n, CHUNK):
        sl = slice(max(a - h, 0), min(b + h, n))
        W = columns(p, pre, delta, sl)[a - sl.start:b - sl.start]
        yield a, b, W, np.isfinite(W).all(axis=(1, 2)) & np.isfinite(pre.vel_img[a:b]).all(axis=1)


def _rough_spans(p: SyncProblem, pre: _Prepared) -> list[tuple[int, int]] | None:
    """ROUGH_WINDOWS windows of ROUGH_WINDOW_S, evenly spread over the session, for the
    grid's coarse pass (which only picks the basin; the fine pass and the refinement score
    every frame); None for a session shorter than ROUGH_MIN_S (all of it is scored), or cut
    into stretches (a check's windows: already short)."""
    n = p.t_frames.size
    if p.frame_cuts or p.t_frames[-1] - p.t_frames[0] < ROUGH_MIN_S:
        return None
    w = int(round(ROUGH_WINDOW_S / pre.dt))
    return [(int(a), int(a) + w) for a in np.linspace(0, n - w, ROUGH_WINDOWS)]


def _usable(p: SyncProblem, pre: _Prepared, delta: float) -> np.ndarray:
    """(n,) bool: the frames scorable at δ (_chunks' ``usable``) without forming the columns:
    a detection's velocity, and the IMU covering every frame of the smoothing's window (the
    bias's columns are finite wherever J is: their times are clipped to the recording)."""
    gap = np.where(_imu_covers(p, p.t_frames - delta), 0.0, np.nan)[:, None]
    covered = np.isfinite(savgol_cut(gap, p.frame_cuts, pre.window, 0, pre.dt))[:, 0]
    return covered & np.isfinite(pre.vel_img).all(axis=1) & np.isfinite(pre.J).all(axis=(1, 2))


def _fit(p: SyncProblem, pre: _Prepared, delta: float, ok: np.ndarray):
    """Least squares u̇_k = c V_k(δ) + J_k (∫R dt) β + J_k d(t_k) over the frames ``ok`` (all
    scorable), d the integrated IMU's drift (a smooth 3-D function of time in the spline
    basis): residuals (n_ok, 2) and the parameter count."""
    E = np.concatenate([W[ok[a:b]] for a, b, W, _ in _chunks(p, pre, delta)])
    D = Drift(pre.drift, pre.J, ok)
    return fit_bordered(D, E, pre.vel_img[ok]), E.shape[2] + D.n_params


def cost(delta: float, p: SyncProblem, pre: _Prepared, n_img: int, cache: dict,
         frames: np.ndarray | None = None, spans=None) -> float:
    """Mean squared residual of the fit (_fit); inf with too little overlap. The drift's
    normal equations are reused while the frames used stay the same (``cache``): with
    G = DᵀD (banded, factored once), the residual sum is yᵀy − (Dᵀy)ᵀG⁻¹Dᵀy − bᵀS⁻¹b, where
    S = WᵀW − (DᵀW)ᵀG⁻¹DᵀW and b = Wᵀy − (DᵀW)ᵀG⁻¹Dᵀy, W the four columns that move with δ
    (the scale's and the bias's) eliminated last; a negative scale (c > 0: a range) leaves
    the bias's three alone. With ``spans`` ((a, b) ranges of frames), over those alone
    (n_img then counts their frames with an image velocity)."""
    ok = np.zeros(p.t_frames.size, bool)
    WW, Wy, DW = np.zeros((4, 4)), np.zeros(4), np.zeros((3 * pre.drift.m, 4))
    for a, b, W, use in _chunks(p, pre, delta, spans):  # WᵀW, Wᵀy and DᵀW a chunk at a time
        if frames is not None:  # the same frames at every δ (a refinement's), when all usable
            if not use[frames[a:b]].all():
                return np.inf
            use = frames[a:b]
        ok[a:b] = use
        Wf, y = W[use].reshape(-1, 4), pre.vel_img[a:b][use].ravel()
        WW += Wf.T @ Wf
        Wy += Wf.T @ y
        DW += Drift(pre.drift[a:b], pre.J[a:b], use).t(W[use])
    n = int(ok.sum())
    if n < max(MIN_OVERLAP * n_img, MIN_FRAMES):
        return np.inf
    if cache.get("ok") is None or not np.array_equal(cache["ok"], ok):
        G, Dy, yy = _normal_update(pre, cache, ok)
        solve = banded_solver(G)
        Gy = solve(Dy)
        cache.update(ok=ok, G=G, Dy=Dy, yy=yy, solve=solve, Gy=Gy, base=yy - Dy @ Gy)
    S = WW - DW.T @ cache["solve"](DW) + RIDGE * np.eye(4)
    b = Wy - DW.T @ cache["Gy"]
    theta = np.linalg.solve(S, b)
    if theta[0] <= 0:  # c > 0: a range
        return (cache["base"] - float(b[1:] @ np.linalg.solve(S[1:, 1:], b[1:]))) / n
    return (cache["base"] - float(b @ theta)) / n


def _normal_update(pre: _Prepared, cache: dict, ok: np.ndarray):
    """DᵀD (banded), Dᵀy and yᵀy over the frames ``ok``: the cached ones' plus the frames
    added less those dropped, when few changed (the grid's next δ moves the overlap's ends by
    a frame or two), else summed afresh."""
    def parts(m):
        return normal_parts(Drift(pre.drift, pre.J, m), pre.vel_img[m])

    old = cache.get("ok")
    if old is not None:
        add, drop = ok & ~old, old & ~ok
        if add.sum() + drop.sum() < 0.1 * ok.sum():
            (Ga, ya, sa), (Gd, yd, sd) = parts(add), parts(drop)
            return cache["G"] + Ga - Gd, cache["Dy"] + ya - yd, cache["yy"] + sa - sd
    return parts(ok)


def estimate_imu_offset(p: SyncProblem, *, centre_s: float = 0.0, search_s: float = 3.0
                        ) -> ImuOffset | None:
    """δ minimising the cost in centre_s ± search_s, and its SD; None when no δ there gives
    enough frames with both an image and an IMU velocity."""
    if np.isfinite(p.uv).all(axis=1).sum() < MIN_FRAMES:
        return None
    pre = _prepare(p, centre_s)
    n_img = int(np.isfinite(pre.vel_img).all(axis=1).sum())
    if n_img < MIN_FRAMES:
        return None
    step = pre.dt
    grid = centre_s + np.arange(-search_s, search_s + step / 2, step)
    costs = _grid_costs(grid, p, pre, n_img)
    if not np.isfinite(costs).any():
        return None
    delta = float(grid[int(np.argmin(costs))])
    # where a ray grazes the sphere the depths' chain can take the other intersection from a
    # slightly different orientation: the preparation that explains the data best is kept
    # (only it and the latest: each holds per-sample arrays)
    best = last = _refine(p, pre, n_img, delta, step) + (pre,)
    for _ in range(REPREPARE):  # the rays' depths with the IMU's orientation at the latest δ
        pre = _prepare(p, last[0], like=pre)
        now = _refine(p, pre, n_img, last[0], step) + (pre,)
        best = now if now[1] < best[1] else best  # the first of equals, as min() took it
        done, last = abs(now[0] - last[0]) < 1e-3, now
        if done:
            break
    delta, _, pre = best
    last = now = None  # noqa: F841 (their arrays freed before the SD)
    sd, frames = _sd(p, pre, delta)
    return ImuOffset(delta, sd, frames)


def _grid_costs(grid: np.ndarray, p: SyncProblem, pre: _Prepared, n_img: int) -> np.ndarray:
    """The cost at every COARSE-th δ of the grid (on _rough_spans' windows of a long session),
    then at each δ within COARSE − 1 of the best of those (coarse to fine: the basin is many
    frames wide); inf where not evaluated."""
    cache: dict = {}  # the grid's normal equations: the refinements keep their own
    spans, rough = _rough_spans(p, pre), None
    if spans is not None:
        n_rough = sum(int(np.isfinite(pre.vel_img[a:b]).all(axis=1).sum()) for a, b in spans)
        cache_r: dict = {}
        def rough(i):  # noqa: E306
            return cost(grid[i], p, pre, n_rough, cache_r, spans=spans)
    return coarse_to_fine(grid.size, lambda i: cost(grid[i], p, pre, n_img, cache),
                          every=COARSE, radius=COARSE - 1, with_last=True, rough=rough)


def _refine(p: SyncProblem, pre: _Prepared, n_img: int, d0: float, step: float
            ) -> tuple[float, float]:
    """The cost's minimum within d0 ± REFINE_FRAMES periods, on the frames all of it scores:
    (δ, cost)."""
    lo, hi = d0 - REFINE_FRAMES * step, d0 + REFINE_FRAMES * step
    frames = _usable(p, pre, lo) & _usable(p, pre, d0) & _usable(p, pre, hi)
    cache: dict = {}
    c0 = cost(d0, p, pre, n_img, cache, frames)
    x, fun = bounded_min(lambda d: cost(d, p, pre, n_img, cache, frames), lo, hi,
                         xatol=XATOL_S)  # scipy's bounded minimize_scalar, step for step
    return (float(x), float(fun)) if fun <= c0 else (d0, c0)


def _sd(p: SyncProblem, pre: _Prepared, delta: float) -> tuple[float, int]:
    """From the curvature of the residual sum of squares S(δ) over the same frames (profiled
    over the scale and the drift): SD² = 2 σ² / S'', σ² = S / (2n − parameters), inflated by
    (1 + ρ)/(1 − ρ) for the residuals' lag-1 autocorrelation ρ; and the frames used."""
    h = 0.5 * pre.dt
    ok = _usable(p, pre, delta) & _usable(p, pre, delta + h) & _usable(p, pre, delta - h)
    cache: dict = {}  # the drift's normal equations on these frames, factored once
    rss = [cost(d, p, pre, 0, cache, ok) * ok.sum() for d in (delta - h, delta, delta + h)]
    r, n_par = _fit(p, pre, delta, ok)  # the residuals themselves, for ρ
    curv = (rss[0] - 2 * rss[1] + rss[2]) / h**2
    sigma2 = rss[1] / max(r.size - n_par, 1)
    rho = float(np.mean([np.corrcoef(r[:-1, k], r[1:, k])[0, 1] for k in range(2)]))
    rho = min(max(rho, 0.0), 0.99)
    if not np.isfinite(curv) or curv <= 0:
        return float("nan"), int(ok.sum())
    return float(np.sqrt(2 * sigma2 / curv * (1 + rho) / (1 - rho))), int(ok.sum())
