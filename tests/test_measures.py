"""Clinical measures against closed forms and published reference values (issue 12).

Reference values: the SPARC and LDLJ of the 1 s minimum-jerk speed profile and of the Gaussian
profile exp(−5t²) as computed by the definitions published with Balasubramanian et al. 2015
(J NeuroEng Rehabil 12: 112): SPARC −1.40583 and −1.41403, LDLJ −5.22414 and −5.81636 (the
issue's figures). Both are sampled at 100 Hz from the first sample up to, not including, the
end (t = 0, 0.01, …, 0.99 s; t = −1, …, 0.99 s), as numpy's arange does.
"""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.measures import Inputs, Settings, angles, measure_rows, path, smoothness
from armtrack_cli.measures.signal import speed_profile

FS = 100.0


def mj_speed(tau):
    """Minimum-jerk speed of a unit move in unit time, 30τ⁴ − 60τ³ + 30τ² (Flash & Hogan 1985)."""
    return 30 * tau**4 - 60 * tau**3 + 30 * tau**2


def mj_reach(D, T, rest=0.5, fs=FS):
    """(t, (N, 3) positions) of a minimum-jerk reach of D metres along x in T seconds."""
    t = np.arange(-rest, T + rest, 1 / fs)
    s = np.clip(t / T, 0, 1)
    x = D * (10 * s**3 - 15 * s**4 + 6 * s**5)
    return t, np.c_[x, 0.2 * np.ones_like(x), 0.05 * np.ones_like(x)]


def rows_of(inp, **kw):
    return {(r["measure"], r["segment"]): r for r in measure_rows(inp, **kw)}


@pytest.mark.parametrize("v, sparc_ref, ldlj_ref", [
    (mj_speed(np.arange(0, 1, 1 / FS)), -1.40583, -5.22414),
    (np.exp(-5 * np.arange(-1, 1, 1 / FS) ** 2), -1.41403, -5.81636),
])
def test_sparc_and_ldlj_match_the_published_reference_values(v, sparc_ref, ldlj_ref):
    assert smoothness.sparc(v, FS) == pytest.approx(sparc_ref, abs=5e-6)
    assert smoothness.ldlj(v, FS) == pytest.approx(ldlj_ref, abs=5e-6)


def test_a_minimum_jerk_reach_gives_its_closed_forms():
    """Peak speed 1.875·D/T at T/2; one movement unit; path length D; straight. Onset and
    offset at 2 % of peak: 16τ²(1 − τ)² = 0.02 (the speed over its peak) at τ* = (1 −
    √(1 − 4c))/2, c = √0.02/4, so movement time (1 − 2τ*)·T and time to peak (1/2 − τ*)·T."""
    D, T = 0.30, 1.2
    t, p = mj_reach(D, T)
    r = rows_of(Inputs(t=t, wrist=p, task="reach"))
    val = lambda k: r[(k, "session")]["value"]  # noqa: E731
    c = np.sqrt(0.02) / 4
    tau = (1 - np.sqrt(1 - 4 * c)) / 2
    assert val("wrist_peak_speed") == pytest.approx(1.875 * D / T, rel=2e-3)
    assert val("movement_time") == pytest.approx((1 - 2 * tau) * T, abs=2 / FS)
    assert val("time_to_peak_speed") == pytest.approx((0.5 - tau) * T, abs=2 / FS)
    assert val("wrist_path_length") == pytest.approx(D, rel=2e-3)
    assert val("movement_units") == 1 and val("segments") == 1
    # the mean speed of a minimum-jerk move is D/T over its whole duration
    assert val("wrist_mean_speed") == pytest.approx(D / ((1 - 2 * tau) * T), rel=2e-2)
    _, pp, v = speed_profile(t, p, Settings())
    assert path.straightness(pp, v, Settings()) == pytest.approx(1.0, abs=1e-3)


def test_two_back_to_back_movements_have_more_units_and_a_lower_sparc():
    one = mj_speed(np.arange(0, 1, 1 / FS))
    two = np.r_[one, one]
    t1, t2 = np.arange(one.size) / FS, np.arange(two.size) / FS
    assert smoothness.movement_units(t1, one)[0] == 1
    assert smoothness.movement_units(t2, two)[0] == 2
    assert smoothness.sparc(two, FS) < smoothness.sparc(one, FS)
    assert smoothness.ldlj(two, FS) < smoothness.ldlj(one, FS)


