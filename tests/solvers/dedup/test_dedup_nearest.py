"""NearestPoints answers k=1 queries as cKDTree does: the same distances bit for bit and the same indices, bounded
or not, whether a query point lands next to one point (answered without the tree), between several, or far away."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from plantsolve.solvers.dedup.matching import make_shape
from plantsolve.solvers.dedup.nearest import NearestPoints


def _arc_segment(radius: float = 5.0, arcs: int = 36) -> np.ndarray:
    """A tunnel segment's points: two arcs at two depths (a shape with a symmetry and many equal coordinates)."""
    angle = np.linspace(0.0, 0.8, arcs + 1)
    return np.array([[r * np.cos(t), r * np.sin(t), z] for r in (radius, radius + 0.3) for z in (0.0, 1.5)
                     for t in angle])


def _same(points: np.ndarray, x: np.ndarray, bound: float = np.inf, window: float | None = None) -> None:
    want_d, want_i = cKDTree(points).query(x, k=1, distance_upper_bound=bound)
    got_d, got_i = NearestPoints(points).query(x, k=1, distance_upper_bound=bound, window=window)
    assert got_d.tobytes() == want_d.tobytes()
    assert np.array_equal(got_i, want_i)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("noise", [0.0, 1e-12, 1e-9, 1e-6, 3e-5, 1e-2])
def test_moved_copies_land_where_the_tree_says_with_the_same_bits(seed, noise):
    rng = np.random.default_rng(seed)
    points = _arc_segment() * rng.choice([1e-3, 1.0, 1e3]) - rng.normal(size=3)
    scale = np.abs(points).max()
    x = points[rng.permutation(len(points))] + rng.normal(size=points.shape) * noise * scale
    for tol in (1e-5 * scale, 1e-8 * scale):
        _same(points, x, window=4 * tol)
        _same(points, x, bound=tol * 1.0001)
        _same(points, x, bound=4 * tol * 1.0001)


@pytest.mark.parametrize("seed", range(4))
def test_wrong_poses_far_points_and_random_clouds_too(seed):
    rng = np.random.default_rng(seed)
    points = _arc_segment()
    turned = points @ np.diag([1.0, -1.0, -1.0]).T  # a wrong guess: lands near some points, between others
    far = points + 1e6
    cloud = rng.normal(size=(300, 3))
    for x in (turned, far, cloud, np.concatenate([turned, points])):
        for bound in (np.inf, 1e-5, 0.05, 0.3):
            _same(points, x, bound=bound, window=4e-5)
    dense = rng.normal(size=(200, 3))  # points closer to each other than the window: every one goes to the tree
    _same(dense, dense + 1e-9, window=10.0)


def test_points_equally_far_from_two_points_get_the_trees_index():
    points = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 3.0, 0.0]])
    x = np.array([[1.0, 0.0, 0.0], [0.0, 1.5, 0.0], [1e-13, 0.0, 0.0]])
    for window in (0.5, 1.0, 1.5, 10.0):
        _same(points, x, window=window)
        _same(points, x, bound=window)


def test_not_finite_and_empty_queries_are_the_trees():
    points = _arc_segment()
    for bad in ([np.nan, 0.0, 0.0], [np.inf, 1.0, 2.0]):  # refused as the tree refuses them, not answered
        x = np.array([points[3], bad])
        for kwargs in ({"window": 1e-3}, {"distance_upper_bound": 1e-3}):
            with pytest.raises(ValueError, match="finite"):
                cKDTree(points).query(x, k=1, **{k: v for k, v in kwargs.items() if k != "window"})
            with pytest.raises(ValueError, match="finite"):
                NearestPoints(points).query(x, k=1, **kwargs)
    _same(points, np.zeros((0, 3)), window=1e-3)


def test_the_shapes_nearest_is_of_its_centred_points():
    points = _arc_segment() + [4.0e5, 6.0e6, 30.0]  # world coordinates: the matching works on centred ones
    shape = make_shape(points)
    assert np.array_equal(shape.nearest.points, shape.local)
    d, i = shape.nearest.query(shape.local[::-1], window=1e-5)
    assert np.array_equal(i, np.arange(len(points))[::-1]) and not d.any()
    assert shape.nearest._tree is None  # answered without building the tree


def test_a_copy_a_little_moved_is_answered_without_the_tree():
    points = _arc_segment()
    nearest = NearestPoints(points)
    moved = points[::-1] + 1e-9
    d, i = nearest.query(moved, window=4e-5)
    d2, i2 = nearest.query(moved, distance_upper_bound=4e-5)
    assert nearest._tree is None
    want_d, want_i = cKDTree(points).query(moved)
    assert d.tobytes() == d2.tobytes() == want_d.tobytes()
    assert np.array_equal(i, want_i) and np.array_equal(i2, want_i)
