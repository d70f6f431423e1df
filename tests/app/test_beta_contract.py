"""``POST /v1/perfmap/jobs/{id}/beta``: one error per bad field with a plain JSON pointer into the body as sent,
strict numbers, both documented forms (a list of points, or one point) in the schema, an OpenAPI example that
works on the kind's shipped example job, and messages without Python reprs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from tests.conftest import service_settings, wait_for

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    app = create_app(service_settings(tmp_path_factory.mktemp("beta")))
    with TestClient(app) as client:
        example = app.state.ctx.kinds["perfmap"].example()
        job = client.post("/v1/perfmap/jobs", json=example).json()
        assert wait_for(client, job["id"], timeout=120)["status"] == "succeeded"
        yield client, job["id"]


def _errors(response) -> list[tuple[str, str]]:
    assert response.status_code == 422, response.text[:300]
    assert response.headers["content-type"] == "application/problem+json"
    return [(e["pointer"], e["msg"]) for e in response.json()["errors"]]


def test_the_openapi_example_answers_on_the_example_job(served):
    client, job = served
    operation = client.get("/openapi.json").json()["paths"]["/v1/perfmap/jobs/{job_id}/beta"]["post"]
    example = operation["requestBody"]["content"]["application/json"]["example"]
    answer = client.post(f"/v1/perfmap/jobs/{job}/beta", json=example)
    assert answer.status_code == 200, answer.text[:500]
    points = answer.json()["points"]
    assert [p["setting"] for p in points] == [p["setting"] for p in example["points"]]
    assert [p["beta"] for p in points] == [p["beta"] for p in example["points"]]
    assert all(0 < p["efficiency"] <= 1 and p["flow"] > 0 and p["pressure"] > 0 for p in points)
    # the shipped file of the README's curl line too (its first point asks the same as the example's first)
    shipped = json.loads((ROOT / "examples/perfmap/beta_query.json").read_text())
    assert shipped["points"][0] == example["points"][0]


def test_one_bad_value_is_one_error_with_a_plain_pointer(served):
    client, job = served
    url = f"/v1/perfmap/jobs/{job}/beta"
    assert _errors(client.post(url, json={"points": [{"setting": [0.0, 0.9], "beta": 0.5},
                                                     {"speed": 0.9, "beta": 1.5}]})) == [
        ("/points/1/beta", "Input should be less than or equal to 1")]
    assert _errors(client.post(url, json={"speed": 0.9, "beta": -0.1})) == [
        ("/beta", "Input should be greater than or equal to 0")]
    assert _errors(client.post(url, json={"points": [{"setting": [0.0, 0.9]}]})) == [("/points/0/beta", "Field required")]
    extra = _errors(client.post(url, json={"points": [{"speed": 0.9, "setting": [0.0, 0.9], "beta": 0.5}]}))
    assert [pointer for pointer, _ in extra] == ["/points/0/setting"]
    wrong_shape = _errors(client.post(url, json={"points": [3]}))
    assert len(wrong_shape) == 1 and wrong_shape[0][0] == "/points/0" and '{"speed": number' in wrong_shape[0][1]
    assert len(_errors(client.post(url, json=[0.9, 0.5]))) == 1
    for response in (client.post(url, json={"points": [{"speed": 0.9, "beta": 1.5}]}),
                     client.post(url, json={"alpha": 1})):
        assert "BetaPoint" not in response.text and "points_list" not in response.text and "by_speed" not in response.text


def test_numbers_are_strict(served):
    client, job = served
    url = f"/v1/perfmap/jobs/{job}/beta"
    assert _errors(client.post(url, json={"speed": "0.9", "beta": 0.5})) == [("/speed", "Input should be a valid number")]
    assert _errors(client.post(url, json={"points": [{"setting": [0.0, "0.9"], "beta": 0.5}]})) == [
        ("/points/0/setting/1", "Input should be a valid number")]
    assert _errors(client.post(url, json={"setting": [0.0, 0.9], "beta": True})) == [("/beta", "Input should be a valid number")]
    assert client.post(url, json={"setting": [0, 1], "beta": 1}).status_code == 200  # an integer is a number


def test_the_one_point_form_is_in_the_schema_and_answers_like_the_list(served):
    client, job = served
    spec = client.get("/openapi.json").json()
    body = spec["paths"]["/v1/perfmap/jobs/{job_id}/beta"]["post"]["requestBody"]["content"]["application/json"]["schema"]
    schemas = spec["components"]["schemas"]
    request = schemas[body["$ref"].rsplit("/", 1)[1]]
    forms = {ref["$ref"].rsplit("/", 1)[1] for ref in request["oneOf"]}
    assert forms == {"BetaPoints", "BetaPointBySetting", "BetaPointBySpeed"}
    assert schemas["BetaPointBySpeed"]["required"] == ["speed", "beta"]
    url = f"/v1/perfmap/jobs/{job}/beta"
    one = client.post(url, json={"setting": [0.0, 0.9], "beta": 0.5}).json()["points"]
    listed = client.post(url, json={"points": [{"setting": [0.0, 0.9], "beta": 0.5}]}).json()["points"]
    assert one == listed and len(one) == 1


def test_messages_are_plain_text(served):
    client, job = served
    url = f"/v1/perfmap/jobs/{job}/beta"
    errors = _errors(client.post(url, json={"points": [{"setting": [7.0, 0.9], "beta": 0.5}]}))
    assert len(errors) == 1 and errors[0][0] == "/points/0/setting/0"
    assert errors[0][1] == "theta = 7 is no value of the map (it has 0; 30)", errors
    speed = _errors(client.post(url, json={"speed": 0.9, "beta": 0.5}))  # two settings: speed alone is not enough
    assert speed[0][0] == "/speed" and "give 'setting' with all of them" in speed[0][1]  # where it is in the body
    listed = _errors(client.post(url, json={"points": [{"setting": [0.0, 0.9], "beta": 0.5}, {"speed": 0.9, "beta": 0.5}]}))
    assert [pointer for pointer, _ in listed] == ["/points/1/speed"]
