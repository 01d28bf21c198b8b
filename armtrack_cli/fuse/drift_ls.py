"""The drift columns of the IMU clock-offset fit (fuse/imu_sync.py) without a dense matrix.

The fit's drift is d(t) = Σ_j θ_j B_j(t), a spline with K = degree + 1 basis functions
non-zero at any time, seen in the image as J_k d(t_k) (eq. 7's Jacobian J_k, 2 × 3). Its
columns D (2 rows per frame, 3 per basis function, column 3j + a for axis a) have 3K
non-zeros a row, so DᵀD is banded (3K − 1 off the diagonal) and the least squares cost O(n)
in time and memory, where the dense D (2n × 3m, m ∝ n) cost O(n³) and O(n²): a 60-minute
session's dense basis alone was 1.6 GB. Products with D and Dᵀ are formed frame by frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

RIDGE = 1e-9  # added to the normal equations' diagonal (keeps an unseen basis function at 0)


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


def normal_parts(rows: SplineRows, J: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                                           float]:
    """DᵀD in upper banded form ((3K, 3m): scipy.linalg.cholesky_banded's), Dᵀy and yᵀy over
    the frames given: each a sum over frames, so the frames' sets can be updated by adding
    and subtracting (imu_sync.cost's grid moves a few frames at a time)."""
    K, n_cols = rows.w.shape[1], 3 * rows.m
    U = 3 * K - 1  # bandwidth above the diagonal
    col = _columns(rows)
    M = np.einsum("kia,kib->kab", J, J)  # J_kᵀ J_k
    ab = np.zeros((U + 1) * n_cols)
    for d in range(K):  # one (d, e, a, b) term at a time: memory of one frame-long column
        for e in range(d, K):
            ww = rows.w[:, d] * rows.w[:, e]
            for a in range(3):
                for b in range(3) if d < e else range(a, 3):
                    ab += np.bincount((U + col[:, d, a] - col[:, e, b]) * n_cols + col[:, e, b],
                                      ww * M[:, a, b], minlength=ab.size)
    ab = ab.reshape(U + 1, n_cols)
    return ab, Drift(rows, J).t(y), float(np.sum(y * y))


def banded_solver(ab: np.ndarray):
    """G⁻¹ for G + RIDGE·I, G = DᵀD in upper banded form, by its Cholesky factor: a function
    of the right-hand side."""
    from scipy.linalg import cho_solve_banded, cholesky_banded

    ab = ab.copy()
    ab[-1] += RIDGE
    factor = cholesky_banded(ab, lower=False)
    return lambda rhs: cho_solve_banded((factor, False), rhs)


class Drift:
    """D for frames with basis rows ``rows`` and Jacobians ``J`` (n, 2, 3)."""

    def __init__(self, rows: SplineRows, J: np.ndarray):
        self.rows, self.J = rows, J
        self._col = _columns(rows)
        self.n_cols = 3 * rows.m

    @property
    def used(self) -> int:
        """The columns these frames touch."""
        return int(np.unique(self._col[self.rows.w != 0]).size)

    def t(self, r: np.ndarray) -> np.ndarray:
        """Dᵀ r for r (n, 2): (3m,)."""
        g = np.einsum("kia,ki->ka", self.J, r)  # J_kᵀ r_k
        vals = self.rows.w[:, :, None] * g[:, None, :]
        return np.bincount(self._col.ravel(), vals.ravel(), minlength=self.n_cols)

    def times(self, theta: np.ndarray) -> np.ndarray:
        """D θ: (n, 2)."""
        d = np.einsum("kd,kda->ka", self.rows.w, theta[self._col])  # d(t_k), (n, 3)
        return np.einsum("kia,ka->ki", self.J, d)


def fit_bordered(D: Drift, E: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Residuals (n, 2) of the least squares y ≈ E γ + D θ, E (n, 2, c) a few dense columns
    (the IMU's scale; a bias's), RIDGE on every parameter's diagonal: the drift eliminated by
    its banded factor, then the c × c system of the dense columns (its Schur complement)."""
    ab, Dy, _ = normal_parts(D.rows, D.J, y)
    solve = banded_solver(ab)
    DE = np.stack([D.t(E[:, :, i]) for i in range(E.shape[2])], axis=1)  # (3m, c)
    Gy, GE = solve(Dy), solve(DE)
    Ef = E.reshape(-1, E.shape[2])
    S = Ef.T @ Ef + RIDGE * np.eye(E.shape[2]) - DE.T @ GE
    gamma = np.linalg.solve(S, Ef.T @ y.ravel() - DE.T @ Gy)
    return y - np.einsum("kic,c->ki", E, gamma) - D.times(Gy - GE @ gamma)
