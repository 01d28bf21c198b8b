"""A declared IMU offset's check on a long session's windows (fuse/sync_windows.py): the
windows it picks, a problem cut into stretches against a dense least squares over separate
recordings, and the check's estimate and warning against the simulated truth."""

from __future__ import annotations

import types
import warnings
from dataclasses import replace

import numpy as np
import pytest

from armtrack_cli.fuse import imu_sync, sync_windows
from armtrack_cli.fuse.imu_sync import SyncProblem, estimate_imu_offset
from armtrack_cli.pipeline.imu_offset import WARN_FLOOR_S, resolve_imu_offset
from tests.sync_cases import case

TRUE_S = 0.2


@pytest.fixture(scope="module")
def long_case():
    """A 250-second circle (over CHECK_MIN_S) whose IMU runs TRUE_S behind the video."""
    return case(TRUE_S, task="circle", seed=3, duration=250.0)


def _joined(p1: SyncProblem, p2: SyncProblem, shift: float) -> SyncProblem:
    """p1 then p2 (its clocks moved on by ``shift``) as one problem of two stretches."""
    return replace(p1, t_imu=np.r_[p1.t_imu, p2.t_imu + shift], a_W=np.vstack([p1.a_W, p2.a_W]),
                   q_WB=np.vstack([p1.q_WB, p2.q_WB]),
                   t_frames=np.r_[p1.t_frames, p2.t_frames + shift],
                   uv=np.vstack([p1.uv, p2.uv]), frame_cuts=(p1.t_frames.size,),
                   imu_cuts=(p1.t_imu.size,))


def _dense(p: SyncProblem, delta: float, ok: np.ndarray):
    """y (2k,), the four columns E (2k, 4) and the drift's dense columns (2k, 3m) of one
    recording's frames ``ok``, from the single-stretch code (held to scipy elsewhere)."""
    pre = imu_sync._prepare(p, 0.2)
    E = imu_sync.columns(p, pre, delta)[ok].reshape(-1, 4)
    rows, J = pre.drift[ok], pre.J[ok]
    D = np.zeros((2 * int(ok.sum()), 3 * rows.m))
    for k in range(rows.start.size):
        for d in range(rows.w.shape[1]):
            j = 3 * (rows.start[k] + d)
            D[2 * k:2 * k + 2, j:j + 3] = rows.w[k, d] * J[k]
    return pre.vel_img[ok].ravel(), E, D


def test_stretches_fit_as_separate_recordings_sharing_the_offset_and_scale():
    """Two recordings joined as stretches of one problem: each stretch's image velocities,
    integrals, rays and usable frames are its recording's alone, and the cost is the mean
    squared residual of one least squares with the four columns shared and a drift of each
    recording's own (numpy's lstsq on the dense design)."""
    p1, p2 = case(TRUE_S, task="circle", seed=5), case(TRUE_S, task="figure8", seed=6)
    p2 = replace(p2, arm=p1.arm, proj=p1.proj)
    both = _joined(p1, p2, 1000.0)
    pre, pres = imu_sync._prepare(both, 0.2), [imu_sync._prepare(p, 0.2) for p in (p1, p2)]
    assert np.array_equal(pre.vel_img, np.vstack([x.vel_img for x in pres]), equal_nan=True)
    for name, rtol in (("v_imu", 1e-9), ("rint", 1e-9), ("J", 1e-5)):  # (the clock moved on
        #  by 1000 s rounds its times: J's central differences magnify that where rays graze)
        assert np.allclose(getattr(pre, name), np.concatenate([getattr(x, name) for x in pres]),
                           rtol=rtol, atol=1e-9)
    assert pre.drift.m == sum(x.drift.m for x in pres)
    assert np.array_equal(pre.drift.start, np.r_[pres[0].drift.start,
                                                 pres[1].drift.start + pres[0].drift.m])
    for delta in (0.17, 0.2, 0.24):
        oks = [imu_sync._usable(p, x, delta) for p, x in zip((p1, p2), pres)]
        ok = imu_sync._usable(both, pre, delta)
        assert np.array_equal(ok, np.r_[oks[0], oks[1]]) and ok.sum() > 800
        (y1, E1, D1), (y2, E2, D2) = (_dense(p, delta, o) for p, o in zip((p1, p2), oks))
        A = np.block([[E1, D1, np.zeros((E1.shape[0], D2.shape[1]))],
                      [E2, np.zeros((E2.shape[0], D1.shape[1])), D2]])
        y = np.r_[y1, y2]
        x = np.linalg.lstsq(A, y, rcond=None)[0]
        assert x[0] > 0  # the scale's sign: cost's unconstrained branch
        rss = imu_sync.cost(delta, both, pre, 0, {}, ok) * ok.sum()
        assert rss == pytest.approx(float(np.sum((y - A @ x) ** 2)), rel=1e-6)


