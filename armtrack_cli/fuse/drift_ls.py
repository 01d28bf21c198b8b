"""The drift columns of the IMU clock-offset fit (fuse/imu_sync.py) without a dense matrix.

The fit's drift is d(t) = Σ_j θ_j B_j(t), a spline with K = degree + 1 basis functions
non-zero at any time, seen in the image as J_k d(t_k) (eq. 7's Jacobian J_k, 2 × 3). Its
columns D (2 rows per frame, 3 per basis function, column 3j + a for axis a) have 3K
non-zeros a row, so DᵀD is banded (3K − 1 off the diagonal) and the least squares cost O(n)
in time and memory, where the dense D (2n × 3m, m ∝ n) cost O(n³) and O(n²): a 60-minute
session's dense basis alone was 1.6 GB. Products with D and Dᵀ are formed CHUNK frames at a
time, so their temporaries do not grow with the session.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

RIDGE = 1e-9  # added to the normal equations' diagonal (keeps an unseen basis function at 0)
CHUNK = 4096  # frames whose products are formed at once: memory bounded however long the session


@dataclass(frozen=True)
class SplineRows:
    """A spline basis evaluated at n times: row k is ``w[k]`` on basis functions
    ``start[k] … start[k] + K − 1`` of ``m``."""

    start: np.ndarray  # (n,) int
    w: np.ndarray  # (n, K)
    m: int

    @classmethod
    def from_csr(cls, B, K: int) -> SplineRows:
        """From scipy's BSpline.design_matrix (CSR, K consecutive entries a row)."""
        if not np.all(np.diff(B.indptr) == K):
            raise ValueError("every row of the spline basis must hold K entries")
        return cls(B.indices[B.indptr[:-1]].astype(np.int64), B.data.reshape(-1, K), B.shape[1])

    def __getitem__(self, rows) -> SplineRows:
        return SplineRows(self.start[rows], self.w[rows], self.m)


def _columns(rows: SplineRows) -> np.ndarray:
    """(n, K, 3) the column of each non-zero of D: 3 (start + d) + a."""
    K = rows.w.shape[1]
    return (3 * (rows.start[:, None, None] + np.arange(K)[None, :, None])
            + np.arange(3)[None, None, :])


