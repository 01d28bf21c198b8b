"""The five methods as pure predict/update steps over one frame interval, and the one loop
that runs them (``run``). Inputs are per-frame arrays; outputs are per-frame estimates.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from armtrack_cli.filters import gaussian
from armtrack_cli.filters.particles import ess, gaussian_cloud, moments, resample_below, weights
from armtrack_cli.filters.resampling import scheme
from armtrack_cli.fuse import arm_smoother, arm_state, imu_bias, robust
from armtrack_cli.fuse.estimates import Estimates, Inputs
from armtrack_cli.fuse.models import Arm, Projection, Steps
from armtrack_cli.fuse.settings import FuseSettings

if TYPE_CHECKING:  # numba's: imported only when a particle filter runs
    from armtrack_cli.filters.splitmix import Stream


def _z(inp: Inputs, k: int) -> np.ndarray | None:
    return None if np.isnan(inp.z[k]).any() else inp.z[k]


def run_gaussian(inp: Inputs, x0: np.ndarray, P0: np.ndarray, proj: Projection, s: FuseSettings,
                 method: str, *, compiled: bool = True) -> Estimates:
    """inertial (prediction only), EKF or UKF, started at frame 0 with (x0, P0). ``compiled``:
    the numba loop (fuse/gaussian_kernel.py); this numpy loop over the pure steps of
    filters/gaussian.py is the reference it is tested against."""
    n_frames = inp.z.shape[0]
    sp = gaussian.SigmaPoints(6, alpha=s.ukf_alpha, beta=s.ukf_beta, kappa=s.ukf_kappa)
    if compiled:
        return _run_gaussian_compiled(inp, x0, P0, proj, s, method, sp)
    R = s.pixel_sigma**2 * np.eye(2)
    h, h_sigma = (lambda x: proj(x[:3])), (lambda X: proj(X[:, :3]))
    H_jac = lambda x: np.hstack([proj.jacobian(x[:3]), np.zeros((2, 3))])  # noqa: E731
    st = gaussian.Gaussian(x0, P0)
    mean, cov = np.empty((n_frames, 6)), np.empty((n_frames, 6, 6))
    codes, run_gated = np.zeros(n_frames, np.int8), 0
    for k in range(n_frames):
        if k > 0:
            if method == "ukf":
                st = gaussian.ukf_predict(st, lambda X, k=k: inp.steps.apply(k, X),
                                          inp.steps.Q(k), sp)
            else:  # linear process: the KF prediction is the EKF's (eq. 6)
                st = gaussian.kf_predict(st, inp.steps.F(k), inp.steps.Q(k), inp.steps.b(k))
        z = _z(inp, k)
        if z is not None and method != "inertial":  # the χ² gate (fuse/robust.py)
            nu, S = (gaussian.ekf_innovation(st, z, h, H_jac, R) if method == "ekf" else
                     gaussian.ukf_innovation(st, z, h_sigma, R, sp))
            codes[k], run_gated = robust.gate(gaussian.mahalanobis2(nu, S), s.gate_chi2,
                                              run_gated, s.reacquire_frames)
            if codes[k] == robust.GATED:
                z = None
            elif codes[k] == robust.REACQUIRED:
                st = gaussian.Gaussian(st.x, st.P + np.diag(_reacquire_inflation(s)))
        elif method != "inertial":  # no detection: counts toward re-acquiring as a gated one
            run_gated = robust.blind(run_gated)
        if method == "ekf":
            st = gaussian.ekf_update(st, z, h, H_jac, R)
        elif method == "ukf":
            st = gaussian.ukf_update(st, z, h_sigma, R, sp)
        mean[k], cov[k] = st.x, st.P
    return Estimates(mean, cov, None, codes)


def _reacquire_inflation(s: FuseSettings) -> np.ndarray:
    """(6,) variances added to P's diagonal when a Gaussian filter re-acquires."""
    return np.r_[np.full(3, s.reacquire_sigma_m**2), np.full(3, s.init_vel_sigma_m_s**2)]


