import numpy as np
import pytest

from plantsolve.solvers.tube.model import (build_spine, control_polygon, model_from_control_polygon, model_from_spine,
                                   reverse_model, spine_distance, frame_quaternion, quaternion_frame)
from plantsolve.solvers.tube.synthetic import random_tube, surface_samples


def _close(a, b, tol=1e-9):
    assert a.n_bends == b.n_bends
    np.testing.assert_allclose(a.start, b.start, atol=tol)
    np.testing.assert_allclose(a.frame, b.frame, atol=tol)
    np.testing.assert_allclose(a.lengths, b.lengths, atol=tol)
    np.testing.assert_allclose(a.angles, b.angles, atol=tol)
    np.testing.assert_allclose(a.radii, b.radii, atol=tol)
    wrap = lambda x: (x + np.pi) % (2 * np.pi) - np.pi  # noqa: E731
    np.testing.assert_allclose(wrap(a.rotations[1:-1] - b.rotations[1:-1]), 0, atol=tol)


@pytest.mark.parametrize("seed", range(8))
def test_lra_xyz_lra_round_trip_exact(seed):
    m = random_tube(np.random.default_rng(seed))
    m.angles = np.minimum(m.angles, np.radians(170))  # the control polygon needs bends < 180°
    pts, clr = control_polygon(m)
    back = model_from_control_polygon(pts, clr, m.pipe_radius)
    _close(m, back)


@pytest.mark.parametrize("seed", range(8))
def test_lra_segments_lra_round_trip_any_angle(seed):
    m = random_tube(np.random.default_rng(100 + seed))
    m.angles[0] = np.radians(215.0)  # beyond what a control polygon can express
    _close(m, model_from_spine(build_spine(m), m.pipe_radius))


def test_reverse_twice_is_identity_and_keeps_the_curve():
    m = random_tube(np.random.default_rng(7), n_bends=5)
    r = reverse_model(m)
    _close(m, reverse_model(r))
    np.testing.assert_allclose(build_spine(r).start[0], build_spine(m).end[-1], atol=1e-9)
    np.testing.assert_allclose(np.sort(r.angles), np.sort(m.angles), atol=1e-12)


def test_arc_normal_orientation_counter_clockwise():
    m = random_tube(np.random.default_rng(3), n_bends=4)
    sp = build_spine(m)
    for k in np.flatnonzero(sp.kind == 1):
        u = (sp.start[k] - sp.centre[k]) / sp.radius[k]
        # tangent at the start = normal × radial vector (counter-clockwise about the normal)
        np.testing.assert_allclose(np.cross(sp.axis[k], u), sp.tangent[k], atol=1e-12)
        assert abs(np.linalg.norm(sp.end[k] - sp.centre[k]) - sp.radius[k]) < 1e-9


def test_lra_convention_first_bend_toward_local_y():
    from plantsolve.solvers.tube.synthetic import make_model

    m = make_model([[10, 0, 90, 5], [20, 90, 90, 5], [7, 0, 0, 0]], 1.0)
    sp = build_spine(m)
    np.testing.assert_allclose(sp.centre[1], [10, 5, 0], atol=1e-12)
    np.testing.assert_allclose(sp.end[1], [15, 5, 0], atol=1e-12)
    # rotation +90° about the tangent (+y) turns the normal (-x) to +z: the next centre is above
    np.testing.assert_allclose(sp.centre[3], [15, 25, 5], atol=1e-12)
    np.testing.assert_allclose(sp.end[-1], [15, 30, 12], atol=1e-12)


def test_surface_samples_lie_at_pipe_radius():
    m = random_tube(np.random.default_rng(11), pipe_radius=3.0, n_bends=4)
    pts = surface_samples(m, 3000, np.random.default_rng(0))
    d, _ = spine_distance(pts, build_spine(m))
    np.testing.assert_allclose(d, 3.0, atol=1e-9)


def test_quaternion_frame_round_trip():
    m = random_tube(np.random.default_rng(5))
    q = frame_quaternion(m.frame)
    assert abs(np.linalg.norm(q) - 1) < 1e-12 and q[0] >= 0
    np.testing.assert_allclose(quaternion_frame(q), m.frame, atol=1e-12)
