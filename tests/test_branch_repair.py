"""fuse/branch_repair.py on a constructed wrist whose truth is known: a camera at the origin, a
sphere of radius L1 about a moving centre, the wrist on it, its path the exact double
integral of a piecewise-constant acceleration (the process steps), and each frame's two roots
of the ray through the wrist in closed form (their depths sum to −2 d·(o − c)). Also the
arm smoother's stopping rule (arm_smoother.converged) on step sequences worked by hand."""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.fuse import arm_smoother, branch_repair

N, DT, L1 = 240, 1 / 30, 0.3


def _session(accel_error: float = 0.0, seed: int = 3):
    """(truth p (N, 3), roots (N, 2, 3) with root 0 the truth, F, b of the (p, v) process)
    whose IMU acceleration is the truth's plus a constant error of accel_error m/s² and white
    noise of 0.05 m/s² (seeded)."""
    rng = np.random.default_rng(seed)
    t = np.arange(N) * DT
    amp, om = np.array([0.15, 0.1, 0.08]), np.array([2.1, 1.7, 3.3])
    a = -amp * om**2 * np.sin(om * t[:, None])  # about p₀ + amp sin(ω t)
    p, v = np.zeros((N, 3)), np.zeros((N, 3))
    p[0], v[0] = [0.1, -0.05, 1.0], amp * om
    for k in range(1, N):  # exact for an acceleration held over each step
        v[k] = v[k - 1] + a[k] * DT
        p[k] = p[k - 1] + v[k - 1] * DT + a[k] * DT**2 / 2
    centre = p - L1 * _towards_camera(p, t)
    d = p / np.linalg.norm(p, axis=1, keepdims=True)  # the ray from the camera at 0
    s_true = np.linalg.norm(p, axis=1)
    s_other = -2 * np.sum(d * -centre, axis=1) - s_true
    roots = np.stack([p, s_other[:, None] * d], axis=1)
    F = np.tile(np.eye(6), (N, 1, 1))
    F[:, :3, 3:] = DT * np.eye(3)
    am = a + accel_error + 0.05 * rng.standard_normal((N, 3))
    b = np.c_[am * DT**2 / 2, am * DT]
    return p, roots, F, b


def _towards_camera(p, t):
    """(N, 3) unit: from the sphere's centre to the wrist, mostly towards the camera."""
    w = -p / np.linalg.norm(p, axis=1, keepdims=True) + np.c_[0.3 * np.sin(t),
                                                              0.2 * np.cos(0.7 * t), 0 * t]
    return w / np.linalg.norm(w, axis=1, keepdims=True)


def _steps(F, b):
    return lambda lo, hi: (F[lo:hi], b[lo:hi])


def test_constructed_roots_lie_on_the_sphere_apart():
    p, roots, _, _ = _session()
    centre = p - L1 * _towards_camera(p, np.arange(N) * DT)
    for r in (0, 1):
        assert np.allclose(np.linalg.norm(roots[:, r] - centre, axis=1), L1, atol=1e-12)
    assert np.linalg.norm(roots[:, 1] - roots[:, 0], axis=1).min() > 0.2


def test_imu_path_is_the_double_integral():
    p, _, F, b = _session(accel_error=0.0)
    D, tau = branch_repair.imu_path(F[41:101], b[41:101], np.r_[p[40], np.zeros(3)])
    assert np.allclose(tau, np.arange(61) * DT, atol=1e-12)
    assert np.array_equal(D[0], np.zeros(3))
    # with velocity and start removed, the truth's path is the IMU's (up to its noise)
    assert branch_repair.misfit(p[40:101], D, tau) < 2e-3


def test_imu_path_steps_the_errors_from_the_start():
    """A state (p, v, b) with an accelerometer bias b that the process steps (here a random
    walk's mean: constant): the path equals p, v stepped by x_k = F_k x_{k−1} + b_k from
    p = v = 0 and the start's b, whatever p and v the start held."""
    rng = np.random.default_rng(5)
    m = 50
    F = np.tile(np.eye(9), (m, 1, 1))
    F[:, :3, 3:6] = DT * np.eye(3)
    F[:, :3, 6:], F[:, 3:6, 6:] = -DT**2 / 2 * np.eye(3), -DT * np.eye(3)
    b = np.c_[rng.normal(size=(m, 6)) * 1e-3, np.zeros((m, 3))]
    x0 = np.r_[rng.normal(size=6), 0.03, -0.02, 0.01]
    ref, pv = np.zeros((m + 1, 3)), np.zeros(6)
    for k in range(m):
        pv = pv + np.r_[DT * pv[3:] - DT**2 / 2 * x0[6:], -DT * x0[6:]] + b[k, :6]
        ref[k + 1] = pv[:3]
    D, _ = branch_repair.imu_path(F, b, x0)
    assert np.abs(D - ref).max() < 1e-12


