"""Where a scan sits changes nothing of its bend-count check. The spread floor was the float32 step of the samples'
largest absolute coordinate: the same scan placed in site coordinates 5e6 mm away got a floor of 0.6 mm, far
above the spread of a 2 mm tube's residuals, and the windows the fit runs off the samples in (z 28 at the origin) fell
under the limit: the lost bends were no longer said. The floor is now taken on the scan's size about its centre."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.schemas.tube import TubeRequest
from plantsolve.solvers.tube.bend_count import COORDINATE_STEP, centred_size
from plantsolve.solvers.tube.solve import solve
from plantsolve.solvers.tube.synthetic import small_bends_tube, surface_samples


@pytest.fixture(scope="module")
def missed_bends() -> np.ndarray:
    """bench/tube.py's small_bends seed 5024 (seven bends, three of them 3.6-5°, reconstructed as four), a tenth
    of its size: a 2 mm tube scanned with 0.024 mm noise."""
    rng = np.random.default_rng(5024)
    m = small_bends_tube(rng)
    pts = surface_samples(m, 6000, rng, view=rng.normal(size=3), noise=0.012 * m.pipe_radius, outlier_fraction=0.005)
    return 0.1 * pts


def _verdict(pts: np.ndarray) -> tuple:
    res = solve(TubeRequest(points=pts.tolist())).result
    first = next((w for w in res.report.warnings if w.code == "bend_count_uncertain"), None)
    return (len(res.lra) - 1, res.report.status, [w.code for w in res.report.warnings],
            first.details["alternative_counts"] if first else None, [row.determined for row in res.lra])


def test_the_size_the_floor_is_taken_on_does_not_move_with_the_scan(missed_bends):
    sizes = [centred_size(missed_bends + shift) for shift in (0.0, 2.5e5, 5e6)]
    np.testing.assert_allclose(sizes, sizes[0], rtol=1e-9)
    assert COORDINATE_STEP * sizes[0] < 1e-4  # far under the scan's noise (0.024 mm)


def test_the_same_scan_moved_into_site_coordinates_gets_the_same_bend_count_verdict(missed_bends):
    at_origin = _verdict(missed_bends)
    assert at_origin[:2] == (4, "warning") and at_origin[2][0] == "bend_count_uncertain" and at_origin[3] == [5]
    for shift in (2.5e5, 5e6):
        # before: moved 5e6 mm, status ok with no warning (the floor 0.6 mm against a noise of 0.024 mm)
        assert _verdict(missed_bends + np.array([shift, shift, 0.0])) == at_origin, shift
