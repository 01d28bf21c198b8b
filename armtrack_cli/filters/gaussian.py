"""Gaussian filters on one state (x, P): Kalman, extended and unscented, as pure functions.

Every ``update`` accepts ``z=None`` (a missing measurement) and returns the state unchanged.
Functions f, h take time-first arrays (..., n) so the UKF pushes all sigma points at once.
"""

from __future__ import annotations

from dataclasses import KW_ONLY, dataclass
from functools import cached_property

import numpy as np


@dataclass(frozen=True)
class Gaussian:
    x: np.ndarray  # (n,)
    P: np.ndarray  # (n, n)


def _joseph(P, gain, H, R):
    """Joseph form (I − gain H) P (I − gain H)ᵀ + gain R gainᵀ: symmetric and positive
    whatever the gain is."""
    I_KH = np.eye(P.shape[0]) - gain @ H
    return I_KH @ P @ I_KH.T + gain @ R @ gain.T


def kf_predict(s: Gaussian, F: np.ndarray, Q: np.ndarray, b: np.ndarray | None = None) -> Gaussian:
    """x⁻ = F x + b, P⁻ = F P Fᵀ + Q."""
    x = F @ s.x + (0 if b is None else b)
    return Gaussian(x, F @ s.P @ F.T + Q)


def kf_update(s: Gaussian, z: np.ndarray | None, H: np.ndarray, R: np.ndarray) -> Gaussian:
    """gain = P Hᵀ (H P Hᵀ + R)⁻¹; x = x + gain (z − H x)."""
    if z is None:
        return s
    S = H @ s.P @ H.T + R
    gain = np.linalg.solve(S.T, (s.P @ H.T).T).T
    return Gaussian(s.x + gain @ (z - H @ s.x), _joseph(s.P, gain, H, R))


def mahalanobis2(nu: np.ndarray, S: np.ndarray) -> float:
    """νᵀ S⁻¹ ν: the squared Mahalanobis length of an innovation ν (m,) with covariance S
    (m, m); χ²(m)-distributed when the filter is consistent (Bar-Shalom et al. 2001, 5.4)."""
    return float(nu @ np.linalg.solve(S, nu))


def ekf_innovation(s: Gaussian, z: np.ndarray, h, H_jac, R: np.ndarray) -> tuple[np.ndarray,
                                                                                np.ndarray]:
    """The EKF's innovation ν = z − h(x⁻) and its covariance S = H P Hᵀ + R."""
    H = H_jac(s.x)
    return z - h(s.x), H @ s.P @ H.T + R


def ukf_innovation(s: Gaussian, z: np.ndarray, h, R: np.ndarray,
                   sp: SigmaPoints) -> tuple[np.ndarray, np.ndarray]:
    """The UKF's innovation ν = z − ẑ and P_zz = Σ Wc dz dzᵀ + R over Z = h(X)."""
    Wm, Wc = sp.weights()
    Z = h(sp.points(s.x, s.P))
    zm = Wm @ Z
    dz = Z - zm
    return z - zm, (Wc[:, None] * dz).T @ dz + R


def ekf_update(s: Gaussian, z: np.ndarray | None, h, H_jac, R: np.ndarray) -> Gaussian:
    """Linearise h at the prior mean: H = ∂h/∂x (x⁻); innovation z − h(x⁻)."""
    if z is None:
        return s
    H = H_jac(s.x)
    S = H @ s.P @ H.T + R
    gain = np.linalg.solve(S.T, (s.P @ H.T).T).T
    return Gaussian(s.x + gain @ (z - h(s.x)), _joseph(s.P, gain, H, R))


@dataclass(frozen=True)
class SigmaPoints:
    """Van der Merwe's scaled sigma points (Wan & van der Merwe 2000); the weights Wm, Wc are
    computed once, when the set is made."""

    n: int
    _: KW_ONLY
    alpha: float = 0.5
    beta: float = 2.0
    kappa: float = 0.0

    @property
    def lam(self) -> float:
        """λ = α² (n + κ) − n."""
        return self.alpha**2 * (self.n + self.kappa) - self.n

    @cached_property
    def _weights(self) -> tuple[np.ndarray, np.ndarray]:
        c = 0.5 / (self.n + self.lam)
        Wm = np.full(2 * self.n + 1, c)  # Wm_i = Wc_i = 1 / 2(n + λ), i ≥ 1
        Wc = Wm.copy()
        Wm[0] = self.lam / (self.n + self.lam)  # Wm_0 = λ / (n + λ)
        Wc[0] = Wm[0] + 1 - self.alpha**2 + self.beta  # Wc_0 = Wm_0 + 1 − α² + β
        Wm.flags.writeable = Wc.flags.writeable = False
        return Wm, Wc

    @property
    def Wm(self) -> np.ndarray:
        return self._weights[0]

    @property
    def Wc(self) -> np.ndarray:
        return self._weights[1]

    def weights(self) -> tuple[np.ndarray, np.ndarray]:
        return self._weights

    def points(self, x: np.ndarray, P: np.ndarray) -> np.ndarray:
        """(2n+1, n): x, x ± columns of √((n+λ) P)."""
        L = np.linalg.cholesky((self.n + self.lam) * P)
        return np.vstack([x, x + L.T, x - L.T])