def camera_arrays(proj: Projection) -> tuple[np.ndarray, np.ndarray]:
    """The projection as the kernels take it: (R row-major, T, fx, fy, cx, cy) and the
    distortion (k1, k2, p1, p2, k3)."""
    cam = np.concatenate([proj.R.ravel(), np.ravel(proj.T), proj._f, proj._c]).astype(float)
    return cam, np.array([proj.k1, proj.k2, proj.p1, proj.p2, proj.k3], float)


def _f64(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=float)


def _run_gaussian_compiled(inp: Inputs, x0: np.ndarray, P0: np.ndarray, proj: Projection,
                           s: FuseSettings, method: str, sp: gaussian.SigmaPoints) -> Estimates:
    from armtrack_cli.fuse import gaussian_kernel

    st = inp.steps
    cam, dist = camera_arrays(proj)
    mean, cov, codes = gaussian_kernel.run(
        _f64(x0), _f64(P0), _f64(inp.z), _f64(st.dt), _f64(st.dp), _f64(st.dv), float(st.q),
        cam, dist, float(s.pixel_sigma**2), gaussian_kernel.METHODS[method], sp.Wm, sp.Wc,
            float(sp.n + sp.lam), float(s.gate_chi2), int(s.reacquire_frames),
        _reacquire_inflation(s))
    return Estimates(mean, cov, None, codes)


def _predict_particles(x: np.ndarray, st: Steps, k: int, ace: np.ndarray,
                       eps: np.ndarray) -> np.ndarray:
    """Sample the dynamic model (eq. 10): x_k ~ N(F x + b, Q), the proposal (eq. 12);
    ace = (a, c, e), the Cholesky factor of Q; eps (N, 6) standard normals."""
    a, c, e = ace
    p, v = x[:, :3], x[:, 3:]
    return np.hstack([p + v * st.dt[k] + st.dp[k] + a * eps[:, :3],
                      v + st.dv[k] + c * eps[:, :3] + e * eps[:, 3:]])


def run_particles(inp: Inputs, x0: np.ndarray, P0: np.ndarray, proj: Projection,
                  s: FuseSettings, arm: Arm | None, *, constrained: bool,
                  compiled: bool = True, v_ref: np.ndarray | None = None,
                  packed: bool = False) -> Estimates:
    """Bootstrap PF (eqs. 12-14), or the layered-sampling PF of section III-E, steps 1-7, each
    detection gated and pf-constraint re-seeded on the ray-sphere points when its colour layer
    collapses or it re-acquires (fuse/robust.py).

    Particles are an (N, 6) array. After every resampling the weights are equal, so each
    layer's weights are just its normalised likelihood. ``compiled``: the numba kernel
    (fuse/pf_kernel.py), which draws the same random numbers and equals this numpy code, the
    reference, to round-off (tests/test_pf_kernel.py, tests/test_gating.py); pf-constraint's
    velocities move s.kalman_velocity of the way to ``v_ref`` (n, 3) after step 6.
    ``packed``: the kernel's covariances kept as their upper triangles (n, 21), all the
    means-only smoother needs (gaussian.rts_smooth): 168 bytes a frame, not 288 (issue 15)."""
    from armtrack_cli.filters import splitmix  # numba's: imported only when a particle filter runs

    rng = np.random.default_rng(s.seed)
    N = s.particles
    x = gaussian_cloud(rng, x0, P0, N)  # rng.multivariate_normal(x0, P0, size=N)
    state = splitmix.stream(rng)  # every later draw: the kernel's and the reference's alike
    n_frames = inp.z.shape[0]
    centres = arm.sphere_centres(inp.q_WB) if constrained else None  # once, for both uses
    v_gain = s.kalman_velocity if v_ref is not None else 0.0
    if compiled:  # the kernel makes the ray-sphere points of the frames that re-seed; it
        # reads v_ref only where v_gain > 0 (else a row, not an (n, 3) array of zeros)
        vel = (_f64(np.zeros((1, 3)) if v_ref is None else v_ref), float(v_gain))
        return _run_particles_compiled(inp, x, state, proj, s, arm, centres, vel, packed)
    v_ref = np.zeros((n_frames, 3)) if v_ref is None else v_ref
    return _run_particles_reference(inp, x, state, proj, s, arm, centres, v_ref, v_gain,
                                    constrained)