def test_movement_units_need_a_20_mm_s_rise_and_150_ms():
    t = np.arange(0, 2, 1 / FS)
    bump = lambda c, h: h * np.exp(-((t - c) / 0.12) ** 2)  # noqa: E731
    assert smoothness.movement_units(t, bump(0.6, 0.3) + bump(1.2, 0.3))[0] == 2
    assert smoothness.movement_units(t, bump(0.6, 0.3) + bump(1.2, 0.015))[0] == 1  # 15 mm/s
    close = bump(0.60, 0.3) + bump(0.72, 0.3)  # 120 ms apart
    assert smoothness.movement_units(t, np.maximum(bump(0.6, 0.3), bump(0.72, 0.3)))[0] == 1
    assert smoothness.movement_units(t, close)[0] <= 1


def test_a_pure_elbow_rotation_of_known_range():
    """Upper arm fixed along −z from the shoulder; the forearm turns in a vertical plane from
    20° to 110° of flexion: elbow RoM 90°, and the 5-95 % range that of the sine's values."""
    t = np.arange(0, 4, 1 / FS)
    flex = np.radians(65 - 45 * np.cos(np.pi * t / 2))  # 20° … 110° … 20°
    S = np.array([0.1, 0.5, 0.4])
    E = S + [0, 0, -0.3]
    W = E + 0.27 * np.c_[np.zeros_like(t), -np.sin(flex), -np.cos(flex)]
    r = rows_of(Inputs(t=t, wrist=W, elbow=np.tile(E, (t.size, 1)), shoulder=S))
    assert r[("elbow_flexion_rom", "session")]["value"] == pytest.approx(90.0, abs=1e-3)
    assert r[("elbow_flexion_min", "session")]["value"] == pytest.approx(20.0, abs=1e-3)
    deg = np.degrees(flex)
    ref = np.percentile(deg, 95) - np.percentile(deg, 5)
    assert r[("elbow_flexion_rom_p5_p95", "session")]["value"] == pytest.approx(ref, abs=1e-9)
    assert "deg (0 = full extension)" == r[("elbow_flexion_rom", "session")]["unit"]


def test_isb_shoulder_angles_for_known_arm_directions():
    """Trunk = W facing −y_W: arm down, forward, out to the right side (−x_W) and up."""
    S = np.zeros((4, 3))
    E = 0.3 * np.array([[0, 0, -1.0], [0, -1, 0], [-1, 0, 0], [0, -1, 1e-9]])
    elev, plane = angles.shoulder_angles_deg(S, E, "right")
    assert elev == pytest.approx([0, 90, 90, 90], abs=1e-6)
    assert np.isnan(plane[0])  # gimbal lock at 0° elevation: undefined, never a number
    assert plane[1:3] == pytest.approx([90, 0], abs=1e-6)
    elev_l, plane_l = angles.shoulder_angles_deg(S, E * [-1, 1, 1], "left")  # mirror image
    assert plane_l[1:3] == pytest.approx([90, 0], abs=1e-6)


def _axis_angle_quat(axis, ang):
    return np.c_[np.cos(ang / 2), np.sin(ang / 2)[:, None] * np.asarray(axis)[None]]


def test_forearm_pronation_from_the_imu_relative_to_the_first_second():
    """The sensor turns about its forearm axis (+y_B) by θ(t) after one still second, its
    pose in W rotated by a fixed R0: pronation of a right forearm is −θ, of a left one +θ."""
    t = np.arange(0, 3, 1 / FS)
    th = np.radians(np.where(t < 1, 0.0, 40 * np.sin(np.pi * (t - 1))))
    q0 = np.array([np.cos(0.4), 0, 0, np.sin(0.4)])  # fixed heading
    qb = _axis_angle_quat([0, 1, 0], th)
    w0, v0 = q0[0], q0[1:]
    q = np.c_[w0 * qb[:, 0] - qb[:, 1:] @ v0, w0 * qb[:, 1:] + qb[:, :1] * v0 + np.cross(v0, qb[:, 1:])]
    for side, sign in (("right", -1), ("left", 1)):
        p = angles.forearm_pronation_deg(t, q, np.array([0, 1.0, 0]), side)
        assert p == pytest.approx(sign * np.degrees(th), abs=1e-9)