def test_the_compiled_path_is_numpys_loop():
    """window_path steps frames by a compiled loop (fuse/path_kernel.py): its D and τ equal
    numpy's x = F x + b frame by frame to 1e-12, on a dense random 15-state process (every
    entry of F used, not only the model's blocks)."""
    rng = np.random.default_rng(11)
    m, d = 300, 15
    F = np.eye(d) + 0.05 * rng.normal(size=(m, d, d))
    F[:, 0, 3] = DT  # τ is read from F's ∂p/∂v entry
    b = rng.normal(size=(m, d))
    x0 = rng.normal(size=d)
    x, ref = np.r_[np.zeros(6), x0[6:]], np.zeros((m + 1, 3))
    for j in range(m):
        x = F[j] @ x + b[j]
        ref[j + 1] = x[:3]
    D, tau = branch_repair.window_path(lambda lo, hi: (F[lo:hi], b[lo:hi]), 0, m, x0, block=64)
    scale = np.abs(ref).max()
    assert scale > 1.0 and np.abs(D - ref).max() <= 1e-12 * scale
    assert np.allclose(tau, np.arange(m + 1) * DT, rtol=0, atol=1e-12)


@pytest.mark.parametrize("block", [1, 7, 59, 60])
def test_a_window_path_taken_in_blocks_is_the_whole_path_to_the_bit(block):
    """window_path builds a window's steps ``block`` frames at a time (a long run's F whole is
    tens of MB): the same D and τ, bit for bit, as the path over F, b at once (imu_path's
    numbers checked above), from a window's first frame on."""
    p, _, F, b = _session(accel_error=0.03)
    calls = []

    def steps(lo, hi):
        calls.append(hi - lo)
        return F[lo:hi], b[lo:hi]

    x0 = np.r_[p[40], np.zeros(3)]
    D, tau = branch_repair.window_path(steps, 41, 101, x0, block=block)
    ref_D, ref_tau = branch_repair.imu_path(F[41:101], b[41:101], x0)
    assert np.array_equal(D, ref_D) and np.array_equal(tau, ref_tau)
    assert max(calls) == min(block, 60) and sum(calls) == 60


@pytest.mark.parametrize("accel_error", [0.0, 0.03])
@pytest.mark.parametrize("lo, hi", [(100, 160), (0, 60), (200, N), (120, 126)])
def test_a_run_put_on_the_wrong_root_is_moved_back(accel_error, lo, hi):
    """In the middle (2 s), at either end, or 6 frames: moved back, alone."""
    p, roots, F, b = _session(accel_error)
    X = np.c_[p, np.zeros((N, 3))]
    X[lo:hi, :3] = roots[lo:hi, 1]
    got, moved = branch_repair.repair(X, roots, _steps(F, b))
    assert moved == 1
    assert np.abs(got[:, :3] - p).max() < 1e-12
    X_in = X.copy()  # in place (the arm smoother's): the same repair, X itself returned
    same, again = branch_repair.repair(X_in, roots, _steps(F, b), in_place=True)
    assert same is X_in and again == 1 and np.array_equal(same, got)
    assert not np.array_equal(X, got)  # without in_place, X was left as it was


@pytest.mark.parametrize("accel_error", [0.0, 0.03])
def test_runs_on_the_right_root_are_not_moved(accel_error):
    p, roots, F, b = _session(accel_error)
    X = np.c_[p, np.zeros((N, 3))]
    got, moved = branch_repair.repair(X, roots, _steps(F, b))
    assert moved == 0
    assert np.array_equal(got, X)


def test_runs_split_where_the_roots_meet_or_nothing_is_seen():
    p, roots, _, _ = _session()
    roots = roots.copy()
    roots[50:53, 1] = roots[50:53, 0] + 0.005  # the ray grazes the sphere: roots 5 mm apart
    roots[120:125] = np.nan  # no detection
    X = p.copy()
    X[130:200] = roots[130:200, 1]
    runs = branch_repair.branch_runs(X, roots)
    assert runs == [(0, 50, 0), (53, 120, 0), (125, 130, 0), (130, 200, 1), (200, N, 0)]
    assert branch_repair.branch_runs(X, roots, min_frames=6) == [(0, 50, 0), (53, 120, 0),
                                                                 (130, 200, 1), (200, N, 0)]


