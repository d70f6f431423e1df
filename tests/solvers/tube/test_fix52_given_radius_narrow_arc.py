"""A given pipe radius against the straights' cross-sections when the scan sees a narrow strip of each (a tube seen
through a slot): a circle with its radius free misses the radius several times over on a 23° arc, and the samples'
centroid sees any strip as covering half the circumference or more, so the right radius was warned as 7 times the
'measured' one. The given radius is warned only when it fits the samples significantly worse than a free one
(F-test) and the samples span a quarter of the circumference about either circle's centre; a radius 8 % off or
more on a wider view is still warned, naming the radius measured."""

import numpy as np
import pytest

from plantsolve.solvers.tube.given_pipe_radius import given_radius_warning
from plantsolve.solvers.tube.synthetic import make_model

RADIUS = 20.0
LENGTH = 300.0


def _straight(span_deg: float, noise: float, n: int = 3000, seed: int = 0) -> np.ndarray:
    """Samples of a straight along x of radius :data:`RADIUS`, seen over ``span_deg`` of its circumference facing
    +z, with radial noise ``noise`` (a share of the radius)."""
    rng = np.random.default_rng(seed)
    a = np.radians(90.0) + rng.uniform(-np.radians(span_deg) / 2, np.radians(span_deg) / 2, n)
    r = RADIUS * (1 + rng.normal(0, noise, n))
    return np.column_stack([rng.uniform(0, LENGTH, n), r * np.cos(a), r * np.sin(a)])


def _warning(pts: np.ndarray, given: float):
    model = make_model([(LENGTH, 0, 0, 0)], given)
    n = len(pts)
    return given_radius_warning(model, pts, np.zeros(n, dtype=int), np.ones(n, dtype=bool), "mm")


@pytest.mark.parametrize(("span", "noise", "seed"), [(23, 0.05, 0), (23, 0.03, 1), (22, 0.05, 2), (40, 0.05, 3)])
def test_the_right_radius_on_a_narrow_strip_is_not_warned(span, noise, seed):
    assert _warning(_straight(span, noise, seed=seed), RADIUS) is None


@pytest.mark.parametrize(("span", "noise", "factor"), [(180, 0.03, 23 / 20), (180, 0.03, 17 / 20),
                                                        (150, 0.03, 1.15), (150, 0.03, 0.92), (360, 0.03, 1.1)])
def test_a_wrong_radius_on_a_wide_enough_view_is_warned_naming_the_measured_one(span, noise, factor):
    warning = _warning(_straight(span, noise), factor * RADIUS)
    assert warning is not None and warning.code == "pipe_radius_disagrees"
    assert warning.details["measured_pipe_radius"] == pytest.approx(RADIUS, rel=0.01)


@pytest.mark.parametrize("span", [150, 180, 360])
def test_the_right_radius_on_a_wide_view_is_not_warned(span):
    assert _warning(_straight(span, 0.03), RADIUS) is None
