"""Bad input is a 422 naming the field; the example runs through the API and the CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest
from pydantic import ValidationError

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.flowmeter.upload import parse_upload
from plantsolve.solvers.flowmeter.validation import check_input
from plantsolve.solvers.flowmeter.synthetic import example, meter
from tests.conftest import REPO, run_plantsolve, wait_for

# the centre and 64 points on the wall of a pipe of radius 50: v = x there has no mean
RING = np.vstack([[0.0, 0.0], 50 * np.column_stack([np.cos(np.arange(64) * np.pi / 32), np.sin(np.arange(64) * np.pi / 32)])])


@pytest.mark.parametrize("reynolds", [-3.0, 0.0, 2e9])
def test_reynolds_numbers_outside_0_1e9_are_refused_by_the_schema(reynolds):
    with pytest.raises(ValidationError) as error:
        FlowmeterRequest.model_validate(meter(reynolds=[1e4, reynolds]))
    assert error.value.errors()[0]["loc"] == ("reynolds", 1)


@pytest.mark.parametrize("beta", [0.0, -5.0, 90.0, 120.0])
def test_half_angles_outside_0_90_are_refused(beta):
    with pytest.raises(ValidationError) as error:
        FlowmeterRequest.model_validate(meter(half_angle=beta))
    assert error.value.errors()[0]["loc"] == ("electrodes", "half_angle")


@pytest.mark.parametrize("body, loc", [
    (meter(radius=50, half_length=200.0, liner_length=300.0), ("electrodes", "half_length")),
    (meter(shape="point", method="fem"), ("options", "method")),
    (meter(half_length=None, method="integral_equation"), ("options", "method")),
    (meter(half_angle=89.0, half_length=1.0, method="integral_equation"), ("options", "method")),
    (meter(probes=[[60.0, 0.0]]), ("options", "probe_points", 0)),
    (meter(probes=[[1.0]]), ("options", "probe_points", 0)),
    (meter(velocity={"type": "samples", "points": [[0, 0], [1, 1]]}), ("velocity", "values")),
    (meter(velocity={"type": "samples", "points": [[0, 0], [10, 0], [20, 0]], "values": [1, 1, 1]}), ("velocity", "points")),
    (meter(velocity={"type": "samples", "points": [[0, 0], [10, 0], [0, 10]], "values": [1, 1, 1]}), ("velocity", "points")),
    (meter(velocity={"type": "samples", "points": [[0, 0], [80, 0], [0, 10]], "values": [1, 1, 1]}), ("velocity", "points", 1)),
    (meter(velocity={"type": "laminar", "values": [1.0]}), ("velocity", "points")),
    (meter(velocity={"type": "samples", "points": RING.tolist(), "values": RING[:, 0].tolist()}), ("velocity", "values")),
    (meter(radius=50, half_length=0.5), ("electrodes", "half_length")),
    (meter(radius=50, half_length=5.0, liner_length=20.0), ("pipe", "liner_length")),
])
def test_semantic_errors_name_the_field(body, loc):
    request = FlowmeterRequest.model_validate(body)
    with pytest.raises(InputRejected) as error:
        check_input(request)
    assert error.value.errors[0].loc == loc


def test_a_json_upload_is_the_request_and_garbage_names_the_file():
    request = parse_upload(StoredInput.from_bytes("meter.json", json.dumps(example()).encode()), None)
    assert request == FlowmeterRequest.model_validate(example())
    with pytest.raises(InputRejected) as error:
        parse_upload(StoredInput.from_bytes("meter.json", b'{"pipe": {"radius": "wide"}}'), None)
    assert error.value.errors[0].loc[:3] == ("file", "pipe", "radius")


def test_the_api_solves_the_shipped_example_and_refuses_nan(client):
    body = json.loads((REPO / "examples" / "flowmeter" / "meter.json").read_text())
    response = client.post("/v1/flowmeter/jobs", json=body)
    assert response.status_code == 202, response.text
    view = wait_for(client, response.json()["id"], timeout=120)
    assert view["status"] == "succeeded", view["report"]
    result = client.get(f"/v1/jobs/{view['id']}/result").json()
    assert result["method"] == "integral_equation" and abs(result["sensitivity"] - 0.965) < 2e-3
    assert {a["name"] for a in view["artifacts"]} >= {"weight_function.png", "electrode_current.png", "linearity.png",
                                                     "weight_grid.csv"}
    bad = client.post("/v1/flowmeter/jobs", content=json.dumps(body).replace('"magnitude": 0.01', '"magnitude": NaN'),
                      headers={"Content-Type": "application/json"})
    assert bad.status_code == 422
    assert any(e["loc"][:2] == ["magnetic_field", "magnitude"] for e in bad.json()["errors"])


@pytest.mark.parametrize("name, method, sensitivity", [("meter.json", "integral_equation", 0.965),
                                                       ("button.json", "integral_equation", 1 - 0.16**2 / 6)])
def test_the_cli_solves_the_examples(tmp_path, name, method, sensitivity):
    out = tmp_path / "result.json"
    done = run_plantsolve(["solve", "flowmeter", str(REPO / "examples" / "flowmeter" / name), "-o", str(out)], tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads(out.read_text())
    assert result["method"] == method
    assert abs(result["sensitivity"] - sensitivity) < 2e-3


def test_a_json_request_cut_short_is_refused_naming_where_it_stops():
    text = '{\n  "units": "m",\n  "options": {\n    "grid": [64,'
    with pytest.raises(InputRejected) as exc:
        parse_upload(StoredInput.from_bytes("meter.json", text.encode()), None)
    (fe,) = exc.value.errors
    assert fe.loc == ("file",) and "ends before" in fe.msg and "line 4" in fe.msg