def _run_particles_reference(inp: Inputs, x: np.ndarray, state, proj: Projection,
                             s: FuseSettings, arm: Arm | None, centres, v_ref: np.ndarray,
                             v_gain: float, constrained: bool) -> Estimates:
    """run_particles' numpy form from the initial cloud x and the SplitMix64 ``state``: the
    reference the compiled kernel equals."""
    from armtrack_cli.filters import splitmix

    n_frames, N = inp.z.shape[0], s.particles
    points = (robust.ray_sphere_points(proj, arm, inp.z, inp.q_WB, centres) if constrained
              else np.full((n_frames, 2, 3), np.nan))
    rng = splitmix.Stream(state)
    resample = scheme(s.resampling)
    w = np.full(N, 1.0 / N)
    walk = _per_axis(s.walk_pos_m, s.walk_vel_m_s)
    mean, cov, n_eff = np.empty((n_frames, 6)), np.empty((n_frames, 6, 6)), np.empty(n_frames)
    codes, run_gated = np.zeros(n_frames, np.int8), 0
    inv2c2 = 0.5 / s.constraint_sigma_m**2
    ace = inp.steps.noise_factors()
    seen = np.isfinite(inp.z).all(axis=1)
    for k in range(n_frames):
        eps = rng.standard_normal((12 if constrained else 6, N)).T  # (N, 12): the kernel's rows
        if k > 0:  # step 1: particle prediction from p¹ (eq. 10)
            x = _predict_particles(x, inp.steps, k, ace[k], eps[:, :6])
        if seen[k]:  # step 2: weights from the colour-tracking likelihood (eq. 11), gated
            px = proj(x[:, :3])
            after_blind = run_gated >= s.reacquire_frames  # the first detection after a card
            codes[k], run_gated = robust.gate(
                robust.pixel_mahalanobis2(px, w, inp.z[k], s.pixel_sigma**2), s.gate_chi2,
                run_gated, s.reacquire_frames)
            if codes[k] == robust.REACQUIRED:
                robust.roughen(x, s.reacquire_sigma_m, s.init_vel_sigma_m_s,
                               rng.standard_normal((6, N)).T)
                px = proj(x[:, :3])
            if codes[k] != robust.GATED:
                w = _colour_layer(x, px, w, inp.z[k], points[k], codes, k, proj, s, rng,
                                  constrained, after_blind)
        else:  # no detection: counts toward re-acquiring as a gated one
            run_gated = robust.blind(run_gated)
        used = codes[k] not in (robust.NONE, robust.GATED)
        n_eff[k] = ess(w)
        if constrained:
            if used:  # step 3 (without a detection the weights are still equal)
                x = x[resample(w, rng)]
            # step 4: random-walk layer p² (eq. 17, 18)
            x = x + eps[:, 6:] * walk
            # step 5: arm-geometry likelihood (eq. 15, 16). The paper's σ is written "0.01 ms"
            # and described as a 1 cm deviation of the upper-arm length: we implement the
            # 1 cm on the length residual |E − S| − L1 (≈ the squared form with σ = 2 L1 cm).
            dc = x[:, :3] - centres[k]
            r = np.sqrt(np.einsum("ij,ij->i", dc, dc)) - arm.L1
            w = weights(-inv2c2 * r * r)
            mean[k], cov[k] = moments(x, w)
            x = x[resample(w, rng)]  # step 6
            w = np.full(N, 1.0 / N)
            x[:, 3:] += v_gain * (v_ref[k] - mean[k, 3:])  # (fuse/imu_error.py)
        else:
            mean[k], cov[k] = moments(x, w)
            if n_eff[k] < resample_below(s.pf_resample_ess) * N:
                x = x[resample(w, rng)]
                w = np.full(N, 1.0 / N)
    return Estimates(mean, cov, n_eff, codes)