@pytest.mark.parametrize("step, previous, stop", [
    (28e-6, 3e-3, True),  # 28² / (3000 − 28) µm = 0.26 µm left
    (0.75e-6, 28e-6, True),
    (2e-3, 1e-1, False),  # a step of 2 mm: not yet
    (9e-4, 1e-3, False),  # 0.9² / 0.1 mm = 8.1 mm left
    (1e-4, 2.2e-3, True),  # 100² / 2100 µm = 4.8 µm left
    (1e-4, 1.9e-3, False),  # 100² / 1800 µm = 5.6 µm
    (5e-4, np.inf, False),  # the first iteration: no rate yet
    (5e-6, 4e-6, False),  # not shrinking
])
def test_converged_stops_on_the_extrapolated_remaining_change(step, previous, stop):
    assert arm_smoother.converged(step, previous) is stop


def test_the_setting_is_a_boolean():
    from armtrack_cli.core.errors import ConfigError
    from armtrack_cli.pipeline.fuse import settings_for

    assert settings_for(None, ())[0].branch_repair is True
    assert settings_for(None, ("fuse.branch_repair=false",))[0].branch_repair is False
    with pytest.raises(ConfigError, match="branch_repair"):
        settings_for(None, ("fuse.branch_repair=3",))


def test_roots_coded_a_chunk_at_a_time_are_those_of_one_pass(monkeypatch):
    """roots_of ROOT_ROWS rows at a time (memory, issue 15) gives what one pass over every row
    gives (the old form), chunk edges falling mid-run, with grazing and unseen frames."""
    p, roots, *_ = _session()
    rng = np.random.default_rng(4)
    q = p + 0.02 * rng.standard_normal(p.shape)
    q[100:130] = roots[100:130, 1]  # a run on the other root
    roots = roots.copy()
    roots[10:14] = np.nan  # unseen
    roots[50:53, 1] = roots[50:53, 0] + 0.005  # grazing
    gap = np.linalg.norm(roots[:, 0] - roots[:, 1], axis=1)
    d = np.linalg.norm(q[:, None, :] - roots, axis=2)
    whole = np.where(~np.isfinite(gap), branch_repair.UNSEEN,
                     np.where(gap < branch_repair.MIN_GAP_M, branch_repair.GRAZING,
                              np.argmin(np.where(np.isfinite(d), d, np.inf), axis=1)))
    monkeypatch.setattr(branch_repair, "ROOT_ROWS", 37)
    got = branch_repair.roots_of(q, roots)
    assert got.dtype == whole.dtype and np.array_equal(got, whole)
    assert {branch_repair.UNSEEN, branch_repair.GRAZING, 0, 1} <= set(got.tolist())


def _dipping(swap: tuple[int, int] | None, seed: int = 3, accel_error: float = 0.0):
    """(truth p, roots, F, b) whose second root lies along each frame's ray from the truth,
    the roots 20 cm apart but for two dips to 8 cm at frames 100 and 160 (where a ray
    tangent to a true sphere meets one a centimetre off, lift13); ``swap`` (a, b): the roots'
    order swapped outside frames a … b − 1, so a wrist on root 1 throughout is the truth
    there and wrong inside: one run, no grazing frame to cut it."""
    p, _, F, b = _session(accel_error, seed)
    k = np.arange(N)
    gap = 0.2 - 0.12 * (np.exp(-((k - 100) / 8.0) ** 2) + np.exp(-((k - 160) / 8.0) ** 2))
    return p, _roots_along_rays(p, gap, swap), F, b


def _roots_along_rays(p: np.ndarray, gap: np.ndarray, swap: tuple[int, int] | None
                      ) -> np.ndarray:
    """(N, 2, 3): the truth p and a second root ``gap`` m beyond it along its ray from the
    origin; ``swap`` (a, b): the two swapped outside frames a … b − 1."""
    other = p + gap[:, None] * p / np.linalg.norm(p, axis=1, keepdims=True)
    roots = np.stack([p, other], axis=1)
    if swap is not None:
        out = np.ones(N, bool)
        out[swap[0]:swap[1]] = False
        roots[out] = roots[out][:, ::-1]
    return roots


