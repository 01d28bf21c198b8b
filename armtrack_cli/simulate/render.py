"""Camera frames rendered with OpenCV: a textured table with the ChArUco board lying on it,
the arm as shaded limb segments, the wrist patch centred on the wrist joint, and optionally
a distractor of similar hue and an occluder. Image noise, blur and lighting flicker.

The static background (table + board) is rendered once through the lens model (a remap of a
1 mm/px table texture); each frame then draws the moving parts with sub-pixel polygons.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from armtrack_cli.core import quaternion as quat
from armtrack_cli.core.streams import CameraModel
from armtrack_cli.simulate import distractors
from armtrack_cli.simulate.camera import pixel_rays, project

TEX_MM = 1.0  # texture resolution, mm per pixel
TEX_X = (-0.45, 0.85)  # table region in W covered by the texture, m
TEX_Y = (-0.55, 0.75)
SHIFT = 4  # sub-pixel bits for OpenCV polygon drawing
SKIN = np.array([120, 150, 205], float)  # BGR
SLEEVE = np.array([140, 90, 60], float)


@dataclass(frozen=True)
class Scene:
    cam: CameraModel
    background: np.ndarray  # (H, W, 3) uint8, lens distortion applied
    depth_m: np.ndarray  # (H, W) depth of the table along the optical axis, m (NaN: none)
    rays_C: np.ndarray  # (H, W, 3) ray (x_n, y_n, 1) of every observed pixel
    patch_bgr: tuple[int, int, int]
    patch_side_m: float = 0.035


def table_texture(board_img: np.ndarray, rng: np.random.Generator, clutter=None) -> np.ndarray:
    """A light grey laminate table (as in many clinics; a wooden one would be skin-coloured)
    at TEX_MM per pixel, with the board placed at W's origin (y_W ≤ 0); ``clutter``
    (patch HSV low, high, generator) adds objects of many colours (distractors.py)."""
    h = int(round((TEX_Y[1] - TEX_Y[0]) * 1000 / TEX_MM))
    w = int(round((TEX_X[1] - TEX_X[0]) * 1000 / TEX_MM))
    grain = cv2.GaussianBlur(rng.standard_normal((h, w // 8)).astype(np.float32), (0, 0), 3)
    grain = cv2.resize(grain, (w, h), interpolation=cv2.INTER_LINEAR)
    base = np.array([168, 163, 155], np.float32)  # light grey laminate, BGR
    tex = np.clip(base[None, None, :] * (1 + 0.04 * grain[..., None]), 0, 255).astype(np.uint8)
    bh, bw = board_img.shape[:2]
    r0 = int(round((-bh * TEX_MM / 1000 - TEX_Y[0]) * 1000 / TEX_MM))  # board spans y_W ∈ [-h, 0]
    c0 = int(round((0 - TEX_X[0]) * 1000 / TEX_MM))
    if clutter is not None:
        low, high, crng = clutter
        distractors.clutter_texture(tex, (int(low[0]), int(high[0])), int(low[1]),
                                    (c0, r0, c0 + bw, r0 + bh), crng)
    # board pixel (c, r) is board point (c, r)·s, i.e. W (c·s, −r·s): rows flip with y
    tex[r0:r0 + bh, c0:c0 + bw] = cv2.cvtColor(np.flipud(board_img), cv2.COLOR_GRAY2BGR)
    return tex


def build_scene(cam: CameraModel, board, square_m: float, patch_bgr, rng,
                clutter=None) -> Scene:
    squares = board.getChessboardSize()
    px_per_sq = int(round(square_m * 1000 / TEX_MM))
    board_img = board.generateImage((squares[0] * px_per_sq, squares[1] * px_per_sq), marginSize=0)
    tex = table_texture(board_img, rng, clutter)
    rays = pixel_rays(cam)  # (H, W, 3) in C
    d_W = rays @ cam.R_WC  # ray directions in W (R_WCᵀ · ray)
    eye = cam.centre_W
    s = -eye[2] / d_W[..., 2]  # hit the table plane z = 0
    hit = eye + s[..., None] * d_W
    ok = (s > 0) & np.isfinite(s)
    # texel k covers [k, k+1) mm from the texture's edge; remap samples texel centres at integers
    mx = ((hit[..., 0] - TEX_X[0]) * 1000 / TEX_MM - 0.5).astype(np.float32)
    my = ((hit[..., 1] - TEX_Y[0]) * 1000 / TEX_MM - 0.5).astype(np.float32)
    mx[~ok], my[~ok] = -1, -1
    bg = cv2.remap(tex, mx, my, cv2.INTER_LINEAR,
                   borderMode=cv2.BORDER_CONSTANT, borderValue=(60, 60, 60))
    # the ray in W is R_WCᵀ (x_n, y_n, 1): its scale s to the table is the depth z_C itself
    depth = np.where(ok, s, np.nan)
    return Scene(cam, bg, depth, rays, tuple(int(c) for c in patch_bgr))


def _poly(img, pts_px: np.ndarray, colour) -> None:
    cv2.fillConvexPoly(img, np.round(pts_px * (1 << SHIFT)).astype(np.int32),
                       tuple(float(c) for c in colour), cv2.LINE_AA, SHIFT)


SHADES = ((1.0, 0.62), (0.75, 0.8), (0.45, 0.95))  # (radius fraction, brightness), rim to core


def _limb(img, cam, a: np.ndarray, b: np.ndarray, radius: float, colour: np.ndarray,
          shades=SHADES) -> None:
    """A shaded cylinder from a to b (W), drawn as nested quads, darker at the rim
    (``shades=((1.0, 1.0),)`` paints it flat, e.g. into a label image)."""
    (pa, pb), (za, zb) = project(cam, np.stack([a, b]))
    if min(za, zb) <= 0.05:
        return
    d = pb - pa
    n = np.array([-d[1], d[0]]) / max(np.linalg.norm(d), 1e-6)
    f = cam.K[0, 0]
    for frac, shade in shades:
        ra, rb = f * radius * frac / za, f * radius * frac / zb
        quad = np.array([pa + n * ra, pb + n * rb, pb - n * rb, pa - n * ra])
        _poly(img, quad, colour * shade)
        for p, r in ((pa, ra), (pb, rb)):
            cv2.circle(img, tuple(np.round(p * (1 << SHIFT)).astype(int)), int(r * (1 << SHIFT)),
                       tuple(float(c) for c in colour * shade), -1, cv2.LINE_AA, SHIFT)


def _split_other_arm(cam, wrist, other_arm, segs) -> tuple[list, list]:
    """The arm's segments with the other arm's that lie behind the wrist, and those in front
    of it (far first)."""
    wrist_depth = project(cam, wrist[None])[1][0]
    behind, front = list(segs), []
    for seg in distractors.other_arm_segments(*other_arm, SKIN):
        depth = project(cam, np.stack(seg[:2]))[1].mean()
        (front if depth < wrist_depth else behind).append((depth, seg) if depth < wrist_depth
                                                          else seg)
    return behind, [seg for _, seg in sorted(front, key=lambda f: -f[0])]


def patch_covered(scene: Scene, wrist, q_WB, other_arm) -> float:
    """Share of the patch's image hidden by the other arm (0: none, 1: all)."""
    cam = scene.cam
    mask = np.zeros((cam.height, cam.width), np.uint8)
    _poly(mask, project(cam, patch_corners(wrist, q_WB, scene.patch_side_m))[0], (255,))
    whole = cv2.countNonZero(mask)
    if whole == 0:
        return 0.0
    for a, b, radius, _ in _split_other_arm(cam, wrist, other_arm, [])[1]:
        _limb(mask, cam, a, b, radius, np.zeros(1), shades=((1.0, 1.0),))
    return 1.0 - cv2.countNonZero(mask) / whole


