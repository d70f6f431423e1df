"""Fixtures of the perfmap solver tests: the real N3 fan map and a synthetic family."""

from __future__ import annotations

from pathlib import Path

import pytest

from plantsolve.schemas.perfmap import PerfmapRequest
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.synthetic import request_body

DATA = Path(__file__).parent / "data"


@pytest.fixture(scope="session")
def n3_csv() -> bytes:
    return (DATA / "n3_fan_map.csv").read_bytes()


@pytest.fixture(scope="session")
def n3_request(n3_csv) -> PerfmapRequest:
    return parse_upload(StoredInput.from_bytes("n3_fan_map.csv", n3_csv), None)


@pytest.fixture(scope="session")
def n3_result(n3_request):
    return solve(n3_request).result


@pytest.fixture(scope="session")
def synthetic_request() -> PerfmapRequest:
    return PerfmapRequest.model_validate(request_body(n_theta=3, n_phi=4,
                                                      options={"grid": [40, 36]}))


@pytest.fixture(scope="session")
def synthetic_result(synthetic_request):
    return solve(synthetic_request).result
