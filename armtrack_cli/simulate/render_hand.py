"""Rendering of a hand with six palm markers (Cordella set-up): forearm, palm and fingers in
skin tones, 1.2 cm blue markers on the back of the hand, a blue clutter blob on the table, and
the depth frame an RGB-D camera registered to the colour image would give."""

from __future__ import annotations

import cv2
import numpy as np

from armtrack_cli.core import quaternion as quat
from armtrack_cli.simulate.camera import project
from armtrack_cli.simulate.render import SKIN, SLEEVE, Scene, _limb, _poly

MARKER_BGR = (190, 70, 25)  # saturated blue (OpenCV HSV ≈ 112, 221, 190)
MARKER_D_M = 0.012
FLAT = ((1.0, 1.0),)


def _disc(centre_W, normal_W, radius, n=20):
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    u = np.cross(normal_W, [0.0, 0.0, 1.0] if abs(normal_W[2]) < 0.9 else [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(normal_W, u)
    return centre_W + radius * (np.cos(a)[:, None] * u + np.sin(a)[:, None] * v)


def draw_hand(scene: Scene, *, wrist, q_WH, q_WF, palm_H, clutter_W=None, hidden=(),
              gain=1.0, noise=None, rng=None):
    """BGR frame, (6,) marker visibility, and the depth image (m, NaN = no reading)."""
    cam = scene.cam
    img = scene.background.copy()
    label = np.zeros(img.shape[:2], np.uint8)  # 1 forearm, 2 hand
    eye = cam.centre_W
    if clutter_W is not None:
        _poly(img, project(cam, _disc(clutter_W, np.array([0, 0, 1.0]), 0.01))[0], MARKER_BGR)
    xF = quat.rotate(q_WF, [1.0, 0, 0])
    elbow_side = wrist - 0.26 * xF - np.array([0, 0, 0.01])
    _limb(img, cam, elbow_side, wrist, 0.03, SLEEVE * 0.6 + SKIN * 0.4)
    _limb(label, cam, elbow_side, wrist, 0.03, np.array([1.0]), FLAT)
    R = quat.to_matrix(q_WH)
    pts = wrist + palm_H @ R.T
    normal = R[:, 2]
    # palm: the hull of the markers widened a little; fingers from the MCP joints
    hull = np.vstack([pts, wrist + R @ [0.0, 0.03, 0], wrist + R @ [0.0, -0.03, 0],
                      pts[4] + R @ [0.0, -0.012, 0], pts[1] + R @ [0.01, 0.01, 0]])
    hull_px = project(cam, hull)[0]
    hull_px = cv2.convexHull(hull_px.astype(np.float32)).reshape(-1, 2)
    _poly(img, hull_px, SKIN * 0.92)
    _poly(label, hull_px, (2,))
    for k in (1, 2, 3, 4):
        tip = pts[k] + R @ np.array([0.07 - 0.005 * abs(k - 2), 0, -0.004])
        _limb(img, cam, pts[k], tip, 0.009, SKIN * 0.95)
        _limb(label, cam, pts[k], tip, 0.009, np.array([2.0]), FLAT)
    thumb = pts[5] + R @ np.array([0.035, 0.04, -0.01])
    _limb(img, cam, pts[5], thumb, 0.011, SKIN * 0.95)
    _limb(label, cam, pts[5], thumb, 0.011, np.array([2.0]), FLAT)
    visible = np.zeros(len(pts), bool)
    for k, p in enumerate(pts):
        if float(normal @ (eye - p)) <= 0 or k in hidden:
            continue
        _poly(img, project(cam, _disc(p + 0.0005 * normal, normal, MARKER_D_M / 2))[0], MARKER_BGR)
        visible[k] = True
    out = cv2.GaussianBlur(img.astype(np.float32) * gain, (3, 3), 0.6)
    if noise is not None:
        out += noise
    depth = _depth(scene, label, wrist, normal, rng)
    return np.clip(out, 0, 255).astype(np.uint8), visible, depth


def _depth(scene: Scene, label, wrist, normal, rng):
    """Depth along the optical axis (m): the table, the palm plane over the hand, a level plane
    through the wrist over the forearm (continuous at the wrist, as skin is); structured-light
    holes along the outline, 1 mm noise on the body."""
    cam = scene.cam
    depth = scene.depth_m.copy()
    rays = scene.rays_C
    for lab, point, n in ((1, wrist, np.array([0, 0, 1.0])), (2, wrist, normal)):
        m = label == lab
        if not m.any():
            continue
        nC = cam.R_WC @ n
        pC = cam.R_WC @ point + cam.T_WC
        depth[m] = (nC @ pC) / (rays[m] @ nC)  # rays have z = 1: the scale is the depth
    body = label > 0
    if rng is not None and body.any():
        depth[body] += rng.normal(0, 0.001, int(body.sum()))
        edge = cv2.morphologyEx(body.astype(np.uint8), cv2.MORPH_GRADIENT, np.ones((3, 3), np.uint8))
        depth[(edge > 0) & (rng.random(edge.shape) < 0.6)] = np.nan
    return depth