def _colour_layer(x: np.ndarray, px: np.ndarray, w: np.ndarray, z: np.ndarray,
                  points: np.ndarray, codes: np.ndarray, k: int, proj: Projection,
                  s: FuseSettings, rng: Stream, constrained: bool,
                  after_blind: bool = False) -> np.ndarray:
    """Step 2's weights w ∝ w⁻ p(z | x) (eq. 11, 14) of the particles x (N, 6) whose pixels
    are px; pf-constraint first re-seeds x in place on the two ray-sphere points if it
    re-acquires, the weights collapse or ``after_blind`` (the first detection after
    reacquire_frames frames without one), and codes[k] says so (fuse/robust.py)."""
    inv2s2 = 0.5 / s.pixel_sigma**2
    w_new = weights(-inv2s2 * np.einsum("ij,ij->i", px - z, px - z), w)
    n_seed = int(np.floor(s.reseed_share * x.shape[0] + 0.5))
    if not constrained or n_seed == 0 or not (codes[k] == robust.REACQUIRED or after_blind
                                               or ess(w_new) < s.reseed_ess * x.shape[0]):
        return w_new
    m, c = moments(x[:, :3], w)  # the predicted cloud, before the colour weights
    n0 = robust.branch_split(n_seed, points, m, c, s.reseed_prior_m)
    robust.reseed(x, points, n0, s.reseed_sigma_m, rng.standard_normal((3, n_seed)).T)
    if codes[k] == robust.USED:
        codes[k] = robust.RESEEDED
    d = proj(x[:, :3]) - z
    return weights(-inv2s2 * np.einsum("ij,ij->i", d, d), w)


def _run_particles_compiled(inp: Inputs, x: np.ndarray, state: np.ndarray,
                            proj: Projection, s: FuseSettings, arm: Arm | None,
                            centres: np.ndarray | None, vel: tuple, packed: bool = False
                            ) -> Estimates:
    """centres: arm.sphere_centres (pf-constraint), or None (the plain PF); ``packed``: the
    covariances as their upper triangles (n, 21), else whole (n, 6, 6)."""
    from armtrack_cli.fuse import pf_kernel

    scheme(s.resampling)  # an unknown name is the same error as in the reference
    st, constrained = inp.steps, centres is not None
    cam, dist = camera_arrays(proj)
    walk = _per_axis(s.walk_pos_m, s.walk_vel_m_s)
    rays = robust.detection_rays(proj, inp.z) if constrained else np.empty((0, 3))
    pf_kernel.load_passes()  # before run itself: its passes' own code (once a process)
    mean, cov, n_eff, codes = pf_kernel.run(
        _f64(x), state, _f64(inp.z), _f64(st.dt), _f64(st.dp), _f64(st.dv), _f64(st.noise_factors()),
        _f64(centres) if constrained else np.zeros((inp.z.shape[0], 3)), cam, dist, walk,
        0.5 / s.pixel_sigma**2, 0.5 / s.constraint_sigma_m**2,
        float(arm.L1) if constrained else 0.0, constrained, pf_kernel.RESAMPLING[s.resampling],
        resample_below(s.pf_resample_ess), guard_args(s, rays, proj.eye), *vel,
        np.empty((inp.z.shape[0], 21 if packed else 36)))
    return Estimates(mean, cov if packed else cov.reshape(-1, 6, 6), n_eff, codes)


def guard_args(s: FuseSettings, rays: np.ndarray, eye: np.ndarray) -> tuple:
    """The kernel's gate and re-seeding arguments (pf_kernel.run): the detections' unit rays
    (n, 3) from the camera's centre eye (3,)."""
    return (_f64(rays), _f64(eye), float(s.pixel_sigma**2), float(s.gate_chi2),
            int(s.reacquire_frames), int(np.floor(s.reseed_share * s.particles + 0.5)), float(s.reseed_ess),
            float(s.reseed_sigma_m), float(s.reseed_prior_m),
            _per_axis(s.reacquire_sigma_m, s.init_vel_sigma_m_s))


def _per_axis(pos: float, vel: float) -> np.ndarray:
    """(6,) pos on p's three axes, vel on v's (np.r_'s tenth of the time: a set-up per call)."""
    return np.repeat(np.array([pos, vel], float), 3)


