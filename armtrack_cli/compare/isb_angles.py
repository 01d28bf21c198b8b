"""Elbow flexion from ISB segment frames (Wu et al., J. Biomech. 38, 2005, §2.3 and §3.3),
built from landmarks (m, any common frame), (N, 3) each, right arm.

Humerus: origin GH; Y from the epicondyles' midpoint to GH; X perpendicular to the plane
(EL, EM, GH), forward; Z = X × Y, to the right. Forearm: origin US; Y from US to the
epicondyles' midpoint; X perpendicular to the plane (US, RS, epicondyles' midpoint), forward;
Z = X × Y. The elbow's rotation R_hf = R_hᵀ R_f decomposed Z-X-Y (Wu 2005, §3.3): the first
angle, about the humerus' Z, is flexion (+) / extension (−).
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


def elbow_flexion_deg(gh, el, em, rs, us, *, fore_el=None, fore_em=None) -> np.ndarray:
    """(N,) ISB elbow flexion, degrees: R = Rz(a) Rx(b) Ry(c), a = atan2(−R01, R11).
    ``fore_el``/``fore_em``: the epicondyles as the forearm carries them (default el, em)."""
    fel = el if fore_el is None else fore_el
    fem = em if fore_em is None else fore_em
    R = np.swapaxes(humerus_frame(gh, el, em), 1, 2) @ forearm_frame(us, rs, fel, fem)
    return np.degrees(np.arctan2(-R[:, 0, 1], R[:, 1, 1]))