def _rot(axis, a):
    c, s = np.cos(a), np.sin(a)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R = np.zeros(a.shape + (3, 3))
    R[..., axis, axis] = 1
    R[..., i, i], R[..., j, j], R[..., i, j], R[..., j, i] = c, c, -s, s
    return R


def test_wrist_angles_from_three_markers_recover_the_contract_angles():
    """Markers of a hand posed by R_FH = Rz(dev)·Ry(flex)·Rx(−pron) (SESSION_FORMAT.md) after
    a neutral second, the forearm frame turned in W: the angles come back."""
    t = np.arange(0, 3, 1 / FS)
    ramp = np.clip(t - 1, 0, None)
    flex, dev, pron = np.radians(30 * ramp), np.radians(-10 * ramp), np.radians(20 * ramp)
    R_FH = _rot(2, dev) @ _rot(1, flex) @ _rot(0, -pron)
    R_WF = _rot(2, np.array(0.7)) @ _rot(0, np.array(0.2))
    R = R_WF @ R_FH
    o = np.array([0.3, 0.2, 0.1])
    mcp3 = o + R @ [0.08, 0, 0]
    cmc1 = o + R @ (0.045 * np.array([np.cos(0.9), np.sin(0.9), 0]))
    H = angles.hand_frames(np.tile(o, (t.size, 1)), mcp3, cmc1, "right")
    got = angles.wrist_angles_deg(t, H, "right")
    assert got == pytest.approx(np.degrees(np.c_[flex, dev, pron]), abs=1e-6)


def test_bad_inputs_say_why_and_never_give_a_number():
    t = np.arange(0, 3, 1 / FS)
    still = np.tile([0.2, 0.3, 0.05], (t.size, 1))
    r = rows_of(Inputs(t=t, wrist=still))
    assert r[("wrist_peak_speed", "session")]["value"].startswith("not computable: no movement")
    assert r[("sparc", "session")]["value"].startswith("not computable")
    short = rows_of(Inputs(t=t[:6], wrist=still[:6]))
    assert "fewer than 10 samples" in short[("wrist_path_length", "session")]["value"]
    tt, p = mj_reach(0.3, 1.0)
    p = p.copy()
    p[40:120] = np.nan  # 0.8 s without the wrist
    gap = rows_of(Inputs(t=tt, wrist=p))
    assert "gap in the wrist trajectory" in gap[("wrist_path_length", "session")]["value"]
    p[40:120] = np.nan
    p[70:90] = mj_reach(0.3, 1.0)[1][70:90]  # two 0.3 s gaps are bridged
    ok = rows_of(Inputs(t=tt, wrist=p))
    assert ok[("wrist_path_length", "session")]["value"] == pytest.approx(0.3, rel=0.02)
    flat = rows_of(Inputs(t=t, wrist=still, wrist_angles=np.full((t.size, 3), np.nan)))
    assert flat[("wrist_flexion_rom", "session")]["value"].startswith("not computable: only 0")


def test_uncertainty_from_posterior_draws_is_seeded_and_scales_with_the_sd():
    t, p = mj_reach(0.3, 1.0, fs=30.0)
    sd = np.full_like(p, 0.002)
    a = rows_of(Inputs(t=t, wrist=p, wrist_sd=sd))
    b = rows_of(Inputs(t=t, wrist=p, wrist_sd=sd))
    c = rows_of(Inputs(t=t, wrist=p, wrist_sd=4 * sd))
    k = ("wrist_path_length", "session")
    assert a[k]["sd"] == b[k]["sd"] and 0 < a[k]["sd"] < c[k]["sd"]
    assert np.isnan(rows_of(Inputs(t=t, wrist=p))[k]["sd"])