def run(method: str, inp: Inputs, x0: np.ndarray, P0: np.ndarray, proj: Projection,
        s: FuseSettings, arm: Arm | None, *, forward_done: Callable[[], object] | None = None,
        summary_rows: slice | None = None) -> Estimates:
    """``forward_done``: called once the compiled forward pass (the particles') is done, before
    what follows it (the smoothers, whose memory peaks): work a caller runs beside that pass
    ends there (pipeline/fuse.py: the IMU offset's check; issue 15). ``summary_rows``: the
    arm smoother's summary's frames (a window's own: pipeline/fuse_windows.py); all if None."""
    if method in ("inertial", "ekf", "ukf"):
        est = run_gaussian(inp, x0, P0, proj, s, method)
    elif method == "pf":
        est = run_particles(inp, x0, P0, proj, s, arm, constrained=False)
    elif method in ("pf-constraint", "arm-smoother"):
        if arm is None:
            raise ValueError(f"{method} needs the arm model")
        causal = method == "pf-constraint" and s.imu_error == "causal"
        est = (None if causal and s.kalman_linearise == "iterated"  # no first run to linearise
               else run_particles(inp, x0, P0, proj, s, arm, constrained=True,
                                  packed=method == "arm-smoother"))  # its means alone used
        if forward_done is not None and est is not None:  # else at the caller's end
            forward_done()
        if causal:
            est = run_error_corrected(inp, x0, P0, proj, s, arm, est)
        elif method == "pf-constraint" and s.imu_bias_window_s > 0:
            est = run_bias_corrected(inp, x0, P0, proj, s, arm, est)
        if method == "arm-smoother":  # its first pass: pf-constraint, RTS-smoothed
            first = [smooth(est, inp, s, "pf-constraint", means_only=True,  # the means,
                            in_place=True).mean]  # over est's: no second (n, 6) array
            del est  # its (n, 6, 6) covariances, not held through the smoother (issue 15)
            inp.drop_steps()  # nor the model's steps (n, 7), where inp is fuse's, run once
            return run_arm_smoother(inp, x0, P0, proj, s, arm, first, summary_rows)
    else:
        raise ValueError(f"unknown method {method!r}")
    if s.smoother == "rts":
        est = smooth(est, inp, s, method)
    return est


def run_bias_corrected(inp: Inputs, x0: np.ndarray, P0: np.ndarray, proj: Projection,
                       s: FuseSettings, arm: Arm, first: Estimates) -> Estimates:
    """pf-constraint again on a_W less the acceleration error b_k fitted to the first run's
    estimates of frames before k (fuse/imu_bias.py): still a forward filter."""
    used = np.isin(first.codes, (robust.USED, robust.REACQUIRED, robust.RESEEDED))
    t = inp.t if inp.t is not None else np.cumsum(inp.steps.dt)  # s; only differences count
    b = imu_bias.causal_bias(t, first.mean[:, :3], used, inp.steps,
                             window_s=s.imu_bias_window_s)
    est = run_particles(replace(inp, steps=imu_bias.corrected(inp.steps, b)), x0, P0, proj, s,
                        arm, constrained=True)
    summary = {"imu_bias_rms_m_s2": round(float(np.sqrt(np.mean(np.sum(b**2, axis=1)))), 4)}
    return replace(est, summary=summary)


def run_error_corrected(inp: Inputs, x0: np.ndarray, P0: np.ndarray, proj: Projection,
                        s: FuseSettings, arm: Arm, first: Estimates | None) -> Estimates:
    """pf-constraint on a_W corrected by the IMU's orientation error and accelerometer bias as
    a forward Kalman pass estimates them from the data up to each frame, its velocity given to
    the particles (fuse/imu_error.py); ``first``: the particles' first run, about which the
    pass is linearised with kalman_linearise = "passes" (None with "iterated")."""
    from armtrack_cli.fuse import imu_error  # numba's: imported only when it runs

    if inp.imu is None or inp.t is None:
        raise ValueError("imu_error = 'causal' needs the IMU samples and the frame times")
    th, ba, v, lin = imu_error.causal_errors(inp, None if first is None else first.mean, x0, P0,
                                             proj, s, arm, s.kalman_passes)
    est = run_particles(replace(inp, steps=imu_error.corrected(inp, inp.steps, th, ba),
                                q_WB=arm_smoother.corrected(inp.q_WB, th)), x0, P0, proj, s, arm,
                        constrained=True, v_ref=v)
    summary = {"orientation_error_rms_deg": round(float(np.degrees(np.sqrt(np.mean(np.sum(
        th**2, axis=1))))), 3), "accel_bias_m_s2": [round(float(v), 4) for v in ba[-1]],
        "kalman_linearisations_mean": round(float(lin.mean()), 2),
        "kalman_linearisations_max": int(lin.max())}
    return replace(est, summary=summary)


