"""π, the camera's projection (models.Projection: OpenCV's pinhole with k1 k2 p1 p2 k3),
compiled for the kernels that project particles, sigma points or states one at a time
(fuse/pf_kernel.py, fuse/pf_guard_kernel.py, fuse/gaussian_kernel.py, fuse/imu_error.py).
cam = (R (3, 3) row-major, T, fx, fy, cx, cy) flattened (16,), dist (5,): methods.camera_arrays."""

from __future__ import annotations

from numba import njit

# error_model="numpy": x / 0 is inf as in numpy, not Python's ZeroDivisionError, whose check
# keeps LLVM from vectorising any loop that divides


@njit(cache=True, error_model="numpy")
def _pixel(p0, p1, p2, cam, dist):
    """π(p) at one point in W; cam, dist: arrays, or tuples (held in registers through a loop
    over particles: _camera_tuple, _dist_tuple)."""
    k1, k2, t1, t2, k3 = dist[0], dist[1], dist[2], dist[3], dist[4]
    X = cam[0] * p0 + cam[1] * p1 + cam[2] * p2 + cam[9]
    Y = cam[3] * p0 + cam[4] * p1 + cam[5] * p2 + cam[10]
    Z = cam[6] * p0 + cam[7] * p1 + cam[8] * p2 + cam[11]
    nx, ny = X / Z, Y / Z
    r2 = nx * nx + ny * ny
    rad = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    dx, dy = nx * rad, ny * rad
    if t1 != 0.0 or t2 != 0.0:  # tangential terms
        xy2 = 2 * nx * ny
        dx += t1 * xy2 + t2 * (r2 + 2 * nx * nx)
        dy += t2 * xy2 + t1 * (r2 + 2 * ny * ny)
    return dx * cam[12] + cam[14], dy * cam[13] + cam[15]


@njit(cache=True, error_model="numpy")
def _camera_tuple(c):
    return (c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9], c[10], c[11], c[12],
            c[13], c[14], c[15])


@njit(cache=True, error_model="numpy")
def _dist_tuple(d):
    return d[0], d[1], d[2], d[3], d[4]
