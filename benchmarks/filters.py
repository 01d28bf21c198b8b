"""Filter and resampling speed against FilterPy 2.0 on the same arm model (make bench).

Both implementations run the same maths: FilterPy's UKF reuses the propagated sigma points in
``update``; here they are redrawn from (x⁻, P⁻) before each update, which is the standard UKF
that armtrack implements, so the two must agree to round-off (the difference is reported).
"""

from __future__ import annotations

import numpy as np
from timing import best_of  # noqa: I001  (benchmarks/ is on sys.path)

from armtrack_cli.filters import gaussian as G
from armtrack_cli.filters.resampling import SCHEMES
from armtrack_cli.fuse.methods import Inputs


def gaussian_vs_filterpy(inp: Inputs, proj, x0, P0, sigma_px=4.0) -> list[tuple]:
    from filterpy.kalman import ExtendedKalmanFilter, MerweScaledSigmaPoints, UnscentedKalmanFilter

    K = inp.z.shape[0]
    R = sigma_px**2 * np.eye(2)
    zs = [None if np.isnan(z).any() else z for z in inp.z]
    Hj = lambda x: np.hstack([proj.jacobian(x[:3]), np.zeros((2, 3))])  # noqa: E731
    hx = lambda x: proj(x[:3])  # noqa: E731

    def ours_ekf():
        st = G.Gaussian(x0, P0)
        for k in range(1, K):
            st = G.kf_predict(st, inp.steps.F(k), inp.steps.Q(k), inp.steps.b(k))
            st = G.ekf_update(st, zs[k], hx, Hj, R)
        return st.x

    def fp_ekf():
        f = ExtendedKalmanFilter(6, 2)
        f.x, f.P, f.R = x0.copy(), P0.copy(), R
        for k in range(1, K):
            f.F, f.Q = inp.steps.F(k), inp.steps.Q(k)
            f.B = np.eye(6)
            f.predict(u=inp.steps.b(k))
            if zs[k] is not None:
                f.update(zs[k], Hj, hx)
        return f.x

    sp = G.SigmaPoints(6, 0.5, 2.0, 0.0)

    def ours_ukf():
        st = G.Gaussian(x0, P0)
        for k in range(1, K):
            st = G.ukf_predict(st, lambda X, k=k: inp.steps.apply(k, X), inp.steps.Q(k), sp)
            st = G.ukf_update(st, zs[k], lambda X: proj(X[:, :3]), R, sp)
        return st.x

    def fp_ukf():
        pts = MerweScaledSigmaPoints(6, alpha=0.5, beta=2.0, kappa=0.0)
        f = UnscentedKalmanFilter(6, 2, dt=1.0, hx=hx, fx=lambda x, dt, k=0: x, points=pts)
        f.x, f.P, f.R = x0.copy(), P0.copy(), R
        for k in range(1, K):
            f.Q = inp.steps.Q(k)
            f.predict(fx=lambda x, dt, k=k: inp.steps.apply(k, x))
            if zs[k] is not None:
                f.sigmas_f = pts.sigma_points(f.x, f.P)  # the standard UKF: redraw from (x⁻, P⁻)
                f.update(zs[k])
        return f.x

    def step_diff(kind: str) -> float:
        """Largest difference of one predict + update started from the same prior (FilterPy's
        state at every step): the maths compared without the drift of a long run."""
        if kind == "EKF":
            f = ExtendedKalmanFilter(6, 2)
        else:
            pts = MerweScaledSigmaPoints(6, alpha=0.5, beta=2.0, kappa=0.0)
            f = UnscentedKalmanFilter(6, 2, dt=1.0, hx=hx, fx=lambda x, dt: x, points=pts)
        f.x, f.P, f.R = x0.copy(), P0.copy(), R
        worst = 0.0
        for k in range(1, K):
            prior = G.Gaussian(f.x.copy(), f.P.copy())
            if kind == "EKF":
                f.F, f.Q, f.B = inp.steps.F(k), inp.steps.Q(k), np.eye(6)
                f.predict(u=inp.steps.b(k))
                if zs[k] is not None:
                    f.update(zs[k], Hj, hx)
                st = G.ekf_update(G.kf_predict(prior, inp.steps.F(k), inp.steps.Q(k),
                                               inp.steps.b(k)), zs[k], hx, Hj, R)
            else:
                f.Q = inp.steps.Q(k)
                f.predict(fx=lambda x, dt, k=k: inp.steps.apply(k, x))
                if zs[k] is not None:
                    f.sigmas_f = pts.sigma_points(f.x, f.P)
                    f.update(zs[k])
                st = G.ukf_update(G.ukf_predict(prior, lambda X, k=k: inp.steps.apply(k, X),
                                                inp.steps.Q(k), sp),
                                  zs[k], lambda X: proj(X[:, :3]), R, sp)
            worst = max(worst, float(np.abs(st.x - f.x).max()))
        return worst

    rows = []
    for name, ours, theirs in (("EKF", ours_ekf, fp_ekf), ("UKF", ours_ukf, fp_ukf)):
        diff = float(np.abs(ours() - theirs()).max())
        t_o, t_f = best_of(ours), best_of(theirs)
        rows.append((name, K - 1, t_o / (K - 1) * 1e6, t_f / (K - 1) * 1e6, t_f / t_o,
                     step_diff(name), diff))
    return rows


def resampling_vs_filterpy(sizes=(500, 5000, 50000)) -> list[tuple]:
    from filterpy.monte_carlo import (
        multinomial_resample,
        residual_resample,
        stratified_resample,
        systematic_resample,
    )

    theirs = {"residual": residual_resample, "systematic": systematic_resample,
              "stratified": stratified_resample, "multinomial": multinomial_resample}
    rng = np.random.default_rng(0)
    rows = []
    for n in sizes:
        w = rng.gamma(0.5, size=n)
        w /= w.sum()
        reps = max(3, 200000 // n)
        for name, fn in SCHEMES.items():
            t_o = best_of(lambda fn=fn, r=reps, w=w: [fn(w, rng) for _ in range(r)]) / reps
            t_f = best_of(lambda name=name, r=reps, w=w: [theirs[name](w) for _ in range(r)]) / reps
            rows.append((name, n, t_o * 1e6, t_f * 1e6))
    return rows
