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
    its IMU errors as estimated there and p = v = 0: D_k, the double-integrated displacement
    (the errors stepped by the process, not taken from the trajectory's later frames: over a
    wrong run those bent to fit it);
  - each hypothesis (the run as it is, the run on the other root) fitted by p_k ≈ p₀ + v₀ τ_k
    + D_k (least squares in p₀, v₀: a start and a velocity the run may have got wrong); its
    RMS residual says how well the IMU agrees with it.

A run is moved when the other root's residual is below ``ratio`` times its own, the clearest
case first (``repair``); so is a chain of runs on the same root cut only by frames where the
ray grazes the sphere (``candidates``); and each piece of a run cut where its roots come
nearest (``nearest_frames``, ``pieces``): with a sphere a centimetre off (a shoulder estimated,
lift13) a ray tangent to the true sphere cuts the declared one 10-25 cm apart, so the wrist
changes root there unseen by the grazing rule and a wrong stretch is no run of its own (the
gap's least, rising on one side at least: a hand lifted from rest leaves it flat before,
lift14). Across such a cut the wrist passes between the roots, on neither: a piece's test
leaves CUT_FRAMES either side of its cuts out of both misfits, over a window of PIECE_MARGIN,
and only pieces with that window whole on both sides are tested (its ratio is nearer 1:
0.45-0.66 for the wrong pieces of the sessions of lift13, 1.03 and more for the right ones).
A wrong run bends the path by the roots' gap (centimetres to decimetres) where the IMU's
error over a second or two is millimetres, so the ratio is far from 1 either way. The arm smoother
(fuse/arm_smoother.py) does this after its first iteration (whose orientation error and
bias make the spheres and the IMU's path right), and goes on from the repaired trajectory;
again after each pass that followed a move (arm_smoother.repair_due): errors fitted to a
wrong stretch can make the IMU agree with it until another stretch has moved (lift14).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from armtrack_cli.core.quaternion import row_spans
from armtrack_cli.fuse.path_kernel import affine_path

MIN_GAP_M = 0.02  # the roots this far apart at least on every frame of a run: nearer, the ray
#                   grazes the sphere and either root is about as good
MARGIN = 15  # frames either side of a run in its window (0.5 s at 30 fps)
RATIO = 0.8  # move a run when the other root's residual is below this times its own
MIN_FRAMES = 3  # shorter runs are left alone (a frame or two the next iteration decides)
NEAREST_HALF = 15  # nearest_frames: the roots' gap least within this many frames either side …
NEAREST_RISE_M = 0.03  # … and this much larger within twice as many on one side: where the
#                        ray passes nearest a tangent while the hand is lifted (lift13; both
#                        sides then, one since lift14: a lift from rest is flat before)
CUT_FRAMES = 10  # a piece's frames this near its cuts left out of its test (off both roots)
PIECE_MARGIN = 60  # frames either side of a piece in its window (2 s: its anchors, fewer near
#                    the cuts, further out; with 15, wrong pieces' ratios were 0.4-1.7, lift13)
PATH_BLOCK = 1024  # a window's steps built at a time (window_path)
GRAZING, UNSEEN = -1, -2  # roots_of's codes: roots nearer than MIN_GAP_M, no detection
ROOT_ROWS = 8192  # frames roots_of codes at a time

# steps(lo, hi) -> (F (hi − lo, d, d), b (hi − lo, d)): the process steps into frames lo … hi − 1
Steps = Callable[[int, int], tuple[np.ndarray, np.ndarray]]


def roots_of(p: np.ndarray, points: np.ndarray, min_gap_m: float = MIN_GAP_M) -> np.ndarray:
    """(n,) the root (0, 1) nearer each position p (n, 3) where the roots points (n, 2, 3)
    are at least min_gap_m apart; GRAZING where they are nearer, UNSEEN where there are none
    (no detection). ROOT_ROWS rows at a time: the temporaries, ~100 bytes a row, a chunk's
    (each row's numbers its own; issue 15)."""
    out = np.empty(p.shape[0], np.int64)
    for a, b in row_spans(p.shape[0], ROOT_ROWS):
        pts = points[a:b]
        gap = np.linalg.norm(pts[:, 0] - pts[:, 1], axis=1)
        d = np.linalg.norm(p[a:b, None, :] - pts, axis=2)
        root = np.argmin(np.where(np.isfinite(d), d, np.inf), axis=1)
        out[a:b] = np.where(~np.isfinite(gap), UNSEEN,
                                        np.where(gap < min_gap_m, GRAZING, root))
    return out


def branch_runs(p: np.ndarray, points: np.ndarray, min_gap_m: float = MIN_GAP_M,
                min_frames: int = MIN_FRAMES, root: np.ndarray | None = None
                ) -> list[tuple[int, int, int]]:
    """(lo, hi, root) for each run of frames lo … hi − 1 whose positions p (n, 3) sit nearer
    the same root points[:, root] (points (n, 2, 3), NaN: no detection) while the two roots
    are at least min_gap_m apart; runs of fewer than min_frames frames left out. ``root``:
    roots_of(p, points, min_gap_m) when the caller has it."""
    root = roots_of(p, points, min_gap_m) if root is None else root
    edges = np.flatnonzero(np.diff(np.r_[UNSEEN, root, UNSEEN]) != 0)  # where runs start, end
    return [(int(lo), int(hi), int(root[lo])) for lo, hi in zip(edges[:-1], edges[1:])
            if root[lo] >= 0 and hi - lo >= min_frames]


def candidates(p: np.ndarray, points: np.ndarray, min_gap_m: float = MIN_GAP_M,
               root: np.ndarray | None = None) -> list[tuple[int, int, int]]:
    """The stretches (lo, hi, root) that ``repair`` tests: every run (``branch_runs``), and
    every chain of two or more runs on the same root with only grazing frames between them
    (a path that stays on one root while the ray nearly touches the sphere: the wrist need not
    have changed root there, and a wrong stretch is often cut so into short pieces); each
    with the grazing frames that border it, which a path leaving the wrong root crosses.
    ``root``: roots_of(p, points, min_gap_m) when the caller has it."""
    root = roots_of(p, points, min_gap_m) if root is None else root
    runs = branch_runs(p, points, min_gap_m, min_frames=1, root=root)
    spans = [r for r in runs if r[1] - r[0] >= MIN_FRAMES]
    i = 0
    while i < len(runs):
        j = i
        while (j + 1 < len(runs) and runs[j + 1][2] == runs[i][2]
               and (root[runs[j][1]:runs[j + 1][0]] == GRAZING).all()):
            j += 1
        if j > i:
            spans.append((runs[i][0], runs[j][1], runs[i][2]))
        i = j + 1
    out = []
    for lo, hi, r in spans:
        while lo > 0 and root[lo - 1] == GRAZING:
            lo -= 1
        while hi < root.size and root[hi] == GRAZING:
            hi += 1
        out.append((lo, hi, r))
    return out


def nearest_frames(gap: np.ndarray, half: int = NEAREST_HALF,
                   rise: float = NEAREST_RISE_M) -> np.ndarray:
    """The frames where the roots' gap (n,) m (NaN: no detection) is least within ``half``
    frames either side and larger by ``rise`` somewhere within 2 ``half`` on one side or
    both: the ray's nearest approach to a tangent, where a wrist that meets a sphere slightly
    off the declared one changes root though the roots stay apart. One side may be flat: a
    hand lifted from rest, or come to rest, leaves the gap still on that side (lift14).
    Frames near the ends, without 2 ``half`` on both sides, are not among them (a run's end
    is a cut already)."""
    n, w = gap.size, 2 * half
    if n <= 2 * w:
        return np.zeros(0, np.int64)
    g = np.where(np.isfinite(gap), gap, np.nan)
    lowest = np.nanmin(np.lib.stride_tricks.sliding_window_view(
        np.where(np.isnan(g), np.inf, g), 2 * half + 1), axis=1)  # frames half … n − half − 1
    hi = np.where(np.isnan(g), -np.inf, g)
    win = np.lib.stride_tricks.sliding_window_view(hi, w)  # win[j]: frames j … j + w − 1
    k = np.arange(w, n - w)  # slices of the view, not its rows gathered: no (n, w) copy
    before, after = win[:n - 2 * w].max(axis=1), win[w + 1:n - w + 1].max(axis=1)
    ok = (np.isfinite(g[k]) & (g[k] <= lowest[k - half])
          & ((before >= g[k] + rise) | (after >= g[k] + rise)))
    return k[ok]


def pieces(runs: list[tuple[int, int, int]], cuts: np.ndarray) -> list[tuple[int, int, int]]:
    """Each run (lo, hi, root) cut at the frames ``cuts`` strictly inside it: its pieces of
    MIN_FRAMES frames or more, none where no cut falls inside (the run is a candidate as it
    is)."""
    out = []
    for lo, hi, r in runs:
        inside = cuts[(cuts > lo) & (cuts < hi)]
        edges = np.r_[lo, inside, hi]
        out += [(int(a), int(b), r) for a, b in zip(edges[:-1], edges[1:])
                if inside.size and b - a >= MIN_FRAMES]
    return out


def moved(p: np.ndarray, points: np.ndarray, code: np.ndarray, lo: int, hi: int,
          root: int) -> np.ndarray:
    """Positions p (m, 3) with the stretch lo … hi − 1 moved off ``root``: its frames on that
    root (``code``, roots_of's) to the other, its grazing frames to the middle of the two
    roots (where the ray passes nearest the sphere's surface); the rest as they are."""
    q = p.copy()
    on = np.flatnonzero(code[lo:hi] == root) + lo
    q[on] = points[on, 1 - root]
    graze = np.flatnonzero(code[lo:hi] == GRAZING) + lo
    q[graze] = points[graze].mean(axis=1)
    return q


def imu_path(F: np.ndarray, b: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(D (m + 1, 3), τ (m + 1,)): the displacement from the state x (d,) with p = v = 0 over
    the steps F (m, d, d), b (m, d) (its IMU errors as x holds them), and the time since it
    (F's ∂p/∂v block is Δ I)."""
    return window_path(lambda lo, hi: (F[lo:hi], b[lo:hi]), 0, F.shape[0], x)


def window_path(steps: Steps, lo: int, hi: int, x: np.ndarray,
                block: int = PATH_BLOCK) -> tuple[np.ndarray, np.ndarray]:
    """imu_path over the steps into frames lo … hi − 1, taken from ``steps`` ``block`` frames
    at a time: a run can be most of a session, whose F whole would be tens of MB (issue 15).
    The same additions in the same order as one imu_path over them all (the frames stepped
    by a compiled loop, fuse/path_kernel.py)."""
    x = np.array(x, float)
    x[:6] = 0.0
    D, tau = np.zeros((hi - lo + 1, 3)), np.zeros(hi - lo + 1)
    for a in range(lo, hi, block):
        F, b = steps(a, min(a + block, hi))
        affine_path(np.ascontiguousarray(F, float), np.ascontiguousarray(b, float), x, D,
                    a - lo + 1)
        tau[a - lo:a - lo + F.shape[0] + 1] = np.cumsum(np.r_[tau[a - lo], F[:, 0, 3]])
    return D, tau


def piece_ratio(here: np.ndarray, there: np.ndarray, D: np.ndarray, tau: np.ndarray,
                lo: int, hi: int, cut: int = CUT_FRAMES) -> float:
    """misfit(there) / misfit(here) over a piece's window (positions (m, 3), the IMU's path D,
    τ), the piece its frames lo … hi − 1, without the ``cut`` frames either side of lo and of
    hi: there the wrist crosses between the roots, on neither (``pieces``)."""
    keep = np.ones(here.shape[0], bool)
    for c in (lo, hi):
        keep[max(c - cut, 0):max(c + cut, 0)] = False
    return misfit(there[keep], D[keep], tau[keep]) / max(
        misfit(here[keep], D[keep], tau[keep]), 1e-300)


def misfit(P: np.ndarray, D: np.ndarray, tau: np.ndarray) -> float:
    """RMS (m) of P (m, 3) − D − (p₀ + v₀ τ) with p₀, v₀ fitted by least squares: the line's
    closed form about the means (v₀ = Σ τ' y' / Σ τ'², τ' = τ − τ̄, y' = y − ȳ; v₀ = 0 when
    every τ is the same), a tenth of lstsq's time on a 2-column fit."""
    Y = P - D
    Y = Y - Y.mean(axis=0)
    tc = tau - tau.mean()
    ss = tc @ tc
    v0 = (tc @ Y) / ss if ss > 0 else np.zeros(Y.shape[1])
    R = Y - tc[:, None] * v0
    return float(np.sqrt(np.mean(np.sum(R * R, axis=1))))


def repair(X: np.ndarray, points: np.ndarray, steps: Steps, *, min_gap_m: float = MIN_GAP_M,
           margin: int = MARGIN, ratio: float = RATIO, in_place: bool = False
           ) -> tuple[np.ndarray, int]:
    """(X with its wrongly rooted stretches moved to the other root, how many moved) for the
    trajectory X (n, d) (p its first three columns, the IMU's errors in the rest as the
    process ``steps`` takes them) and the roots ``points`` (n, 2, 3); a stretch moves as
    ``moved`` says.

    Greedy, the clearest first: a stretch's window reaches into its neighbours, so a right
    one beside a wrong one sees a path half on each root either way; the wrong one, between
    right ones, sees the IMU agree with the other root on its whole window, the smallest
    ratio of all. So the stretch of smallest ratio (below ``ratio``) moves, those that
    share frames off the grazing ones with it are dropped, those whose windows reach it are
    tested again, and so on. ``in_place``: X itself repaired and returned, not a copy (the
    arm smoother's, which holds no other: a second (n, d) trajectory, issue 15)."""
    n = X.shape[0]
    X = X if in_place else X.copy()
    code = roots_of(X[:, :3], points, min_gap_m)
    cands = candidates(X[:, :3], points, min_gap_m, root=code)
    whole = len(cands)  # those after it: pieces of runs cut where the roots come nearest
    cands += [(lo, hi, r) for lo, hi, r in pieces(  # anchored on both sides: its test is weaker
        branch_runs(X[:, :3], points, min_gap_m, root=code),
        nearest_frames(np.linalg.norm(points[:, 0] - points[:, 1], axis=1)))
        if lo >= PIECE_MARGIN and hi + PIECE_MARGIN <= n]
    windows = [(max(lo - m, 0), min(hi + m, n)) for i, (lo, hi, _) in enumerate(cands)
               for m in [margin if i < whole else PIECE_MARGIN]]

    def test(i: int) -> float:
        """The other root's misfit over stretch i's window against its own. The IMU's path
        over the window is the same whichever root (moves change positions, the path starts
        from the IMU errors alone): made again where a stretch is tested again (rarely: 615
        paths made in all on tiled-6x10, 0.3 s of CPU), not held for every stretch (32 bytes
        a frame of every window, 3.5 MB and more at 60 minutes, issue 15)."""
        (lo, hi, r), (a, e) = cands[i], windows[i]
        path = window_path(steps, a + 1, e, X[a])
        here = X[a:e, :3]
        there = moved(here, points[a:e], code[a:e], lo - a, hi - a, r)
        if i >= whole:
            return piece_ratio(here, there, *path, lo - a, hi - a)
        return misfit(there, *path) / max(misfit(here, *path), 1e-300)

    ratios = np.array([test(i) for i in range(len(cands))])
    count = 0
    while ratios.size and ratios.min() < ratio:
        lo, hi, r = cands[int(np.argmin(ratios))]
        X[lo:hi, :3] = moved(X[lo:hi, :3], points[lo:hi], code[lo:hi], 0, hi - lo, r)
        code[lo:hi] = np.where(code[lo:hi] == r, 1 - r, code[lo:hi])
        count += 1
        for j, (lj, hj, rj) in enumerate(cands):
            if (code[lj:hj] == 1 - rj).any():  # some of its own frames moved (itself too)
                ratios[j] = np.inf
            elif np.isfinite(ratios[j]) and windows[j][0] < hi and windows[j][1] > lo:
                ratios[j] = test(j)  # its window reaches it
    return X, count
