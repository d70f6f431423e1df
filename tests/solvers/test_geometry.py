"""The shared geometry, checked against scipy and closed forms."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from plantsolve.solvers import geometry as g


@pytest.fixture
def rng():
    return np.random.default_rng(7)


def test_quaternions_are_scalar_first_and_round_trip(rng):
    R = Rotation.random(50, random_state=1)
    q = g.quaternion(R)
    np.testing.assert_array_equal(q[:, 0], R.as_quat()[:, 3])  # w first
    np.testing.assert_allclose(g.rotation(q).as_matrix(), R.as_matrix(), atol=1e-15)
    assert np.all(g.quaternion(R, positive_w=True)[:, 0] >= 0)
    np.testing.assert_allclose(g.rotation([1.0, 0, 0, 0]).as_matrix(), np.eye(3))
    # 90 degrees about z: w = cos 45°, z = sin 45°
    np.testing.assert_allclose(g.rotvec_to_quaternion([0, 0, np.pi / 2]), [np.sqrt(0.5), 0, 0, np.sqrt(0.5)])
    rv = rng.normal(size=(10, 3))
    np.testing.assert_allclose(g.quaternion_to_rotvec(g.rotvec_to_quaternion(rv)),
                               Rotation.from_rotvec(rv).as_rotvec(), atol=1e-12)


def test_rodrigues_matches_scipy(rng):
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    v = rng.normal(size=3)
    expected = Rotation.from_rotvec(axis * 0.7).apply(v)
    np.testing.assert_allclose(g.rotate_about(v, axis, 0.7), expected, atol=1e-14)
    vs = rng.normal(size=(5, 3))
    angles = rng.uniform(-3, 3, 5)
    expected = Rotation.from_rotvec(axis * angles[:, None]).apply(vs)
    np.testing.assert_allclose(g.rotate_about(vs, axis, angles), expected, atol=1e-14)
    for w in (rng.normal(size=3), np.array([1e-8, -2e-8, 3e-9]), np.zeros(3)):
        np.testing.assert_allclose(g.rotvec_matrix(w), Rotation.from_rotvec(w).as_matrix(), atol=1e-15)


def test_kabsch_recovers_a_rigid_motion_and_a_similarity(rng):
    P = rng.normal(size=(30, 3))
    R = Rotation.random(random_state=3).as_matrix()
    t = np.array([1e3, -2.0, 5.0])
    R_fit, t_fit, s = g.kabsch(P, P @ R.T + t)
    np.testing.assert_allclose(R_fit, R, atol=1e-12)
    np.testing.assert_allclose(t_fit, t, atol=1e-10)
    assert s == 1.0
    R_fit, t_fit, s = g.kabsch(P, 2.5 * P @ R.T + t, scale=True)
    assert s == pytest.approx(2.5, rel=1e-12)
    np.testing.assert_allclose(R_fit, R, atol=1e-12)


def test_kabsch_never_returns_a_reflection(rng):
    P = rng.normal(size=(20, 3))
    mirrored = P * [1, 1, -1]
    R, _, _ = g.kabsch(P, mirrored)
    assert np.linalg.det(R) == pytest.approx(1.0)
    planar = np.column_stack([rng.normal(size=(10, 2)), np.zeros(10)])
    R, t, _ = g.kabsch(planar, planar)
    np.testing.assert_allclose(R, np.eye(3), atol=1e-12)


def test_weights_pick_the_trusted_points(rng):
    P = rng.normal(size=(10, 3))
    Q = P + [0, 0, 1.0]
    Q[0] += 50.0  # an outlier with zero weight
    w = np.ones(10)
    w[0] = 0.0
    R, t, _ = g.kabsch(P, Q, w)
    np.testing.assert_allclose(R, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(t, [0, 0, 1.0], atol=1e-12)


def test_angles():
    assert g.wrap_angle(3 * np.pi / 2) == pytest.approx(-np.pi / 2)
    assert g.wrap_angle(190.0, 360.0) == pytest.approx(-170.0)
    np.testing.assert_allclose(g.wrap_angle(np.array([-181.0, 0.0, 359.0]), 360.0), [179.0, 0.0, -1.0])
    assert g.wrap_angle(np.pi) == pytest.approx(-np.pi)
    a = np.array([1.0, 0, 0])
    assert g.angle_between(a, [np.cos(1e-9), np.sin(1e-9), 0]) == pytest.approx(1e-9, rel=1e-6)
    assert g.angle_between(a, [-1.0, 1e-9, 0]) == pytest.approx(np.pi - 1e-9, rel=1e-12)
    assert g.signed_angle(a, [0, 1.0, 0], [0, 0, 1.0]) == pytest.approx(np.pi / 2)
    assert g.signed_angle(a, [0, 1.0, 0], [0, 0, -1.0]) == pytest.approx(-np.pi / 2)
    for v in np.eye(3).tolist() + [[0.6, 0.8, 0.0]]:
        p = g.any_perpendicular(np.array(v))
        assert abs(p @ v) < 1e-15 and np.linalg.norm(p) == pytest.approx(1.0)
