"""Dual-quaternion calculus against scipy's Rotation."""

import numpy as np
from scipy.spatial.transform import Rotation

from plantsolve.solvers.geometry import quaternion, quaternion_to_rotvec, rotvec_to_quaternion
from plantsolve.solvers.alignment import dualquat as dq

RNG = np.random.default_rng(42)


def _random(n):
    R = Rotation.random(n, random_state=3)
    t = RNG.normal(size=(n, 3)) * 100
    q = quaternion(R)
    return R, t, dq.dq_from_rt(q, t)


def test_points_match_scipy_rotation_and_translation():
    R, t, Q = _random(50)
    p = RNG.normal(size=(50, 3)) * 1000
    np.testing.assert_allclose(dq.transform_points(Q, p), R.apply(p) + t, rtol=0, atol=1e-9)
    np.testing.assert_allclose(dq.qmatrix(quaternion(R)), R.as_matrix(), atol=1e-14)


def test_product_composes_motions_and_conjugate_inverts():
    R1, t1, Q1 = _random(20)
    R2 = Rotation.random(20, random_state=9)
    t2 = RNG.normal(size=(20, 3))
    Q2 = dq.dq_from_rt(quaternion(R2), t2)
    p = RNG.normal(size=(20, 3))
    np.testing.assert_allclose(dq.transform_points(dq.dq_mul(Q2, Q1), p), R2.apply(R1.apply(p) + t1) + t2, atol=1e-9)
    ident = dq.dq_mul(Q1, dq.dq_conj(Q1))
    np.testing.assert_allclose(ident, np.tile(dq.IDENTITY, (20, 1)), atol=1e-12)
    a, b = dq.dq_norm(Q1)
    np.testing.assert_allclose(a, 1.0, atol=1e-14)
    np.testing.assert_allclose(b, 0.0, atol=1e-12)


def test_rt_round_trip_and_normalisation():
    R, t, Q = _random(10)
    q, t2 = dq.dq_to_rt(Q)
    np.testing.assert_allclose(t2, t, atol=1e-10)
    np.testing.assert_allclose(np.abs(np.einsum("ij,ij->i", q, quaternion(R))), 1.0, atol=1e-14)
    N = dq.dq_normalize(3.7 * Q)
    np.testing.assert_allclose(dq.transform_points(N, np.ones((10, 3))), dq.transform_points(Q, np.ones((10, 3))), atol=1e-9)


def test_lines_transform_like_their_points():
    R, t, Q = _random(10)
    p = RNG.normal(size=(10, 3))
    d = RNG.normal(size=(10, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d2, m2 = dq.transform_lines(Q, d, np.cross(p, d))
    p2 = R.apply(p) + t
    np.testing.assert_allclose(d2, R.apply(d), atol=1e-14)
    np.testing.assert_allclose(m2, np.cross(p2, d2), atol=1e-9)


def test_weighted_mean_is_sign_and_order_independent():
    axis = np.array([0.0, 0.0, 1.0])
    qs = np.array([rotvec_to_quaternion(axis * a) for a in (0.1, 0.3)])
    Q = dq.dq_from_rt(qs, np.array([[0, 0, 1.0], [0, 0, 3.0]]))
    mean = dq.dq_weighted_mean(Q, np.array([1.0, 1.0]))[0]
    r, t = dq.dq_to_rt(mean)
    np.testing.assert_allclose(quaternion_to_rotvec(r), axis * 0.2, atol=1e-12)
    np.testing.assert_allclose(t, [0, 0, 2.0], atol=1e-12)
    flipped = dq.dq_weighted_mean(np.stack([-Q[1], Q[0]]), np.array([1.0, 1.0]))[0]
    np.testing.assert_allclose(flipped * np.sign(flipped[0] * mean[0]), mean, atol=1e-15)
    heavy = dq.dq_weighted_mean(Q, np.array([1.0, 1e9]))[0]
    np.testing.assert_allclose(heavy * np.sign(heavy[0] * Q[1, 0]), Q[1], atol=1e-8)
    grouped = dq.dq_weighted_mean(Q, np.ones(2), np.array([1, 1]), 3)
    np.testing.assert_allclose(grouped[0], dq.IDENTITY)
    np.testing.assert_allclose(grouped[1], mean, atol=1e-15)


def test_screw_power_keeps_the_screw():
    R, t, Q = _random(8)
    half = dq.dq_pow(Q, np.full(8, 0.5))
    p = RNG.normal(size=(8, 3))
    np.testing.assert_allclose(dq.transform_points(dq.dq_mul(half, half), p), dq.transform_points(Q, p), atol=1e-8)
    np.testing.assert_allclose(dq.transform_points(dq.dq_pow(Q, np.ones(8)), p), dq.transform_points(Q, p), atol=1e-8)
    np.testing.assert_allclose(dq.dq_pow(Q, np.zeros(8)), np.tile(dq.IDENTITY, (8, 1)), atol=1e-12)
    pure = dq.dq_from_rt(np.array([1.0, 0, 0, 0]), np.array([4.0, 0, 0]))
    np.testing.assert_allclose(dq.transform_points(dq.dq_pow(pure, np.array(0.25)), np.zeros(3)), [1.0, 0, 0])


def test_minimal_rotation_maps_a_to_b():
    a = RNG.normal(size=(30, 3)); a /= np.linalg.norm(a, axis=1, keepdims=True)
    b = RNG.normal(size=(30, 3)); b /= np.linalg.norm(b, axis=1, keepdims=True)
    b[0] = -a[0]
    q = dq.minimal_rotation(a, b)
    np.testing.assert_allclose(dq.qrotate(q, a), b, atol=1e-12)
    np.testing.assert_allclose(dq.rotation_angle(q)[1:], np.arccos(np.clip(np.einsum("ij,ij->i", a, b), -1, 1))[1:], atol=1e-7)
