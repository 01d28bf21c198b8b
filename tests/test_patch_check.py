"""The patch tracker's appearance check and search region on synthetic frames, where the
patch's centre is known exactly: ok = 1 only on the patch (not on a same-size square of
another in-range hue, not on a window joined by a same-hue bar), the search region gives the
whole-frame result, and loss / re-acquisition behave as documented."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from armtrack_cli.detect.colour import bhattacharyya, hue_distribution
from armtrack_cli.detect.patch_tracker import PatchSettings, PatchTracker

LOW, HIGH = (170, 140, 90), (10, 255, 255)  # the simulator's patch range (wraps through red)
PATCH = (25, 35, 225)  # H ≈ 1.5
OTHER_HUE = (25, 60, 215)  # H ≈ 5.5: inside the range, another dye
H, W, SIDE = 240, 320, 20.0


def frame(rng, items) -> np.ndarray:
    """Grey frame with noise; items: (kind, centre (u, v), colour), kind 'square' (SIDE px) or
    'bar' (60 x 12 px) or 'disc' (radius 11 px) or 'dot' (radius 6 px); sub-pixel edges, a
    little blur."""
    img = np.full((H, W, 3), 150, np.uint8)
    for kind, (u, v), colour in items:
        if kind in ("disc", "dot"):
            r = 11 if kind == "disc" else 6
            cv2.circle(img, (int(u * 16), int(v * 16)), r * 16, colour, -1, cv2.LINE_AA, 4)
            continue
        hw, hh = (SIDE / 2, SIDE / 2) if kind == "square" else (30.0, 6.0)
        pts = np.array([[u - hw, v - hh], [u + hw, v - hh], [u + hw, v + hh], [u - hw, v + hh]])
        cv2.fillConvexPoly(img, np.round(pts * 16).astype(np.int32), colour, cv2.LINE_AA, 4)
    img = cv2.GaussianBlur(img, (3, 3), 0.6).astype(np.float32)
    return np.clip(img + rng.normal(0, 2.0, img.shape), 0, 255).astype(np.uint8)


def path(n: int, still: int = 10) -> np.ndarray:
    """(n, 2) patch centres: still for ``still`` frames, then round a circle (≈ 2.6 px/frame)."""
    k = np.clip(np.arange(n) - still, 0, None)
    a = 2 * np.pi * k / 120
    return np.stack([160 + 50 * np.sin(a), 120 - 50 * np.cos(a) + 50], -1) * [1, 0.5] + [0, 40]


def track(frames, settings: PatchSettings | None = None) -> np.ndarray:
    t = PatchTracker(LOW, HIGH, settings or PatchSettings(), fps=30.0)
    for i, img in enumerate(frames):
        t.step(i, img)
    return t.detections()


def err(d: np.ndarray, truth: np.ndarray) -> np.ndarray:
    return np.hypot(d[:, 0] - truth[:, 0], d[:, 1] - truth[:, 1])


def test_bhattacharyya_is_the_closed_form():
    rng = np.random.default_rng(1)
    a, b = rng.random((180, 1)).astype(np.float32), rng.random((180, 1)).astype(np.float32)
    a, b = a / a.sum(), b / b.sum()
    assert bhattacharyya(a, b) == pytest.approx(np.sqrt(1 - np.sqrt(a * b).sum()), abs=1e-5)
    assert bhattacharyya(a, a) == pytest.approx(0.0, abs=1e-3)
    hsv = np.zeros((4, 4, 3), np.uint8)
    hsv[:2, :, 0], hsv[2:, :, 0] = 3, 100
    top, bottom = (np.arange(16).reshape(4, 4) < 8), (np.arange(16).reshape(4, 4) >= 8)
    d = bhattacharyya(hue_distribution(hsv, top.astype(np.uint8)),
                      hue_distribution(hsv, bottom.astype(np.uint8)))
    assert d == pytest.approx(1.0, abs=1e-6)  # disjoint hues


def test_search_region_gives_the_whole_frame_result():
    """The windowed fast path (default) against CamShift on the whole frame (a search region
    larger than the image): the same detections, on the patch to a fraction of a pixel."""
    rng = np.random.default_rng(2)
    truth = path(90)
    frames = [frame(rng, [("square", p, PATCH), ("disc", (60, 200), PATCH)]) for p in truth]
    fast = track(frames)
    whole = track(frames, PatchSettings(search_px=10_000))
    np.testing.assert_allclose(fast, whole, rtol=0, atol=1e-9)  # centroids: offsets added
    ok = fast[:, 5] == 1
    assert ok.all()  # found from the first frame: it moves; the disc never does
    assert err(fast, truth).max() < 0.5


def test_a_square_of_another_hue_is_not_the_patch():
    """From frame 40 the patch is swapped for an equal square of another in-range hue, on
    the same path: CamShift alone would follow it; the hue check reports ok = 0."""
    rng = np.random.default_rng(3)
    truth = path(80)
    frames = [frame(rng, [("square", p, PATCH if i < 40 else OTHER_HUE)])
              for i, p in enumerate(truth)]
    d = track(frames)
    assert (d[:40, 5] == 1).all() and (d[40:, 5] == 0).all()
    off = track(frames, PatchSettings(max_hue_distance=1.0))
    assert (off[:, 5] == 1).all()  # the check is what makes the difference


def test_a_same_hue_bar_joining_the_window_is_not_the_patch():
    """A bar of the patch's own colour (60 x 12 px: too long to be the patch) overtakes the
    moving patch, sliding across it: while the two touch, ok = 0; well apart, ok = 1, on the
    patch; CamShift alone is pulled onto the bar."""
    rng = np.random.default_rng(4)
    truth = path(100, still=5)
    rel = np.clip(-150 + 5 * (np.arange(100) - 20), -150, 150)  # bar centre from the patch's, px
    frames = [frame(rng, [("square", truth[i], PATCH),
                          ("bar", (truth[i, 0] + rel[i], truth[i, 1] + 8), PATCH)])
              for i in range(100)]
    d = track(frames)
    ok = d[:, 5] == 1
    gap = np.abs(rel) - 30 - SIDE / 2  # the bar's end to the patch's edge, px
    assert not ok[gap < 0].any()  # merged with the bar: never reported
    assert ok[gap > 40].all()  # well apart: always reported (re-acquired after the bar)
    assert err(d, truth)[ok].max() < 0.5
    off = track(frames, PatchSettings(lost_fraction=0.0, max_growth=1e9, max_aspect=1e9,
                                      max_aspect_change=1e9))
    assert err(off, truth)[off[:, 5] == 1].max() > 5


def test_lost_then_back_moving_and_at_rest():
    """Hidden frames 20-39 while moving: taken back once it has moved again, its first frames
    back reported too. Hidden frames 80-89 at rest: re-linked where it was lost at once. The
    still square like the patch, 37 px from where the patch was first lost (within
    relink_px), is never reported: it was there when the patch was lost, so it is something
    else."""
    rng = np.random.default_rng(5)
    moving = path(60, still=5)
    truth = np.vstack([moving, np.tile(moving[-1], (60, 1))])
    hidden = np.zeros(120, bool)
    hidden[20:40] = hidden[80:90] = True
    frames = [frame(rng, ([] if hidden[i] else [("square", truth[i], PATCH)])
                    + [("square", truth[19] - (0, 37), PATCH)]) for i in range(120)]
    d = track(frames)
    ok = d[:, 5] == 1
    np.testing.assert_array_equal(ok, ~hidden)
    assert err(d, truth)[ok].max() < 0.5
    assert np.isnan(d[hidden, :2]).all()  # missing is missing, never zero


def test_leaving_the_image_fast():
    """The patch runs out of the image at 12 px per frame and comes back: no error, ok = 0
    while it is outside, on the patch whenever reported."""
    rng = np.random.default_rng(6)
    u = np.r_[np.full(5, 200.0), 200 + 12 * np.arange(1, 21), 440 - 12 * np.arange(1, 26)]
    truth = np.stack([u, np.full(u.size, 120.0)], -1)
    frames = [frame(rng, [("square", p, PATCH)]) for p in truth]
    d = track(frames)
    ok = d[:, 5] == 1
    assert not ok[truth[:, 0] > W + SIDE / 2].any()
    assert ok[truth[:, 0] < W - SIDE].sum() >= 25
    assert err(d, truth)[ok].max() < 0.5


def test_trend_carries_a_steady_growth_and_ignores_one_outlier():
    """``trend`` of a geometric run is its next term; one outlier moves it by nothing."""
    from armtrack_cli.detect.patch_check import trend
    run = 100.0 * 1.15 ** np.arange(8)
    assert trend(run) == pytest.approx(100.0 * 1.15**8, rel=1e-9)
    bad = run.copy()
    bad[4] *= 0.6  # one frame half covered
    assert trend(bad) == pytest.approx(100.0 * 1.15**8, rel=1e-9)
    assert trend([50.0, 50.0, 50.0, 50.0]) == pytest.approx(50.0)


def test_a_patch_turning_face_on_is_followed():
    """The patch grows 11 % in area a frame for 16 frames while it moves (a hand turning its
    back to the camera as it comes nearer: the UE-ADL reaches do this). Every frame is the patch
    and is reported, on it; a running median of the last 8 masses (the check before) would
    have taken the growth for a neighbour joining (mass > 1.3 × that median)."""
    rng = np.random.default_rng(7)
    n = 40
    side = np.r_[np.full(10, 12.0), 12.0 * (28 / 12) ** (np.arange(1, 17) / 16), np.full(14, 28.0)]
    centre = np.stack([100 + 3.0 * np.arange(n), 120 + 0.5 * np.arange(n)], -1)
    frames = []
    for i in range(n):
        img = np.full((H, W, 3), 150, np.uint8)
        u, v, h = centre[i, 0], centre[i, 1], side[i] / 2
        pts = np.array([[u - h, v - h], [u + h, v - h], [u + h, v + h], [u - h, v + h]])
        cv2.fillConvexPoly(img, np.round(pts * 16).astype(np.int32), PATCH, cv2.LINE_AA, 4)
        img = cv2.GaussianBlur(img, (3, 3), 0.6).astype(np.float32)
        frames.append(np.clip(img + rng.normal(0, 2.0, img.shape), 0, 255).astype(np.uint8))
    d = track(frames)
    assert (d[:, 5] == 1).all()
    assert err(d, centre).max() < 0.5
    area = side**2
    old = [area[k] / np.median(area[k - 8:k]) for k in range(8, n)]
    assert max(old) > 1.3  # the old rule's band is exceeded: this test tells them apart


def test_back_at_rest_far_from_where_it_went_then_crossed():
    """Hidden for 30 frames (1 s: a card) while moving, back at rest 60-70 px from where it was
    lost (beyond relink_px, within the reach the time allows), then a same-hue bar passes
    over it twice at rest: every frame it is in clear view is reported (also the rest frames
    before each crossing: the stretches chain to the one that is taken), never a frame under
    the bar, all on the patch."""
    rng = np.random.default_rng(8)
    moving = path(70, still=5)
    truth = np.vstack([moving, np.tile(moving[-1], (90, 1))])
    hidden = np.zeros(160, bool)
    hidden[40:70] = True
    bar = np.full(160, np.nan)
    bar[95:110] = truth[-1, 0] - 110 + 15 * np.arange(15)  # the bar's centre sweeps across
    bar[130:145] = truth[-1, 0] + 110 - 15 * np.arange(15)
    items = [([] if hidden[i] else [("square", truth[i], PATCH)])
             + ([] if np.isnan(bar[i]) else [("bar", (bar[i], truth[i, 1]), OTHER_HUE)])
             for i in range(160)]
    d = track([frame(rng, it) for it in items])
    ok = d[:, 5] == 1
    assert np.hypot(*(truth[70] - truth[39])) > 50  # back beyond relink_px
    near = np.abs(np.nan_to_num(bar, nan=1e9) - truth[:, 0]) < 30 + SIDE / 2 + 6
    assert ok[~hidden & ~near].all()
    assert not ok[hidden].any()
    assert not ok[np.abs(np.nan_to_num(bar, nan=1e9) - truth[:, 0]) < 30 + SIDE / 2].any()
    assert err(d, truth)[ok].max() < 0.5
