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


def normal_parts(D: Drift, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """DᵀD in upper banded form ((3K, 3m): scipy.linalg.cholesky_banded's), Dᵀy and yᵀy over
    D's frames (y (n_used, 2) at them): each a sum over frames, so the frames' sets can be
    updated by adding and subtracting (imu_sync.cost's grid moves a few frames at a time)."""
    K, n_cols = D.rows.w.shape[1], D.n_cols
    U = 3 * K - 1  # bandwidth above the diagonal
    ab = np.zeros((U + 1, n_cols))
    for rows, J, _ in D.chunks():
        c0 = 3 * int(rows.start.min())  # the chunk's columns: c0 … c0 + w − 1
        col = _columns(rows) - c0
        w = int(col.max()) + 1
        M = np.einsum("kia,kib->kab", J, J)  # J_kᵀ J_k
        part = np.zeros((U + 1) * w)
        for d in range(K):  # one (d, e, a, b) term at a time: memory of one chunk's column
            for e in range(d, K):
                ww = rows.w[:, d] * rows.w[:, e]
                for a in range(3):
                    for b in range(3) if d < e else range(a, 3):
                        part += np.bincount((U + col[:, d, a] - col[:, e, b]) * w
                                            + col[:, e, b], ww * M[:, a, b], minlength=part.size)
        ab[:, c0:c0 + w] += part.reshape(U + 1, w)
    return ab, D.t(y), float(np.sum(y * y))


def banded_solver(ab: np.ndarray):
    """G⁻¹ for G + RIDGE·I, G = DᵀD in upper banded form, by its Cholesky factor: a function
    of the right-hand side."""
    from scipy.linalg import cho_solve_banded, cholesky_banded

    ab = ab.copy()
    ab[-1] += RIDGE
    factor = cholesky_banded(ab, lower=False)
    return lambda rhs: cho_solve_banded((factor, False), rhs)


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
        """Dᵀ r for r (n_used, 2) or (n_used, 2, c): (3m,) or (3m, c)."""
        r3 = r[:, :, None] if r.ndim == 2 else r
        out = np.zeros((r3.shape[2], self.n_cols))
        for rows, J, s in self.chunks():
            col = _columns(rows).ravel()
            g = np.einsum("kia,kic->cka", J, r3[s])  # J_kᵀ r_k per column c
            for c in range(r3.shape[2]):
                vals = rows.w[:, :, None] * g[c][:, None, :]
                out[c] += np.bincount(col, vals.ravel(), minlength=self.n_cols)
        return out[0] if r.ndim == 2 else out.T

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
