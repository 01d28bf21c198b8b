"""The elbow's functional flexion axis, from the motion of the forearm relative to the upper arm
(rather than from the epicondyles palpated in a static trial).

The elbow is two hinges in series: flexion about n₁, fixed in the humerus, and pronation about
n₂, fixed in the forearm (Biryukova et al., J. Biomech. 33, 2000). The forearm's angular
velocity relative to the humerus, in the humerus' frame, is

    ω(t) = ȧ n₁ + ċ R(t) n₂,          R(t) the forearm's rotation in the humerus frame.

The flexion axis is the mean helical axis (Woltring et al., J. Biomech. 18, 1985; Ehrig et al.,
J. Biomech. 40, 2007, review such functional axes) of ω with its pronation part taken out
along the forearm's long axis from the landmarks (flexion_axis). The exact two-axis least
squares (n₁ and n₂ both free, ω normal to their plane least) was tried on UE-ADL and is ill
posed there: with little pronation in a trial, n₂ wanders and n₁ with it (up to 78° from the
epicondylar axis). ω comes from finite rotations over a short step (the finite helical axis
of each pair of frames).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def relative_rotation(R_upper: np.ndarray, R_fore: np.ndarray) -> np.ndarray:
    """(N, 3, 3) the forearm cluster's rotation in the upper-arm cluster's frame, R_uᵀ R_f."""
    return np.swapaxes(R_upper, 1, 2) @ R_fore


def angular_velocity(R: np.ndarray, rate_hz: float, step: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """(ω (M, 3) rad/s in the frame R is expressed in, R at the middle frames (M, 3, 3)): the
    finite helical axis of R(k + step) R(k − step)ᵀ times its angle, over 2·step frames.
    Frames where either end is missing are left out."""
    a, b, mid = R[: -2 * step], R[2 * step:], R[step:-step]
    ok = np.isfinite(a).all(axis=(1, 2)) & np.isfinite(b).all(axis=(1, 2))
    d = b[ok] @ np.swapaxes(a[ok], 1, 2)
    return Rotation.from_matrix(d).as_rotvec() * rate_hz / (2 * step), mid[ok]


def flexion_axis(omega: np.ndarray, R: np.ndarray, long_axis: np.ndarray) -> np.ndarray:
    """The mean flexion axis n₁ (unit, upper-arm frame): the principal direction of the
    relative angular velocity once its pronation part, along the forearm's long axis carried
    into the upper-arm frame (R_k · long_axis), is taken out, i.e. the eigenvector of the
    largest eigenvalue of Σ ω⊥ ω⊥ᵀ, ω⊥ = ω − (ω · p) p. Each instant weighs with its squared
    angular speed, as the mean helical axis does (Woltring et al. 1985). Exact when n₁ is
    normal to the long axis; tilted by about 0.9 × the departure from normal when it is not
    (tests/test_functional_axis.py). ω (M, 3), R (M, 3, 3) from angular_velocity; long_axis
    (3,) in the forearm frame."""
    p = R @ (long_axis / np.linalg.norm(long_axis))
    w = omega - np.sum(omega * p, axis=1, keepdims=True) * p
    return np.linalg.eigh(w.T @ w)[1][:, -1]


def axis_frame(y_from: np.ndarray, y_to: np.ndarray, z_axis: np.ndarray) -> np.ndarray:
    """(N, 3, 3) columns X, Y, Z with Z the given axis exactly (the flexion axis, so that a
    hinge about it is a pure Z rotation), Y the projection of y_from → y_to normal to it,
    X = Y × Z (forward for a right arm with Z pointing right)."""
    z = z_axis / np.linalg.norm(z_axis, axis=-1, keepdims=True)
    y = y_to - y_from
    y = y - np.sum(y * z, axis=-1, keepdims=True) * z
    y /= np.linalg.norm(y, axis=-1, keepdims=True)
    return np.stack([np.cross(y, z), y, z], axis=-1)


def angle_deg(u: np.ndarray, v: np.ndarray) -> float:
    """Angle between two axes (sign ignored), degrees."""
    c = abs(float(np.dot(u, v))) / (np.linalg.norm(u) * np.linalg.norm(v))
    return float(np.degrees(np.arccos(min(c, 1.0))))
