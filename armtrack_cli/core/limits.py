"""Every bound armtrack puts on what it is given: recipe settings, command-line numbers and
the physical ranges its readers accept. One table, so each limit is stated once and says why.

A setting is (low, high): both inclusive; a value outside is refused with the range named.
"""

from __future__ import annotations

G = 9.81
MAX_ACCEL_M_S2 = 16 * G  # ±16 g: the largest range of MTw/DOT-class wrist IMUs
MAX_GYRO_RAD_S = 35.0  # ±2000 °/s, the largest gyro range of such IMUs
MAX_PARTICLES = 1_000_000  # ≈ 1 GB of particle arrays; 50,000 already runs in real time
MAX_BOARD_SQUARES = 10_000  # a ChArUco board of more squares is a typo, not a board
MAX_PIXEL_MARGIN = 0.5  # detections may lie outside the image by this share of its size
MAX_SESSION_S = 24 * 3600.0  # a stream longer than a day is a broken clock, not a session
MAX_OFFSET_S = 3600.0  # a clock offset (and so a video clock's start) beyond an hour: another clock
VIDEO_FPS = (1.0, 1000.0)  # frames/s a session's video_timestamps.csv may tick at

SETTINGS = {  # recipe section.key -> (low, high)
    "calibrate.max_error_px": (1e-4, 50.0),
    "detect.patch.min_area_px": (1, 1e6),
    "detect.patch.max_jump_px": (1.0, 1e4),
    "detect.patch.lost_fraction": (0.0, 1.0),
    "detect.patch.move_px": (0.0, 1e4),
    "detect.patch.relink_px": (0.0, 1e4),
    "detect.patch.relink_s": (0.0, 3600.0),
    "detect.palm.min_area_px": (1, 1e6),
    "detect.palm.roi_margin": (0.0, 10.0),
    "detect.palm.hue_slack": (0, 90),
    "detect.palm.sat_floor": (0, 255),
    "detect.palm.min_score": (0.0, 1.0),
    "fuse.particles": (10, MAX_PARTICLES),
    "fuse.pixel_sigma": (0.05, 1000.0),
    "fuse.accel_noise": (1e-4, 100.0),
    "fuse.constraint_sigma_m": (1e-4, 1.0),
    "fuse.walk_pos_m": (0.0, 1.0),
    "fuse.walk_vel_m_s": (0.0, 10.0),
    "fuse.pf_resample_ess": (0.0, 1.0),
    "fuse.init_pos_sigma_m": (1e-4, 10.0),
    "fuse.init_vel_sigma_m_s": (1e-4, 10.0),
    "fuse.init_plane_m": (-2.0, 2.0),
    "fuse.ukf_alpha": (1e-4, 1.0),
    "fuse.ukf_beta": (0.0, 10.0),
    "fuse.ukf_kappa": (-10.0, 10.0),
    "fuse.seed": (0, 2**63 - 1),
}
MAX_TEXT_BYTES = 1 << 30  # a text export over 1 GiB is not a session (60 min at 100 Hz ≈ 50 MB)
MAX_SMALL_BYTES = 1 << 20  # session.toml, recipes, camera.yaml, palm.toml
REACH_MARGIN_M = 0.10  # an estimated wrist this far beyond L1 + L2 from the shoulder is impossible
MAX_OBJECT_RANGE_M = 5.0  # without an arm model: farther than this from W's origin is impossible