def test_repeated_reaches_are_measured_per_segment():
    """Three reaches out and back (six minimum-jerk moves of 0.25 m) with rests between."""
    T, D, rest = 1.0, 0.25, 0.4
    t = np.arange(0, 6 * (T + rest) + rest, 1 / FS)
    k = np.clip(np.floor((t - rest) / (T + rest)), 0, 5)
    s = np.clip((t - rest - k * (T + rest)) / T, 0, 1)
    mj = 10 * s**3 - 15 * s**4 + 6 * s**5
    x = D * np.where(k % 2 == 0, mj, 1 - mj)
    r = rows_of(Inputs(t=t, wrist=np.c_[x, 0 * x, 0 * x], task="reach"))
    assert r[("segments", "session")]["value"] == 6
    for n in range(1, 7):
        assert r[("wrist_peak_speed", str(n))]["value"] == pytest.approx(1.875 * D / T, rel=3e-3)
        assert r[("wrist_path_length", str(n))]["value"] == pytest.approx(D, rel=3e-3)
        assert r[("straightness", str(n))]["value"] == pytest.approx(1.0, abs=2e-3)
    assert r[("wrist_path_length", "session")]["value"] == pytest.approx(6 * D, rel=3e-3)
    for m in ("time_to_peak_speed", "sparc", "ldlj"):  # one movement's measures: per segment
        assert r[(m, "session")]["value"] == "not computable: 6 movements (see each segment)"
        assert np.isnan(r[(m, "session")]["sd"])
    v = speed_profile(t, np.c_[x, 0 * x, 0 * x], Settings())[2]
    for n in range(1, 7):  # each segment's SPARC and LDLJ: smoothness.py on its own movement
        a, b = (round(FS * r[("sparc", str(n))][k]) for k in ("t_start", "t_end"))
        onset, offset = path.onset_offset(v[a:b + 1], Settings())
        move = v[a:b + 1][onset:offset + 1]
        assert r[("sparc", str(n))]["value"] == pytest.approx(smoothness.sparc(move, FS), abs=1e-9)
        assert r[("ldlj", str(n))]["value"] == pytest.approx(smoothness.ldlj(move, FS), abs=1e-9)


def test_posterior_draws_have_the_stated_sd_correlation_and_smoothness():
    """smooth_draws: marginal SD σ, correlation exp(−τ²/τc²) (1/e at τc), and velocity SD
    √2·σ/τc (the closed form of a Gaussian-correlated process; an AR(1) process with the same σ
    and τc had σ·√(2/(τc·Δt)), 14 σ/s at 100 Hz, which made peak-speed SDs as large as the peak)."""
    from dataclasses import replace

    from armtrack_cli.measures.base import DEFAULT
    from armtrack_cli.measures.uncertainty import smooth_draws

    t = np.arange(0, 20, 0.01)
    e = np.stack(list(smooth_draws(t, np.full((t.size, 2), 0.005),
                                   replace(DEFAULT, draws=200, draw_corr_s=1.0))))
    assert e.shape == (200, t.size, 2)
    assert e.std() == pytest.approx(0.005, rel=0.05)
    r = np.mean(e[:, :-100] * e[:, 100:]) / np.mean(e**2)  # lag 1 s
    assert r == pytest.approx(np.exp(-1), abs=0.05)
    assert (np.diff(e, axis=1) / 0.01).std() == pytest.approx(np.sqrt(2) * 0.005, rel=0.05)


def test_the_session_row_spans_the_frames_measured_not_the_empty_ones():
    """A filter that left the arm's reach has its rows left empty (fuse): the session's
    measures are taken from the first to the last frame with a wrist, and its t_start/t_end
    say so (they gave the trajectory's whole span, 0 to 19.97 s, for measures of its first
    2.9 s). The closed form: a minimum-jerk reach of D in T, padded by empty rows."""
    D, T = 0.30, 1.2
    t, p = mj_reach(D, T)
    pad = 200  # 2 s of empty rows before and after
    t_all = np.r_[t[0] - np.arange(pad, 0, -1) / FS, t, t[-1] + np.arange(1, pad + 1) / FS]
    p_all = np.r_[np.full((pad, 3), np.nan), p, np.full((pad, 3), np.nan)]
    r = rows_of(Inputs(t=t_all, wrist=p_all, task="reach"))
    row = r[("wrist_path_length", "session")]
    assert (row["t_start"], row["t_end"]) == (pytest.approx(t[0]), pytest.approx(t[-1]))
    assert row["value"] == pytest.approx(D, rel=2e-3)