def test_windows_are_the_moving_stretches_one_in_each_part(long_case):
    """With detections only on one 20-second island in each eighth of the session, each
    window lies on its part's island; the windowed problem holds the session's own frames
    and samples, its stretches' IMU samples more than GAP_S apart."""
    p, n = long_case, long_case.t_frames.size
    rng = np.random.default_rng(0)
    edges = np.linspace(0, n, sync_windows.CHECK_WINDOWS + 1).astype(int)
    seen = np.zeros(n, bool)
    islands = []
    for a, b in zip(edges[:-1], edges[1:]):
        s = int(rng.integers(a + 30, b - 630))  # away from the part's ends
        seen[s:s + 600] = True
        islands.append((s, s + 600))
    q = sync_windows.check_windows(replace(p, uv=np.where(seen[:, None], p.uv, np.nan)), TRUE_S,
                                   0.5)
    w = int(round(sync_windows.CHECK_WINDOW_S * 30))
    assert len(q.frame_cuts) == sync_windows.CHECK_WINDOWS - 1
    starts = np.searchsorted(p.t_frames, q.t_frames[[0, *q.frame_cuts]])
    for s, (a, b) in zip(starts, islands):
        assert a <= s and s + w <= b
    idx = np.searchsorted(p.t_frames, q.t_frames)
    assert np.array_equal(p.t_frames[idx], q.t_frames) and q.t_frames.size == 8 * w
    j = np.searchsorted(p.t_imu, q.t_imu)
    assert np.array_equal(p.t_imu[j], q.t_imu) and np.array_equal(p.a_W[j], q.a_W)
    assert all(q.t_imu[k] - q.t_imu[k - 1] > imu_sync.GAP_S for k in q.imu_cuts)


def test_a_short_session_is_checked_on_every_frame():
    p = case(TRUE_S, task="reach", seed=1, duration=60.0)
    assert sync_windows.check_windows(p, TRUE_S, 0.5) is p


@pytest.mark.parametrize("declared", [TRUE_S, TRUE_S + 0.2])
def test_the_windowed_check_finds_the_offset_and_warns_when_it_is_wrong(long_case, declared):
    """Through resolve_imu_offset, beside and not: the windows' estimate within 10 ms of the
    truth with an SD well under the warning's floor (two minutes of the session scored); a
    declared offset 0.2 s off is warned about, the true one not."""
    session = types.SimpleNamespace(sync=types.SimpleNamespace(imu_offset_s=declared), arm=None)
    p = long_case
    got = []
    for beside in (False, True):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            value, how = resolve_imu_offset(session, "imu.txt", p.t_imu, p.q_WB, p.a_W,
                                            p.t_frames, p.uv, p.proj, p.arm, beside=beside)
            how.start()
            info = how.result()
        assert value == declared and info["from"] == "declared"
        assert abs(info["estimate"] - TRUE_S) < 0.01 and info["sd"] < WARN_FLOOR_S / 10
        assert len(caught) == (declared != TRUE_S)
        got.append(info)
    assert got[0] == got[1]
    windows = sync_windows.check_windows(p, declared, 0.5)
    assert estimate_imu_offset(windows, centre_s=declared, search_s=0.5).frames <= 8 * 450
