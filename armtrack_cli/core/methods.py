"""The fusion methods armtrack knows and what each needs from a session: the one list that
fuse, info, compare and the command line read."""

from __future__ import annotations

ARM_METHODS = ("inertial", "ekf", "ukf", "pf", "pf-constraint",  # Tao & Hu 2008 and baselines
               "arm-smoother")  # beyond the paper: docs/fusion.md
PALM_METHODS = ("ukf-palm",)  # Cordella et al.
METHODS = ARM_METHODS + PALM_METHODS
BUILT = ARM_METHODS + PALM_METHODS  # methods this version can run
DEFAULT_METHOD = "arm-smoother"

_CAMERA = ("video", "intrinsics", "board")
NEEDS = {
    **{m: ("imu", *_CAMERA, "patch") for m in ARM_METHODS},
    "pf-constraint": ("imu", *_CAMERA, "patch", "arm"),
    "arm-smoother": ("imu", *_CAMERA, "patch", "arm"),
    "ukf-palm": (*_CAMERA, "palm"),  # depth frames help, but are not needed (docs/palm-ukf.md)
}
DEFAULT_FOR_KIND = {"arm": "arm-smoother", "object": "ukf", "palm": "ukf-palm"}
