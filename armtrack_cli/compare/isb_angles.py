"""Elbow flexion from ISB segment frames (Wu et al., J. Biomech. 38, 2005, §2.3 and §3.3),
built from landmarks (m, any common frame), (N, 3) each, right arm.

Humerus: origin GH; Y from the epicondyles' midpoint to GH; X perpendicular to the plane
(EL, EM, GH), forward; Z = X × Y, to the right. Forearm: origin US; Y from US to the
epicondyles' midpoint; X perpendicular to the plane (US, RS, epicondyles' midpoint), forward;
Z = X × Y. The elbow's rotation R_hf = R_hᵀ R_f decomposed Z-X-Y (Wu 2005, §3.3): the first
angle, about the humerus' Z, is flexion (+) / extension (−).

The three-point angle φ (180° − the angle at the elbow between shoulder and wrist, armtrack's
measure) is the angle between the two frames' Y axes when the points are the same: the
forearm's Y in the humerus frame is Rz(a) Rx(b) e_y = (−sin a cos b, cos a cos b, sin b), so
cos φ = cos a · cos b, with a the flexion and b the carrying (varus-valgus) angle; pronation
does not enter. φ ≥ |a|, most where the arm is extended (a = 20°, b = 15° give φ = 24.9°),
so the three-point range is the smaller one.
"""

from __future__ import annotations

import numpy as np


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def segment_frame(y_from: np.ndarray, y_to: np.ndarray, lateral: np.ndarray) -> np.ndarray:
    """(N, 3, 3) columns X, Y, Z: Y along y_from -> y_to; X = Y × lateral (forward for a right
    arm, lateral pointing right); Z = X × Y."""
    y = _unit(y_to - y_from)
    x = _unit(np.cross(y, lateral))
    z = np.cross(x, y)
    return np.stack([x, y, z], axis=-1)


def humerus_frame(gh, el, em) -> np.ndarray:
    return segment_frame((el + em) / 2, gh, el - em)  # EL - EM points laterally (right)


def forearm_frame(us, rs, el, em) -> np.ndarray:
    return segment_frame(us, (el + em) / 2, rs - us)  # RS - US points laterally (right)


def joint_rotation(gh, el, em, rs, us, *, fore_el=None, fore_em=None) -> np.ndarray:
    """(N, 3, 3) R_hf = R_hᵀ R_f, the forearm frame in the humerus frame."""
    fel = el if fore_el is None else fore_el
    fem = em if fore_em is None else fore_em
    return np.swapaxes(humerus_frame(gh, el, em), 1, 2) @ forearm_frame(us, rs, fel, fem)


def zxy_deg(R: np.ndarray) -> np.ndarray:
    """(N, 3) Z-X-Y Euler angles (a, b, c) of R = Rz(a) Rx(b) Ry(c), degrees (Wu 2005 §3.3:
    elbow flexion, carrying angle, pronation): R01 = −sin a cos b, R11 = cos a cos b,
    R21 = sin b, R20 = −cos b sin c, R22 = cos b cos c."""
    a = np.arctan2(-R[:, 0, 1], R[:, 1, 1])
    b = np.arcsin(np.clip(R[:, 2, 1], -1.0, 1.0))
    c = np.arctan2(-R[:, 2, 0], R[:, 2, 2])
    return np.degrees(np.stack([a, b, c], -1))


def elbow_flexion_deg(gh, el, em, rs, us, *, fore_el=None, fore_em=None) -> np.ndarray:
    """(N,) ISB elbow flexion, degrees: R = Rz(a) Rx(b) Ry(c), a = atan2(−R01, R11).
    ``fore_el``/``fore_em``: the epicondyles as the forearm carries them (default el, em)."""
    return zxy_deg(joint_rotation(gh, el, em, rs, us, fore_el=fore_el, fore_em=fore_em))[:, 0]
