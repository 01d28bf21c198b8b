"""Filter, smoother and resampling speed (make bench): the Gaussian filters against FilterPy
2.0 on the same arm model, the compiled particle filters against their numpy reference, the
smoother against its step-at-a-time form.

FilterPy's UKF reuses the propagated sigma points in ``update``; here they are redrawn from
(x⁻, P⁻) before each update, which is the standard UKF that armtrack implements, so the two
must agree to round-off (the difference is reported; tests/test_fuse_filters.py asserts it).
Times are CPU seconds of this process (one core: the benchmark pins BLAS to one thread).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from timing import best_of  # noqa: I001  (benchmarks/ is on sys.path)

from armtrack_cli.filters import gaussian
from armtrack_cli.filters.resampling import SCHEMES
from armtrack_cli.fuse.methods import Inputs, run_gaussian, run_particles


def gaussian_vs_filterpy(inp: Inputs, proj, x0, P0, s) -> list[tuple]:
    from filterpy.kalman import ExtendedKalmanFilter, MerweScaledSigmaPoints, UnscentedKalmanFilter

    n_frames = inp.z.shape[0]
    R = s.pixel_sigma**2 * np.eye(2)
    zs = [None if np.isnan(z).any() else z for z in inp.z]
    Hj = lambda x: np.hstack([proj.jacobian(x[:3]), np.zeros((2, 3))])  # noqa: E731
    hx = lambda x: proj(x[:3])  # noqa: E731

    def ours_ekf():
        st = gaussian.Gaussian(x0, P0)
        for k in range(1, n_frames):
            st = gaussian.kf_predict(st, inp.steps.F(k), inp.steps.Q(k), inp.steps.b(k))
            st = gaussian.ekf_update(st, zs[k], hx, Hj, R)
        return st.x

    def fp_ekf():
        f = ExtendedKalmanFilter(6, 2)
        f.x, f.P, f.R = x0.copy(), P0.copy(), R
        for k in range(1, n_frames):
            f.F, f.Q = inp.steps.F(k), inp.steps.Q(k)
            f.B = np.eye(6)
            f.predict(u=inp.steps.b(k))
            if zs[k] is not None:
                f.update(zs[k], Hj, hx)
        return f.x

    sp = gaussian.SigmaPoints(6, alpha=0.5, beta=2.0, kappa=0.0)

    def ours_ukf():
        st = gaussian.Gaussian(x0, P0)
        for k in range(1, n_frames):
            st = gaussian.ukf_predict(st, lambda X, k=k: inp.steps.apply(k, X), inp.steps.Q(k), sp)
            st = gaussian.ukf_update(st, zs[k], lambda X: proj(X[:, :3]), R, sp)
        return st.x

    def fp_ukf():
        pts = MerweScaledSigmaPoints(6, alpha=0.5, beta=2.0, kappa=0.0)
        f = UnscentedKalmanFilter(6, 2, dt=1.0, hx=hx, fx=lambda x, dt, k=0: x, points=pts)
        f.x, f.P, f.R = x0.copy(), P0.copy(), R
        for k in range(1, n_frames):
            f.Q = inp.steps.Q(k)
            f.predict(fx=lambda x, dt, k=k: inp.steps.apply(k, x))
            if zs[k] is not None:
                f.sigmas_f = pts.sigma_points(f.x, f.P)  # the standard UKF: redraw from (x⁻, P⁻)
                f.update(zs[k])
        return f.x

    rows = []
    for name, ours, theirs in (("EKF", ours_ekf, fp_ekf), ("UKF", ours_ukf, fp_ukf)):
        diff = float(np.abs(ours() - theirs()).max())
        method = name.lower()
        s2 = dataclasses.replace(s, method=method)
        compiled = lambda m=method, s2=s2: run_gaussian(inp, x0, P0, proj, s2, m)  # noqa: E731
        compiled()  # the kernel loaded (compiled once per install)
        t_c, t_o, t_f = best_of(compiled, runs=7), best_of(ours), best_of(theirs)
        n = n_frames - 1
        rows.append((name, n, t_c / n * 1e6, t_o / n * 1e6, t_f / n * 1e6, t_f / t_c,
                     step_diff(name, inp, proj, x0, P0, R, sp), diff))
    return rows


def step_diff(kind: str, inp: Inputs, proj, x0, P0, R, sp) -> float:
    """Largest difference of one predict + update started from the same prior (FilterPy's
    state at every step): the maths compared without the drift of a long run."""
    from filterpy.kalman import ExtendedKalmanFilter, MerweScaledSigmaPoints, UnscentedKalmanFilter

    zs = [None if np.isnan(z).any() else z for z in inp.z]
    Hj = lambda x: np.hstack([proj.jacobian(x[:3]), np.zeros((2, 3))])  # noqa: E731
    hx = lambda x: proj(x[:3])  # noqa: E731
    if kind == "EKF":
        f = ExtendedKalmanFilter(6, 2)
    else:
        pts = MerweScaledSigmaPoints(6, alpha=0.5, beta=2.0, kappa=0.0)
        f = UnscentedKalmanFilter(6, 2, dt=1.0, hx=hx, fx=lambda x, dt: x, points=pts)
    f.x, f.P, f.R = x0.copy(), P0.copy(), R
    worst = 0.0
    for k in range(1, inp.z.shape[0]):
        prior = gaussian.Gaussian(f.x.copy(), f.P.copy())
        if kind == "EKF":
            f.F, f.Q, f.B = inp.steps.F(k), inp.steps.Q(k), np.eye(6)
            f.predict(u=inp.steps.b(k))
            if zs[k] is not None:
                f.update(zs[k], Hj, hx)
            st = gaussian.ekf_update(gaussian.kf_predict(prior, inp.steps.F(k), inp.steps.Q(k),
                                           inp.steps.b(k)), zs[k], hx, Hj, R)
        else:
            f.Q = inp.steps.Q(k)
            f.predict(fx=lambda x, dt, k=k: inp.steps.apply(k, x))
            if zs[k] is not None:
                f.sigmas_f = pts.sigma_points(f.x, f.P)
                f.update(zs[k])
            st = gaussian.ukf_update(gaussian.ukf_predict(prior, lambda X, k=k: inp.steps.apply(k, X),
                                            inp.steps.Q(k), sp),
                              zs[k], lambda X: proj(X[:, :3]), R, sp)
        worst = max(worst, float(np.abs(st.x - f.x).max()))
    return worst


def pf_vs_reference(inp: Inputs, proj, arm, x0, P0, s, sizes=(500, 5000, 50000)) -> list[tuple]:
    """The forward particle filters (no smoother), compiled kernel against the numpy
    reference, on the same inputs and seed (so the same draws)."""
    rows = []
    for method, constrained in (("pf-constraint", True), ("pf", False)):
        for n in sizes:
            s2 = dataclasses.replace(s, particles=n, method=method)
            fast = lambda s2=s2, c=constrained: run_particles(  # noqa: E731
                inp, x0, P0, proj, s2, arm, constrained=c)
            ref = lambda s2=s2, c=constrained: run_particles(  # noqa: E731
                inp, x0, P0, proj, s2, arm, constrained=c, compiled=False)
            fast()
            t_fast = best_of(fast, runs=15 if n < 50000 else 3)  # best of many: a shared machine
            t_ref = best_of(ref, runs=3 if n < 50000 else 1)
            rows.append((method, n, inp.z.shape[0], t_fast, t_ref))
    return rows


def smoother_rows(n_frames: int = 18000) -> list[tuple]:
    """smooth()'s inputs and the RTS smoother on a 10-minute session (random steps and
    filtered states: the work does not depend on the values), against the former per-frame
    loops, which are kept here as the reference: the results are identical (asserted)."""
    from armtrack_cli.fuse.models import Steps

    rng = np.random.default_rng(0)
    dt = np.r_[0.0, np.full(n_frames - 1, 1 / 30)]
    st = Steps(dt, rng.normal(0, 1e-3, (n_frames, 3)), rng.normal(0, 1e-2, (n_frames, 3)), 0.01)
    x = rng.normal(size=(n_frames, 6))
    A = rng.normal(size=(n_frames, 6, 6))
    P = A @ np.swapaxes(A, 1, 2) * 1e-3 + 1e-4 * np.eye(6)

    def build_loops():
        return (np.stack([st.F(k) for k in range(n_frames)]),
                np.stack([st.b(k) for k in range(n_frames)]),
                np.stack([st.Q(k) for k in range(n_frames)]))

    def rts_steps(F, b, Q):
        xs, Ps = x.copy(), P.copy()
        for k in range(n_frames - 2, -1, -1):
            Fk = F[k + 1]
            xp = Fk @ x[k] + b[k + 1]
            Pp = Fk @ P[k] @ Fk.T + Q[k + 1]
            C = np.linalg.solve(Pp.T, (P[k] @ Fk.T).T).T
            xs[k] = x[k] + C @ (xs[k + 1] - xp)
            Pk = P[k] + C @ (Ps[k + 1] - Pp) @ C.T
            Ps[k] = 0.5 * (Pk + Pk.T)
        return xs, Ps

    F, b, Q = st.stacked()
    assert all(np.array_equal(u, v) for u, v in zip((F, b, Q), build_loops()))
    assert all(np.array_equal(u, v) for u, v in zip(gaussian.rts_smooth(x, P, F, b, Q),
                                                    rts_steps(F, b, Q)))
    return [("F, b, Q for every frame (smooth)", best_of(st.stacked), best_of(build_loops)),
            ("RTS smoother", best_of(lambda: gaussian.rts_smooth(x, P, F, b, Q)),
             best_of(lambda: rts_steps(F, b, Q)))]


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
