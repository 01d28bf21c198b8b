"""The ground truth's clock offset, estimated from the data ([sync] groundtruth_offset_s =
"auto"): the δ, with session time = truth time + δ, that best lines the truth up with an
estimated trajectory, and its standard deviation.

Cost: the variance of the residual estimate − truth(t − δ) over the frames both cover (the
mean residual, an estimate's constant bias, is not a time offset and is left out). Given the
camera's centre, only the residual across each frame's camera ray counts: a one-camera
tracker's error lies mostly along the ray, and where it follows the motion (a smoother's
depth lagging at a rectangle's corners) it pulls the offset by several ms; across the ray the
image pins the estimate to a pixel. A grid at
the truth's sample period finds the basin; a bounded scalar search refines it. The SD is the
Gauss–Newton one, σ² / Σ‖v‖² with v the truth's velocity, inflated for the residuals' serial
correlation (n / n_eff, n_eff from their lag-1 autocorrelation ρ: n (1 − ρ) / (1 + ρ)).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armtrack_cli.compare.errors import truth_at
from armtrack_cli.core.bounded_min import bounded_min
from armtrack_cli.core.grid_search import coarse_to_fine

MIN_OVERLAP = 0.5  # share of the estimate's frames that must meet the shifted truth
COARSE = 5  # the coarse pass tries every 5th offset of the grid (0.05 s at 100 Hz) …
DECIMATE = 4  # … on every 4th frame,
REFINE = 3  # and the grid is searched whole around its 3 lowest dips


@dataclass(frozen=True)
class Offset:
    estimate_s: float  # δ: session time = truth time + δ
    sd_s: float
    frames: int  # frames used at the estimate


def _across(x: np.ndarray, rays: np.ndarray | None) -> np.ndarray:
    """x (n, 3) without its components along the unit rays (n, 3) (unchanged without rays),
    in place: x and rays are the caller's own (this runs hundreds of times beside the
    scoring, issue 15)."""
    if rays is None:
        return x
    along = np.sum(x * rays, axis=1, keepdims=True)
    x -= np.multiply(along, rays, out=rays)
    return x


def _residual(delta, t, est, truth_t, truth_xyz, rate_hz):
    tr = truth_at(t, truth_t + delta, truth_xyz, rate_hz)
    ok = np.isfinite(est).all(axis=1) & np.isfinite(tr).all(axis=1)
    r = est[ok]
    r -= tr[ok]
    return r, ok


def _cost(delta, t, est, truth_t, truth_xyz, rate_hz, n_est, rays=None):
    r, ok = _residual(delta, t, est, truth_t, truth_xyz, rate_hz)
    if ok.sum() < MIN_OVERLAP * n_est:
        return np.inf
    r -= r.mean(axis=0)  # in place, as in _across: this runs beside the scoring (issue 15)
    r = _across(r, None if rays is None else rays[ok])
    np.square(r, out=r)
    return float(np.mean(np.sum(r, axis=1)))


def _grid_costs(grid, t, est, truth_t, truth_xyz, rate_hz, rays) -> np.ndarray:
    """The cost at each offset of ``grid`` (inf where not evaluated), coarse to fine: every
    COARSE-th offset on every DECIMATE-th frame finds the basins; the whole grid around the
    REFINE best of them, on every frame, gives the minimum the full grid would (its cost is
    smooth over COARSE samples of the truth: a basin is several tenths of a second wide).
    When the coarse pass finds no overlap anywhere, every offset is evaluated."""
    def cost(d, k=1):
        e = est[::k]
        n = int(np.isfinite(e).all(axis=1).sum())
        return _cost(d, t[::k], e, truth_t, truth_xyz, rate_hz, n,
                     None if rays is None else rays[::k])

    return coarse_to_fine(grid.size, lambda i: cost(grid[i]), every=COARSE, radius=COARSE,
                          basins=REFINE, rough=lambda i: cost(grid[i], DECIMATE))


def estimate_offset(t: np.ndarray, est: np.ndarray, truth_t: np.ndarray, truth_xyz: np.ndarray,
                    rate_hz: float, *, search_s: float = 2.0, centre_s: float = 0.0,
                    eye: np.ndarray | None = None) -> Offset | None:
    """t (n,) s on the session clock, est (n, 3) m (NaN = missing); truth_t (m,) s on the
    truth's own clock, truth_xyz (m, 3) m in W; eye (3,) m in W, the camera's centre (None:
    the whole residual counts). None when no offset in centre_s ± search_s gives the overlap
    needed."""
    n_est = int(np.isfinite(est).all(axis=1).sum())
    if n_est < 10:
        return None
    rays = None
    if eye is not None:
        rays = est - eye
        rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    step = 1.0 / rate_hz
    grid = centre_s + np.arange(-search_s, search_s + step / 2, step)
    costs = _grid_costs(grid, t, est, truth_t, truth_xyz, rate_hz, rays)
    if not np.isfinite(costs).any():
        return None
    d0 = grid[int(np.argmin(costs))]
    x, fun = bounded_min(lambda d: _cost(d, t, est, truth_t, truth_xyz, rate_hz, n_est, rays),
                         d0 - step, d0 + step, xatol=1e-5)  # scipy's bounded minimize_scalar
    delta = float(x) if fun <= costs.min() else float(d0)
    r, ok = _residual(delta, t, est, truth_t, truth_xyz, rate_hz)
    r -= r.mean(axis=0)  # the SD from the whole residual: across the rays alone it is
    #                      pixel-small and the SD too sure (0.1 ms against 0.6 ms off)
    h = 0.5 * step  # the truth's velocity at the frames, by central differences (in place)
    v = truth_at(t, truth_t + delta + h, truth_xyz, rate_hz)
    v -= truth_at(t, truth_t + delta - h, truth_xyz, rate_hz)
    v = v[ok]
    v /= 2 * h
    good = np.isfinite(v).all(axis=1)
    r, v = r[good], v[good]
    n = len(r)
    sigma2 = float(np.sum(r**2) / max(3 * n - 1, 1))
    rho = float(np.mean([np.corrcoef(r[:-1, k], r[1:, k])[0, 1] for k in range(3)
                         if np.std(r[:, k]) > 0])) if n > 3 else 0.0
    rho = min(max(rho, 0.0), 0.99)
    inflate = (1 + rho) / (1 - rho)
    sd = float(np.sqrt(sigma2 / max(np.sum(v**2), 1e-12) * inflate))
    return Offset(delta, sd, n)
