"""Runs of frames on the wrong ray–sphere root, found and moved to the other (issue 14).

The detection's camera ray meets the wrist's sphere (|p − (S + L2 R u)| = L1, Tao & Hu eq. 15)
at two points (robust.ray_sphere_points). Camera and arm are satisfied at either, so a
trajectory that sits on the wrong one for a run of frames is a local minimum of the arm
smoother's least squares: Gauss–Newton, linearised there, stays there. Only the IMU tells the
roots apart, through the path between them. A true wrist changes root only where the two
meet (the ray tangent to the sphere) or unseen; a run of frames on one root whose other root
is well apart is therefore tested as a whole:

  - the window: the run and up to ``margin`` frames either side (the trajectory as it is);
  - the IMU's path over it: the linear process x_k = F_k x_{k−1} + b_k (Tao & Hu eqs. 4–6
    with the orientation error and bias, fuse/imu_fold.py) from the window's first frame,
    its IMU errors as estimated and p = v = 0: D_k, the double-integrated displacement;
  - each hypothesis (the run as it is, the run on the other root) fitted by p_k ≈ p₀ + v₀ τ_k
    + D_k (least squares in p₀, v₀: a start and a velocity the run may have got wrong); its
    RMS residual says how well the IMU agrees with it.

A run is moved when the other root's residual is below ``ratio`` times its own, the clearest
case first (``repair``). A wrong
run bends the path by the roots' gap (centimetres to decimetres) where the IMU's error over a
second or two is millimetres, so the ratio is far from 1 either way. The arm smoother
(fuse/arm_smoother.py) does this once, after its first iteration (whose orientation error and
bias make the spheres and the IMU's path right), and goes on from the repaired trajectory.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

MIN_GAP_M = 0.02  # the roots this far apart at least on every frame of a run: nearer, the ray
#                   grazes the sphere and either root is about as good
MARGIN = 15  # frames either side of a run in its window (0.5 s at 30 fps)
RATIO = 0.8  # move a run when the other root's residual is below this times its own
MIN_FRAMES = 3  # shorter runs are left alone (a frame or two the next iteration decides)

# steps(lo, hi) -> (F (hi − lo, d, d), b (hi − lo, d)): the process steps into frames lo … hi − 1
Steps = Callable[[int, int], tuple[np.ndarray, np.ndarray]]


def branch_runs(p: np.ndarray, points: np.ndarray, min_gap_m: float = MIN_GAP_M,
                min_frames: int = MIN_FRAMES) -> list[tuple[int, int, int]]:
    """(lo, hi, root) for each run of frames lo … hi − 1 whose positions p (n, 3) sit nearer
    the same root points[:, root] (points (n, 2, 3), NaN: no detection) while the two roots
    are at least min_gap_m apart; runs of fewer than min_frames frames left out."""
    gap = np.linalg.norm(points[:, 0] - points[:, 1], axis=1)
    ok = np.isfinite(gap) & (gap >= min_gap_m)
    d = np.linalg.norm(p[:, None, :] - points, axis=2)
    root = np.where(ok, np.argmin(np.where(np.isfinite(d), d, np.inf), axis=1), -1)
    edges = np.flatnonzero(np.diff(np.r_[-1, root, -1]) != 0)  # where a run starts or ends
    return [(int(lo), int(hi), int(root[lo])) for lo, hi in zip(edges[:-1], edges[1:])
            if root[lo] >= 0 and hi - lo >= min_frames]


def imu_path(F: np.ndarray, b: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(D (m + 1, 3), τ (m + 1,)): the displacement from the state x (d,) with p = v = 0 over
    the steps F (m, d, d), b (m, d) (its IMU errors as x holds them), and the time since it
    (F's ∂p/∂v block is Δ I)."""
    x = np.array(x, float)
    x[:6] = 0.0
    D = np.zeros((F.shape[0] + 1, 3))
    for j in range(F.shape[0]):
        x = F[j] @ x + b[j]
        D[j + 1] = x[:3]
    return D, np.r_[0.0, np.cumsum(F[:, 0, 3])]


def misfit(P: np.ndarray, D: np.ndarray, tau: np.ndarray) -> float:
    """RMS (m) of P (m, 3) − D − (p₀ + v₀ τ) with p₀, v₀ fitted by least squares."""
    A = np.c_[np.ones_like(tau), tau]
    Y = P - D
    coef = np.linalg.lstsq(A, Y, rcond=None)[0]
    return float(np.sqrt(np.mean(np.sum((Y - A @ coef) ** 2, axis=1))))


def repair(X: np.ndarray, points: np.ndarray, steps: Steps, *, min_gap_m: float = MIN_GAP_M,
           margin: int = MARGIN, ratio: float = RATIO) -> tuple[np.ndarray, int]:
    """(X with its wrongly rooted runs' positions moved to the other root, how many runs
    moved) for the trajectory X (n, d) (p its first three columns, the IMU's errors in the
    rest as the process ``steps`` takes them) and the roots ``points`` (n, 2, 3).

    Greedy, the clearest first: a run's window reaches into its neighbours, so a right run
    beside a wrong one sees a path half on each root either way; the wrong one, between
    right ones, sees the IMU agree with the other root on its whole window, the smallest
    ratio of all. So the run of smallest ratio (below ``ratio``) moves, the runs whose windows
    reach it are tested again, and so on; a run moves at most once."""
    n = X.shape[0]
    X = X.copy()
    runs = branch_runs(X[:, :3], points, min_gap_m)
    windows = [(max(lo - margin, 0), min(hi + margin, n)) for lo, hi, _ in runs]
    paths = []
    for a, e in windows:  # the IMU's path over each window: the same whichever root
        F, b = steps(a + 1, e)
        paths.append(imu_path(F, b, X[a]))

    def test(i: int) -> float:
        """The other root's misfit over run i's window against its own."""
        (lo, hi, root), (a, e) = runs[i], windows[i]
        here = X[a:e, :3]
        there = here.copy()
        there[lo - a:hi - a] = points[lo:hi, 1 - root]
        return misfit(there, *paths[i]) / max(misfit(here, *paths[i]), 1e-300)

    ratios = np.array([test(i) for i in range(len(runs))])
    moved = 0
    while ratios.size and ratios.min() < ratio:
        i = int(np.argmin(ratios))
        lo, hi, root = runs[i]
        X[lo:hi, :3] = points[lo:hi, 1 - root]
        ratios[i], moved = np.inf, moved + 1  # moved once only
        for j in range(len(runs)):  # the runs whose windows reach it
            if np.isfinite(ratios[j]) and windows[j][0] < hi and windows[j][1] > lo:
                ratios[j] = test(j)
    return X, moved
