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
