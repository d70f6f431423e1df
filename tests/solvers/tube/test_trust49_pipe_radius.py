"""A pipe radius that is not the scan's (a diameter typed where the radius is asked, a radius in another unit) is
refused at submission naming ``options.pipe_radius`` with the radius the scan's cross-sections show. Held fixed, it
left the fit nothing to follow: the example scan (radius 6 mm) with 12 mm failed in the spine stage without naming
the option, and with 3 mm came out as one straight of 175 mm."""

from __future__ import annotations

import json

import numpy as np
import pytest

from plantsolve.solvers.tube.synthetic import clear_tube, surface_samples
from plantsolve.solvers.tube.validation import measured_pipe_radius, pipe_radius_against_measured
from tests.conftest import REPO

EXAMPLE = json.loads((REPO / "examples" / "tube" / "scan_request.json").read_text())  # pipe radius 6 mm


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    from fastapi.testclient import TestClient

    from plantsolve.app.main import create_app
    from tests.conftest import service_settings

    with TestClient(create_app(service_settings(tmp_path_factory.mktemp("trust49_pipe_radius")))) as test_client:
        yield test_client


def _body(pipe_radius: float) -> dict:
    body = json.loads(json.dumps(EXAMPLE))
    body["options"]["pipe_radius"] = pipe_radius
    return body


@pytest.mark.parametrize("pipe_radius, times, why", [(12.0, "2.2 times", "a diameter?"),
                                                    (3.0, "0.54 times", "another unit"),
                                                    (60.0, "11 times", "another unit")])
def test_a_pipe_radius_the_scan_does_not_show_is_refused_naming_both_radii(client, pipe_radius, times, why):
    response = client.post("/v1/tube/jobs", json=_body(pipe_radius))
    assert response.status_code == 422, response.text
    (error,) = response.json()["errors"]
    assert error["loc"] == ["options", "pipe_radius"]
    assert f"pipe radius {pipe_radius:g} mm is {times} the radius the scan's cross-sections show (5.51 mm)" \
        in error["msg"] and why in error["msg"]


@pytest.mark.parametrize("pipe_radius", [6.0, 5.5, 6.5])
def test_the_scans_own_radius_is_taken(client, pipe_radius):
    response = client.post("/v1/tube/jobs", json=_body(pipe_radius))
    assert response.status_code in (200, 201, 202), response.text


@pytest.mark.parametrize("seed", range(8))
def test_the_measured_radius_is_near_the_true_one_on_sparse_noisy_one_sided_coarse_scans(seed):
    rng = np.random.default_rng(seed)
    radius = float(np.exp(rng.uniform(np.log(1.0), np.log(60.0))))
    view = rng.normal(size=3) * 1000 if seed % 2 else None
    pts = surface_samples(clear_tube(rng, pipe_radius=radius), (2000, 5000, 50_000)[seed % 3], rng, view=view,
                          noise=0.03 * radius, outlier_fraction=0.02)
    if seed % 4 == 0:
        pts = np.round(pts, 0 if radius > 10 else 1)  # printed to 1 mm (0.1 mm for thin tubes)
    # well inside the refusal's factor 1.4 either way (balls of 2/3 of a radius gave 0.60 on seed 0)
    assert 0.85 < measured_pipe_radius(pts) / radius < 1.05


@pytest.mark.parametrize("share", [0.3, 0.6])
def test_a_scan_partly_of_something_else_keeps_its_right_radius(share):
    """A table top under the tube (30 %, 60 % of the samples): the stated radius is the one the tube's cross-sections
    show and is taken (at 60 % the median curvature is the table's: before it was refused as 2.7e-38 times it); the
    diameter is still refused where the tube's samples are the most."""
    points = np.loadtxt(REPO / "examples" / "tube" / "scan.xyz")
    rng = np.random.default_rng(0)
    lo, hi = points.min(0), points.max(0)
    n = int(len(points) * share / (1 - share))
    table = np.column_stack([rng.uniform(lo[0], hi[0], n), rng.uniform(lo[1], hi[1], n), np.full(n, lo[2] - 20)])
    scan = np.vstack([points, table])
    assert pipe_radius_against_measured(scan, 6.0, "mm") == []
    if share < 0.5:
        (error,) = pipe_radius_against_measured(scan, 12.0, "mm")
        assert error.loc == ("options", "pipe_radius") and "a diameter?" in error.msg