def ukf_predict(s: Gaussian, f, Q: np.ndarray, sp: SigmaPoints) -> Gaussian:
    """Sigma points through f (vectorised over the first axis)."""
    Wm, Wc = sp.weights()
    Y = f(sp.points(s.x, s.P))
    x = Wm @ Y
    d = Y - x
    return Gaussian(x, (Wc[:, None] * d).T @ d + Q)


def ukf_update(s: Gaussian, z: np.ndarray | None, h, R: np.ndarray, sp: SigmaPoints) -> Gaussian:
    """Measurement sigma points Z = h(X); gain = P_xz P_zz⁻¹."""
    if z is None:
        return s
    Wm, Wc = sp.weights()
    X = sp.points(s.x, s.P)
    Z = h(X)
    zm = Wm @ Z
    dz, dx = Z - zm, X - s.x
    Pzz = (Wc[:, None] * dz).T @ dz + R
    Pxz = (Wc[:, None] * dx).T @ dz
    gain = np.linalg.solve(Pzz.T, Pxz.T).T
    P = s.P - gain @ Pzz @ gain.T
    return Gaussian(s.x + gain @ (z - zm), 0.5 * (P + P.T))


def rts_smooth(x: np.ndarray, P: np.ndarray, F: np.ndarray | None = None,
               b: np.ndarray | None = None, Q: np.ndarray | None = None, *, steps=None,
               block: int = 4096, means_only: bool = False, P_add: np.ndarray | float = 0.0,
               in_place: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
    """Rauch-Tung-Striebel fixed-interval smoother.

    x (n_steps, n), P (n_steps, n, n): filtered means and covariances (or, with
    ``means_only``, P (n_steps, n (n + 1) / 2): their upper triangles row by row, ``unpacked``
    a block at a time); F (n_steps, n, n),
    b (n_steps, n), Q (n_steps, n, n): the step into k (x_k = F_k x_{k-1} + b_k + w,
    w ~ N(0, Q_k); index 0 unused). The predictions and gains depend only on filtered values,
    so they are computed for ``block`` steps at once (memory stays flat with the length):
    x⁻_{k+1} = F_{k+1} x_k + b_{k+1}, P⁻_{k+1} = F_{k+1} P_k F_{k+1}ᵀ + Q_{k+1},
    gain_k = P_k F_{k+1}ᵀ (P⁻_{k+1})⁻¹; then backwards
    x^s_k = x_k + gain_k (x^s_{k+1} − x⁻_{k+1}),
    P^s_k = P_k + gain_k (P^s_{k+1} − P⁻_{k+1}) gain_kᵀ (Rauch, Tung & Striebel 1965).
    Instead of F, b, Q: ``steps(lo, hi)`` giving their rows [lo, hi), one block at a time, so
    that they are never held for the whole session. ``means_only``: the smoothed means alone
    (they need no smoothed covariance), Ps None. ``P_add``: added to every P (a jitter), a
    block at a time, so that P is never copied whole. ``in_place``: the smoothed means written
    over x (returned as xs), which each step reads before it writes (the steps go backwards).
    """
    if steps is None:
        steps = lambda lo, hi: (F[lo:hi], b[lo:hi], Q[lo:hi])  # noqa: E731
    if P.ndim == 2 and not means_only:
        raise ValueError("packed covariances (upper triangles) give the smoothed means alone")
    xs, Ps = x if in_place else x.copy(), None if means_only else P + P_add
    for stop in range(x.shape[0] - 1, 0, -block):  # steps k in [start, stop), backwards
        start = max(0, stop - block)
        Fn, bn, Qn = steps(start + 1, stop + 1)
        FnT = np.swapaxes(Fn, 1, 2)
        xp = np.einsum("kij,kj->ki", Fn, x[start:stop]) + bn
        Pb = unpacked(P[start:stop], x.shape[1]) + P_add
        Pp = Fn @ Pb @ FnT + Qn
        gain = np.swapaxes(np.linalg.solve(np.swapaxes(Pp, 1, 2),
                                           np.swapaxes(Pb @ FnT, 1, 2)), 1, 2)
        for j in range(stop - start - 1, -1, -1):
            k = start + j
            xs[k] = x[k] + gain[j] @ (xs[k + 1] - xp[j])
            if means_only:
                continue
            Pk = Pb[j] + gain[j] @ (Ps[k + 1] - Pp[j]) @ gain[j].T
            Ps[k] = 0.5 * (Pk + Pk.T)
    return xs, Ps


def unpacked(tri: np.ndarray, n: int) -> np.ndarray:
    """(m, n, n) symmetric matrices from their upper triangles tri (m, n (n + 1) / 2), row by
    row (np.triu_indices(n)'s order); full ones (m, n, n) as they are."""
    if tri.ndim == 3:
        return tri
    iu = np.triu_indices(n)
    out = np.empty((tri.shape[0], n, n))
    out[:, iu[0], iu[1]] = tri
    out[:, iu[1], iu[0]] = tri
    return out
