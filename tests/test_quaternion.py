"""Property tests of the quaternion conventions (w, x, y, z), Hamilton, B -> W."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from armtrack_cli.core import quaternion as Q

finite = st.floats(-1e3, 1e3, allow_nan=False)
quats = arrays(float, 4, elements=st.floats(-1, 1)).filter(lambda q: np.linalg.norm(q) > 0.1)
vecs = arrays(float, 3, elements=finite)
angles = st.floats(-np.pi, np.pi)


def _rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


@given(quats)
def test_matrix_is_a_rotation(q):
    R = Q.to_matrix(q)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert abs(np.linalg.det(R) - 1) < 1e-12


@given(quats)
def test_matrix_round_trip(q):
    q = Q.normalize(q)
    back = Q.from_matrix(Q.to_matrix(q))
    assert min(np.abs(back - q).max(), np.abs(back + q).max()) < 1e-9


@given(quats, vecs)
def test_rotate_is_the_sandwich_product(q, v):
    q = Q.normalize(q)
    sandwich = Q.multiply(Q.multiply(q, np.r_[0.0, v]), Q.conjugate(q))
    np.testing.assert_allclose(Q.rotate(q, v), sandwich[1:], atol=1e-9 * (1 + np.abs(v).max()))


@given(quats, quats)
def test_product_composes_rotations(p, q):
    np.testing.assert_allclose(Q.to_matrix(Q.multiply(p, q)), Q.to_matrix(p) @ Q.to_matrix(q),
                               atol=1e-12)


@settings(max_examples=200)
@given(angles, st.floats(-1.5, 1.5), angles)
def test_euler_is_z_y_x(roll, pitch, yaw):
    expected = _rz(yaw) @ _ry(pitch) @ _rx(roll)  # Xsens: R_GS = Rz(yaw) Ry(pitch) Rx(roll)
    np.testing.assert_allclose(Q.to_matrix(Q.from_euler_zyx(roll, pitch, yaw)), expected,
                               atol=1e-12)


def test_quarter_turn_about_z_takes_x_to_y():
    q = Q.from_axis_angle(np.array([0.0, 0, 1]), np.pi / 2)
    np.testing.assert_allclose(Q.rotate(q, [1.0, 0, 0]), [0, 1, 0], atol=1e-15)


def test_vectorised_over_leading_axes():
    rng = np.random.default_rng(1)
    q = Q.normalize(rng.normal(size=(5, 7, 4)))
    v = rng.normal(size=(5, 7, 3))
    R = Q.to_matrix(q)
    assert R.shape == (5, 7, 3, 3)
    np.testing.assert_allclose(Q.rotate(q, v), np.einsum("abij,abj->abi", R, v))


def test_rotation_vector_maps_are_the_axis_angle_closed_form():
    """to_rotvec(from_axis_angle(u, a)) = a·u for a in [0, π); from_rotvec inverts it, and a
    quaternion's sign does not change its rotation vector."""
    rng = np.random.default_rng(3)
    u = rng.normal(size=(50, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    a = rng.uniform(0, np.pi - 1e-6, 50)
    a[:3] = [0.0, 1e-12, 1e-7]
    q = Q.from_axis_angle(u, a)
    np.testing.assert_allclose(Q.to_rotvec(q), a[:, None] * u, atol=1e-12)
    np.testing.assert_allclose(Q.to_rotvec(-q), a[:, None] * u, atol=1e-12)
    np.testing.assert_allclose(Q.from_rotvec(a[:, None] * u), q, atol=1e-12)


def test_rotate_in_row_chunks_is_every_rows_own_product(monkeypatch):
    """(n, 4) rows rotated ROWS_AT_ONCE at a time (memory): each row R(q_k) v_k as a 3 × 3
    product of its own, bit for bit, for one vector or one per row; NaN rows stay NaN."""
    rng = np.random.default_rng(6)
    q = Q.normalize(rng.normal(size=(23, 4)))
    q[4] = np.nan
    v, u = rng.normal(size=(23, 3)), rng.normal(size=3)
    monkeypatch.setattr(Q, "ROWS_AT_ONCE", 5)
    R = Q.to_matrix(q)
    for w, each in ((v, v), (u, np.broadcast_to(u, v.shape))):
        got = Q.rotate(q, w)
        ref = np.array([np.einsum("ij,j->i", R[k], each[k]) for k in range(23)])
        assert got.shape == (23, 3) and np.array_equal(got, ref, equal_nan=True)
        assert np.isnan(got[4]).all() and np.isfinite(np.delete(got, 4, 0)).all()