def _segments(start: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The runs of equal ``start`` (non-decreasing: frames in time order): each run's first
    row and its start. A run's rows share their K basis functions, so a product's sum over
    frames is a sum over runs of their rows' sums (np.add.reduceat), ~m runs for n rows."""
    first = np.r_[0, np.flatnonzero(np.diff(start)) + 1]
    return first, start[first]


def normal_parts(D: Drift, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """DᵀD in upper banded form ((3K, 3m): scipy.linalg.cholesky_banded's), Dᵀy and yᵀy over
    D's frames (y (n_used, 2) at them): each a sum over frames, so the frames' sets can be
    updated by adding and subtracting (imu_sync.cost's grid moves a few frames at a time).
    DᵀD = Σ_k (b_k b_kᵀ) ⊗ (J_kᵀ J_k), b_k the row's K weights: summed over each run of
    frames on the same basis functions (_segments), then placed in the band."""
    K, n_cols = D.rows.w.shape[1], D.n_cols
    U = 3 * K - 1  # bandwidth above the diagonal
    ab = np.zeros((U + 1) * n_cols)
    dd, ee, aa, bb = (x.ravel() for x in np.meshgrid(np.arange(K), np.arange(K), np.arange(3),
                                                     np.arange(3), indexing="ij"))
    upper = 3 * dd + aa <= 3 * ee + bb  # (d, a) row, (e, b) column: the band's upper half
    dd, ee, aa, bb = dd[upper], ee[upper], aa[upper], bb[upper]
    for rows, J, _ in D.chunks():
        first, s = _segments(rows.start)
        M = np.einsum("kia,kib->kab", J, J)  # J_kᵀ J_k
        ww = rows.w[:, :, None] * rows.w[:, None, :]  # (k, K, K)
        part = np.add.reduceat((ww[:, :, :, None, None] * M[:, None, None]).reshape(
            rows.w.shape[0], -1)[:, np.flatnonzero(upper)], first, axis=0)  # (runs, terms)
        i = 3 * (s[:, None] + dd) + aa  # row and column of each term in DᵀD
        j = 3 * (s[:, None] + ee) + bb
        ab += np.bincount(((U + i - j) * n_cols + j).ravel(), part.ravel(), minlength=ab.size)
    return ab.reshape(U + 1, n_cols), D.t(y), float(np.sum(y * y))


def banded_solver(ab: np.ndarray):
    """G⁻¹ for G + RIDGE·I, G = DᵀD in upper banded form, by its Cholesky factor: a function
    of the right-hand side (r (N,) or (N, c)). With b = U + 1 the band's width, G is block
    tridiagonal in b × b blocks (diagonal D_i, above it C_i); its factor L Lᵀ has diagonal
    blocks L_i = chol(D_i − M_{i−1} M_{i−1}ᵀ) and below them M_i = C_iᵀ L_i⁻ᵀ (Golub & Van
    Loan, Matrix Computations, 4th ed., §4.5.4), each a dense b × b step in numpy: no
    scipy.linalg to import (half a second, issue 15), N / b steps."""
    U = ab.shape[0] - 1
    b, N = U + 1, ab.shape[1]
    nb = -(-N // b)
    Dg, Cg = np.zeros((nb, b, b)), np.zeros((max(nb - 1, 0), b, b))
    Dg[:, np.arange(b), np.arange(b)] = 1.0  # the padding's rows beyond N: decoupled, unit
    for o in range(U + 1):  # the o-th diagonal above the main one: G[j − o, j]
        j = np.arange(o, N)
        i, v = j - o, ab[U - o, o:]
        same = i // b == j // b
        Dg[i[same] // b, i[same] % b, j[same] % b] = v[same]
        Dg[i[same] // b, j[same] % b, i[same] % b] = v[same]
        Cg[i[~same] // b, i[~same] % b, j[~same] % b] = v[~same]
    Dg[:, np.arange(b), np.arange(b)] += RIDGE
    Li, M = np.empty_like(Dg), np.empty_like(Cg)  # L_k⁻¹ and M_k
    for k in range(nb):
        S = Dg[k] - M[k - 1] @ M[k - 1].T if k else Dg[k]
        Li[k] = np.linalg.inv(np.linalg.cholesky(S))
        if k < nb - 1:
            M[k] = (Li[k] @ Cg[k]).T  # C_kᵀ L_k⁻ᵀ
    LiT, MT = Li.transpose(0, 2, 1).copy(), M.transpose(0, 2, 1).copy()

    def solve(rhs: np.ndarray) -> np.ndarray:
        y = np.zeros((nb, b) + rhs.shape[1:])
        y.reshape((nb * b,) + rhs.shape[1:])[:N] = rhs
        for k in range(nb):  # L y = r
            y[k] = Li[k] @ (y[k] - M[k - 1] @ y[k - 1] if k else y[k])
        for k in range(nb - 2, -1, -1) if nb > 1 else ():  # Lᵀ x = y
            y[k + 1] = LiT[k + 1] @ y[k + 1]
            y[k] -= MT[k] @ y[k + 1]
        y[0] = LiT[0] @ y[0]
        return y.reshape((nb * b,) + rhs.shape[1:])[:N].copy()

    return solve


class Drift:
    """D for the frames ``used`` (default: all) of basis rows ``rows`` and Jacobians ``J``
    (n, 2, 3); the products run over CHUNK frames at a time (no per-frame copy)."""

    def __init__(self, rows: SplineRows, J: np.ndarray, used: np.ndarray | None = None):
        self.rows, self.J = rows, J
        self.used = np.ones(J.shape[0], bool) if used is None else used
        self.n_cols = 3 * rows.m

    def chunks(self):
        """(rows, J, s) of each chunk's used frames, s their places among the used ones."""
        at = 0
        for a in range(0, self.used.size, CHUNK):
            sel = np.flatnonzero(self.used[a:a + CHUNK]) + a
            if sel.size:
                yield self.rows[sel], self.J[sel], slice(at, at + sel.size)
                at += sel.size

    @property
    def n_params(self) -> int:
        """The columns these frames touch."""
        touched = np.zeros(self.n_cols, bool)
        for rows, _, _ in self.chunks():
            touched[_columns(rows)[rows.w != 0]] = True
        return int(touched.sum())

    def t(self, r: np.ndarray) -> np.ndarray:
        """Dᵀ r for r (n_used, 2) or (n_used, 2, c): (3m,) or (3m, c); each frame's
        b_k ⊗ J_kᵀ r_k summed over the runs of frames on the same basis functions."""
        r3 = r[:, :, None] if r.ndim == 2 else r
        K = self.rows.w.shape[1]
        out = np.zeros((self.rows.m, 3, r3.shape[2]))  # row 3j + a: basis j, axis a
        for rows, J, s in self.chunks():
            first, start = _segments(rows.start)
            g = np.einsum("kia,kic->kac", J, r3[s])  # J_kᵀ r_k, (k, 3, c)
            part = np.add.reduceat(rows.w[:, :, None, None] * g[:, None], first, axis=0)
            for d in range(K):  # the runs' starts differ: no index twice in one d
                out[start + d] += part[:, d]
        out = out.reshape(self.n_cols, -1)
        return out[:, 0] if r.ndim == 2 else out

    def times(self, theta: np.ndarray) -> np.ndarray:
        """D θ: (n_used, 2)."""
        out = np.empty((int(self.used.sum()), 2))
        for rows, J, s in self.chunks():
            d = np.einsum("kd,kda->ka", rows.w, theta[_columns(rows)])  # d(t_k), (k, 3)
            out[s] = np.einsum("kia,ka->ki", J, d)
        return out


def fit_bordered(D: Drift, E: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Residuals (n, 2) of the least squares y ≈ E γ + D θ, E (n, 2, c) a few dense columns
    (the IMU's scale; a bias's), RIDGE on every parameter's diagonal: the drift eliminated by
    its banded factor, then the c × c system of the dense columns (its Schur complement)."""
    ab, Dy, _ = normal_parts(D, y)
    solve = banded_solver(ab)
    DE = D.t(E)  # (3m, c)
    Gy, GE = solve(Dy), solve(DE)
    Ef = E.reshape(-1, E.shape[2])
    S = Ef.T @ Ef + RIDGE * np.eye(E.shape[2]) - DE.T @ GE
    gamma = np.linalg.solve(S, Ef.T @ y.ravel() - DE.T @ Gy)
    return y - np.einsum("kic,c->ki", E, gamma) - D.times(Gy - GE @ gamma)
