"""armtrack: 3-D arm and wrist trajectories from a wrist IMU and one camera.

Data flow (each stage exchanges files in the session folder, see ``pipeline``):
session -> calibrate -> detect -> fuse -> compare -> report.
"""

__version__ = "0.1.0"

import os as _os

# OpenCV and FFmpeg print their own warnings on stderr; armtrack reports problems itself, in
# one line per error, so their logging is quieted unless the user asks for it.
_os.environ.setdefault("OPENCV_LOG_LEVEL", "ERROR")
_os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")

# numba's compiled kernels are cached per version of all their sources, not per file
# (session/kernel_cache.py): a change to a helper kernel cannot leave stale machine code.
from armtrack_cli.session.kernel_cache import configure as _configure_kernel_cache  # noqa: E402

_configure_kernel_cache()