def run_arm_smoother(inp: Inputs, x0: np.ndarray, P0: np.ndarray, proj: Projection,
                     s: FuseSettings, arm: Arm, first: np.ndarray | list,
                     rows: slice | None = None) -> Estimates:
    """The orientation-aware arm smoother (fuse/arm_smoother.py) from the first pass ``first``
    (n_frames, 6) (or [it]: arm_smoother.run lets it go); its (p, v) block as every
    method's, the rest in the summary, over the frames ``rows`` (all by default)."""
    if inp.imu is None or inp.t is None:
        raise ValueError("arm-smoother needs the IMU samples and the frame times in its inputs")
    imu = [inp.take_imu()]  # arm_smoother.run's: freed once folded where inp lets them go
    rows = slice(None) if rows is None else rows
    at_rest = (int(arm_smoother.resting(imu[0], inp.t, inp.z, s)[rows].sum())
               if s.rest_velocity_sd_m_s > 0 else None)
    r = arm_smoother.run(imu, inp.t, inp.z, inp.q_WB, first, x0, P0, proj, s, arm)
    x = r.x[rows]  # a view: the frames summarised
    th = x[:, arm_smoother.TH]
    summary = {"detections_gated": int(r.gated[rows].sum()),
               "smoother_iterations_run": r.iterations, "start_runs_moved": r.runs_moved,
               "accel_bias_m_s2": [round(float(v), 4) for v in x[-1, arm_smoother.BA]],
               "orientation_error_rms_deg": round(float(np.degrees(
                   np.sqrt(np.mean(np.sum(th**2, axis=1))))), 3)}
    if r.gyro:
        summary["gyro_bias_deg_s"] = [round(float(v), 4) for v in
                                      np.degrees(x[-1, arm_smoother.BG])]
    summary["orientation_error_model"] = "gyro" if r.gyro else "gauss-markov"
    if s.shoulder == "drifting":
        sh = x[:, arm_state.shoulder_slice(r.x.shape[1])]
        summary["shoulder_mean_m"] = [round(float(v), 4) for v in sh.mean(axis=0)]
        summary["shoulder_drift_max_m"] = round(float(np.linalg.norm(
            sh - arm.shoulder, axis=1).max()), 4)
        ell = x[:, arm_state.drift_slice(r.x.shape[1]).start]
        summary["upper_arm_change_m"] = [round(float(v), 4) for v in (ell.min(), ell.max())]
    if at_rest is not None:
        summary["frames_at_rest"] = at_rest
    return Estimates(r.x[:, :6].copy(), None, None, q_WB=r.q_WB, elbow_var=r.elbow_var,
                     summary=summary, var=r.var)  # (p, v) alone: not the whole state held


SMOOTH_BLOCK = 1024  # frames whose RTS gains are computed at once (a 4,096-frame block's
#                     temporaries were ~8 MB, the peak of fuse's first pass at 60 minutes)


def smooth(est: Estimates, inp: Inputs, s: FuseSettings, method: str, *,
           means_only: bool = False, in_place: bool = False) -> Estimates:
    """Offline: each frame's estimate also uses every later detection. The filtered Gaussian
    (for particle filters, the particles' weighted mean and covariance) is smoothed backwards
    through the same linear dynamics; the random-walk layer of pf-constraint adds its variance
    to the process noise of each step. ``means_only``: the means alone (cov None), all the
    arm smoother's first pass takes; ``in_place``: written over est.mean (whose caller is
    done with it)."""
    walk = np.diag(np.r_[np.full(3, s.walk_pos_m), np.full(3, s.walk_vel_m_s)] ** 2) \
        if method == "pf-constraint" else 0.0

    def steps(lo: int, hi: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        F, b, Q = inp.steps.stacked(lo, hi)  # a block at a time: memory flat with the length
        return F, b, Q + walk + 1e-12 * np.eye(6)

    x, P = gaussian.rts_smooth(est.mean, est.cov, steps=steps, means_only=means_only,
                               P_add=1e-12 * np.eye(6), block=SMOOTH_BLOCK,
                               in_place=in_place)  # P None with means_only
    return Estimates(x, P, est.ess, est.codes)