def test_the_nearest_frames_are_the_gaps_dips_not_its_noise():
    _, roots, _, _ = _dipping(None)
    gap = np.linalg.norm(roots[:, 0] - roots[:, 1], axis=1)
    noisy = gap + 0.004 * np.random.default_rng(5).standard_normal(N)  # mm wobble: no cut
    assert branch_repair.nearest_frames(gap).tolist() == [100, 160]
    assert np.abs(branch_repair.nearest_frames(noisy) - [100, 160]).max() <= 2  # the dips'
    gap[100:103] = np.nan  # no detection at the dip: its neighbours cut, none undetected
    assert set(branch_repair.nearest_frames(gap).tolist()) <= {99, 103, 160}
    assert branch_repair.pieces([(0, N, 1), (0, 50, 0)], np.array([100, 160])) == [
        (0, 100, 1), (100, 160, 1), (160, N, 1)]


def _from_rest(swap: tuple[int, int] | None, accel_error: float = 0.0):
    """As _dipping, but the gap nearly flat up to frame 100 (9 cm falling to 8), then rising
    to 20 cm: a hand lifted from rest, where the ray passes nearest a tangent with nothing
    3 cm higher before it (lift14: rectangle s1's first lift, 27.2 cm falling to 25.9 over
    2.4 s, then rising); a dip to 8 cm at frame 160 as there."""
    p, _, F, b = _session(accel_error)
    k = np.arange(N)
    rising = 0.12 * (1 - np.exp(-(np.maximum(k - 100, 0) / 8.0) ** 2))
    gap = (0.08 + 0.01 * np.maximum(100 - k, 0) / 100 + rising
           - 0.12 * np.exp(-((k - 160) / 8.0) ** 2) * (k > 130))
    return p, _roots_along_rays(p, gap, swap), F, b


def test_a_gap_flat_on_one_side_of_its_least_is_cut_there():
    _, roots, _, _ = _from_rest(None)
    cuts = branch_repair.nearest_frames(np.linalg.norm(roots[:, 0] - roots[:, 1], axis=1))
    assert cuts.tolist() == [100, 160]  # not only the two-sided dip at 160


# The wrong stretch: frames 100 … 159 on root 1, the truth on root 0, the whole trajectory on
# root 1, one run the grazing rule cannot cut. _dipping: the roots never nearer than 8 cm
# (before lift13 nothing moved; cut at the gap's dips). _from_rest: the stretch starts where
# the gap leaves its flat (before lift14 only the dip at 160 cut the run, its pieces (0, 160)
# and (160, N) untested, their windows reaching past the session's ends; cut where the flat
# turns). Either way the wrong piece moves back to the truth, and a right one stays.
BUILDERS = {"dipping": _dipping, "from_rest": _from_rest}


@pytest.mark.parametrize("accel_error", [0.0, 0.03])
@pytest.mark.parametrize("build", sorted(BUILDERS))
def test_a_wrong_stretch_cut_where_the_roots_come_nearest_is_moved_back(build, accel_error):
    p, roots, F, b = BUILDERS[build]((100, 160), accel_error=accel_error)
    X = np.c_[roots[:, 1], np.zeros((N, 3))]
    assert branch_repair.branch_runs(X[:, :3], roots) == [(0, N, 1)]
    got, moved = branch_repair.repair(X, roots, _steps(F, b))
    assert moved == 1
    assert np.abs(got[:, :3] - p).max() < 1e-12


@pytest.mark.parametrize("accel_error", [0.0, 0.03])
@pytest.mark.parametrize("build", sorted(BUILDERS))
def test_a_right_stretch_cut_where_the_roots_come_nearest_stays(build, accel_error):
    p, roots, F, b = BUILDERS[build](None, accel_error=accel_error)
    X = np.c_[p, np.zeros((N, 3))]
    got, moved = branch_repair.repair(X, roots, _steps(F, b))
    assert moved == 0 and np.array_equal(got, X)


@pytest.mark.parametrize("iterations, moved_last, most, due", [
    (1, 0, 10, True), (2, 0, 10, False), (2, 3, 10, True), (5, 1, 10, True), (9, 1, 10, True),
    (10, 1, 10, False), (1, 0, 1, False)])
def test_repair_follows_the_first_pass_and_each_after_a_move(iterations, moved_last, most,
                                                            due):
    assert arm_smoother.repair_due(iterations, moved_last, most) is due
