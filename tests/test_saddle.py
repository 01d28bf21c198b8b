"""calibrate/saddle.py against closed forms: a quadratic saddle surface (which the fit and the
Gaussian both keep exactly) and a chessboard X-junction rendered by area integration."""

import cv2
import numpy as np

from armtrack_cli.calibrate.saddle import saddle_points


def _grid(n=41):
    v, u = np.mgrid[0:n, 0:n].astype(float)
    return u, v


def test_a_quadratic_saddle_is_found_exactly():
    # f = (x − x0)² − (y − y0)² + 0.5 (x − x0)(y − y0): Gaussian smoothing adds σ² − σ² = 0
    u, v = _grid()
    x0, y0 = 20.3, 19.6
    img = 100 + (u - x0) ** 2 - (v - y0) ** 2 + 0.5 * (u - x0) * (v - y0)
    got = saddle_points(img, np.array([[19.0, 21.0], [21.4, 18.7]]))
    np.testing.assert_allclose(got, [[x0, y0], [x0, y0]], atol=1e-9)


def _x_junction(x0, y0, angle, n=41, sub=16):
    """A chessboard corner at (x0, y0), its edges turned by ``angle``, each pixel the mean of
    sub × sub samples over its area (the pixel centre at integer coordinates)."""
    o = (np.arange(sub) + 0.5) / sub - 0.5
    v, u = np.mgrid[0:n, 0:n].astype(float)
    uu = u[..., None, None] + o[None, None, None, :]
    vv = v[..., None, None] + o[None, None, :, None]
    c, s = np.cos(angle), np.sin(angle)
    a = c * (uu - x0) + s * (vv - y0)
    b = -s * (uu - x0) + c * (vv - y0)
    return np.where(a * b > 0, 220.0, 30.0).mean(axis=(2, 3))


def test_an_x_junction_is_found_to_a_tenth_of_a_pixel():
    # a sharp corner is not a quadratic over the 5 × 5 window: the fit's own bias, measured
    # over 20 draws, is 0.05-0.09 px with the renderer's 0.6 px blur
    rng = np.random.default_rng(3)
    for _ in range(20):
        x0, y0 = 20 + rng.uniform(-0.5, 0.5, 2)
        img = cv2.GaussianBlur(_x_junction(x0, y0, rng.uniform(0, np.pi / 2)), (0, 0), 0.6)
        got = saddle_points(img, np.array([[x0 + 0.4, y0 - 0.4]]))
        assert np.hypot(*(got[0] - [x0, y0])) < 0.1


def test_a_corner_that_is_no_saddle_keeps_its_estimate():
    u, v = _grid()
    blob = 200 - (u - 20.2) ** 2 - (v - 20.4) ** 2  # a maximum, not a saddle
    start = np.array([[20.0, 21.0], [0.5, 0.5]])  # the second's window leaves the image
    np.testing.assert_array_equal(saddle_points(blob, start), start)