def patch_corners(wrist: np.ndarray, q_WB: np.ndarray, side: float) -> np.ndarray:
    """(4, 3) corners in W of the square patch in B's x-y plane, centred on the wrist joint."""
    h = side / 2
    c = np.array([[-h, -h, 0], [h, -h, 0], [h, h, 0], [-h, h, 0]])
    return wrist + quat.rotate(q_WB, c)


def draw_frame(scene: Scene, *, shoulder, elbow, wrist, q_WB, forearm_unit_B,
               distractor_W=None, occluder=False, other_arm=None, gain: float = 1.0,
               noise: np.ndarray | None = None) -> tuple[np.ndarray, bool]:
    """One BGR frame and whether the patch is visible (facing the camera, not occluded).
    ``other_arm`` (elbow, wrist in W) draws the other arm in its sleeve (distractors.py),
    over the patch where it is nearer the camera."""
    cam = scene.cam
    img = scene.background.copy()
    if distractor_W is not None:
        ring = distractor_W + 0.022 * np.stack([np.cos(a := np.linspace(0, 2 * np.pi, 24,
                                                                           endpoint=False)),
                                                 np.sin(a), 0 * a], -1)
        _poly(img, project(cam, ring)[0], scene.patch_bgr)
    hand_dir = quat.rotate(q_WB, forearm_unit_B)
    segs = [(shoulder, elbow, 0.045, SLEEVE), (elbow, wrist, 0.034, SKIN),
            (wrist, wrist + 0.085 * hand_dir, 0.032, SKIN)]
    depths = [project(cam, np.stack([a, b]))[1].mean() for a, b, _, _ in segs]
    front = []
    if other_arm is not None:  # behind the wrist: drawn with the arm; in front: after the patch
        segs, front = _split_other_arm(cam, wrist, other_arm, segs)
        depths = [project(cam, np.stack([a, b]))[1].mean() for a, b, _, _ in segs]
    for k in np.argsort(depths)[::-1]:  # painter's order: far first
        _limb(img, cam, *segs[k])
    corners = patch_corners(wrist, q_WB, scene.patch_side_m)
    normal = quat.rotate(q_WB, [0.0, 0.0, 1.0])
    eye = cam.centre_W
    facing = float(normal @ (eye - wrist)) > 0
    sensor = patch_corners(wrist, q_WB, scene.patch_side_m * 1.35)
    _poly(img, project(cam, sensor)[0], (45, 45, 45))
    if facing:
        _poly(img, project(cam, corners)[0], scene.patch_bgr)
    for seg in front:
        _limb(img, cam, *seg)
    if occluder:  # a grey card held between the camera and the wrist
        centre = project(cam, wrist[None])[0][0]
        _poly(img, centre + np.array([[-40, -30], [45, -35], [50, 40], [-35, 35]]), (150, 150, 150))
    out = img.astype(np.float32) * gain
    out = cv2.GaussianBlur(out, (3, 3), 0.6)
    if noise is not None:
        out += noise
    return np.clip(out, 0, 255).astype(np.uint8), facing and not occluder
