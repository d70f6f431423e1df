"""The rounding of a file's numbers is no uncertainty of the bend count. A noise-free scan of a bent tube far from
the origin (coordinates 900 to 2,500 mm) leaves residuals of rounding alone: float32 steps of 1e-4 mm in an STL,
1e-13 mm in a float64 text file. The bend-count check took their spread for the scan's noise and called a window
whose mean residual was 2e-12 mm 333 standard errors off (``bend_count_uncertain`` on the text file, not on the STL
of the same tube). The spread is now never taken finer than the coordinates' float32 step."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.tube.solve import solve
from plantsolve.solvers.tube.synthetic import make_model, random_rotation, surface_samples
from plantsolve.solvers.tube.upload import parse_upload

ROWS = [(60, 0, 60, 40.0), (50, 45, 90, 50.0), (60, -30, 45, 40.0), (70, 0, 0, 0)]


def _binary_stl(triangles: np.ndarray) -> bytes:
    records = np.zeros(len(triangles), [("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
    records["corners"] = triangles
    return b"\0" * 80 + np.uint32(len(triangles)).tobytes() + records.tobytes()


@pytest.fixture(scope="module")
def samples() -> np.ndarray:
    rng = np.random.default_rng(4)
    model = make_model(ROWS, 10.0, start=(2500.0, -1500.0, 900.0), frame=random_rotation(rng))
    pts = surface_samples(model, 60_000, rng)
    return pts[: len(pts) // 3 * 3]


@pytest.mark.parametrize("name", ["scan.xyz", "scan.stl"])
def test_a_noise_free_scan_far_from_the_origin_has_its_three_bends_and_no_bend_count_doubt(samples, name):
    if name.endswith(".stl"):
        content = _binary_stl(samples.reshape(-1, 3, 3))  # float32, three samples to a triangle
    else:
        content = "\n".join(f"{x!r} {y!r} {z!r}" for x, y, z in samples.tolist()).encode()  # float64, exact
    result = solve(parse_upload(StoredInput.from_bytes(name, content), {})).result
    assert [w.code for w in result.report.warnings] == [] and result.report.status == "ok"
    np.testing.assert_allclose([row.angle for row in result.lra[:-1]], [45.0, 90.0, 60.0], atol=1e-3)
