"""Dot products and lengths of (..., 3) vectors, bit for bit np.sum(a * b, -1) and
np.linalg.norm(x, axis=-1) (the three terms added in order, as numpy's reduction of a
length-3 axis adds them), as three whole-array terms: numpy reduces a length-3 last axis
element by element, ~3× slower (a 10-minute session's 40 posterior draws pass through
these a few hundred times; tests/test_measures_vec3.py holds them to numpy's)."""

from __future__ import annotations

import numpy as np


def dot3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(...,) Σ a·b over the last axis (length 3)."""
    a0, a1, a2 = np.moveaxis(np.asarray(a, float), -1, 0)
    b0, b1, b2 = np.moveaxis(np.asarray(b, float), -1, 0)
    return a0 * b0 + a1 * b1 + a2 * b2


def norm3(x: np.ndarray) -> np.ndarray:
    """(...,) Euclidean length over the last axis (length 3)."""
    x0, x1, x2 = np.moveaxis(np.asarray(x, float), -1, 0)
    return np.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
