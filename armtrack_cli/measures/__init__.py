"""Clinical measures of arm and wrist movement, as pure functions of arrays (numpy/scipy).

    signal.py      uniform resampling, gap bridging, low-pass, speed
    path.py        wrist path: peak/mean speed, time to peak, movement time, path length,
                   straightness
    smoothness.py  movement units (Alt Murphy 2011), SPARC (Balasubramanian 2012/2015),
                   log dimensionless jerk (Balasubramanian 2015, speed form)
    angles.py      elbow flexion, shoulder elevation and plane (ISB, Wu 2005), forearm
                   pronation from the IMU, range of motion
    segments.py    movement segments (laps, reaches) of a repeated task
    uncertainty.py measures' spread over draws from the filter's posterior
    draws.py       the path measures of a block of draws at once
    angle_draws.py the angles' ranges of motion of a block of draws at once
    pchip.py       scipy's PCHIP interpolation in numpy, a block of points at a time
    peaks.py       scipy's find_peaks in numpy, and peak counts of many rows at once
    vec3.py        dot products and lengths of 3-vectors, numpy's bits, faster
    table.py       the rows of kinematics-METHOD.csv for one trajectory
    windowed.py    the same rows of a long trajectory read a window at a time (issue 15)
    clock.py       its uniform clock and each window's speed profile on it
    stream.py      onset, offset, runs, peaks and percentiles over a signal's pieces
    angle_rows.py  its angles' session rows; windowed_sd.py its posterior SDs

A measure that cannot be computed raises ``NotComputable(why)``; ``table`` turns it into a
"not computable: why" cell, never a number. docs/measures.md defines every measure.
"""

from armtrack_cli.measures import angles, path, smoothness
from armtrack_cli.measures.base import NotComputable, Settings
from armtrack_cli.measures.table import CATALOGUE, Inputs, measure_rows

__all__ = ["NotComputable", "Settings", "CATALOGUE", "Inputs", "measure_rows", "angles", "path",
           "smoothness"]
