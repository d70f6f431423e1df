"""Hostile and extreme input: every one a 4xx problem document naming the field, never a 500."""

from __future__ import annotations

import json

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from plantsolve.solvers.perfmap.synthetic import example as perfmap_example
from tests.conftest import service_settings, wait_for

PROBLEM = "application/problem+json"


def deep(levels: int) -> str:
    return "[" * levels + "1" + "]" * levels


def pipe(position1=(1000.0, 0.0, 0.0), direction0=(-1.0, 0.0, 0.0)):
    return {"id": "P", "kind": "pipe", "ports": [{"position": [0.0, 0.0, 0.0], "direction": list(direction0)},
                                                  {"position": list(position1), "direction": [1.0, 0.0, 0.0]}]}


@pytest.mark.parametrize("levels", [1000, 5000, 100_000])
def test_deeply_nested_json_body_is_a_422(client, levels):
    for kind in ("test-compute", "alignment", "perfmap", "tube"):
        body = '{"values": ' + deep(levels) + "}"
        response = client.post(f"/v1/{kind}/jobs", content=body, headers={"Content-Type": "application/json"})
        assert response.status_code == 422, (kind, response.status_code)
        assert response.headers["content-type"] == PROBLEM
        assert response.json()["errors"][0]["type"] == "json_too_deep"


def test_deeply_nested_options_field_and_json_upload_are_422(client):
    files = {"file": ("numbers.txt", b"1\n2\n", "text/plain")}
    response = client.post("/v1/test-compute/jobs", files=files, data={"options": deep(3000)})
    assert response.status_code == 422 and response.json()["errors"][0]["loc"] == ["options"]
    files = {"file": ("model.json", ('{"components": ' + deep(3000) + "}").encode(), "application/json")}
    response = client.post("/v1/alignment/jobs", files=files)
    assert response.status_code == 422 and response.json()["errors"][0]["loc"][0] == "file"


def test_a_key_named_twice_in_one_object_is_a_422_not_the_last_value_taken(client):
    """json.loads keeps the last of two equal keys: '"units": "mm", …, "units": "m"' was solved in metres without a
    word. A body, the options field and an uploaded JSON file naming a key twice are refused naming the key."""
    body = '{"units": "mm", "components": [' + json.dumps(pipe()) + '], "units": "m"}'
    response = client.post("/v1/alignment/jobs", content=body, headers={"Content-Type": "application/json"})
    assert response.status_code == 422 and response.headers["content-type"] == PROBLEM
    (error,) = response.json()["errors"]
    assert error["type"] == "json_duplicate_key" and "'units' appears twice" in error["msg"]
    files = {"file": ("numbers.txt", b"1\n2\n", "text/plain")}
    response = client.post("/v1/test-compute/jobs", files=files, data={"options": '{"a": 1, "a": 2}'})
    assert response.status_code == 422 and response.json()["errors"][0]["loc"] == ["options"]
    for kind, name in (("alignment", "model.json"), ("tube", "scan.json"), ("perfmap", "map.json"),
                       ("flowmeter", "meter.json")):
        files = {"file": (name, body.encode(), "application/json")}
        response = client.post(f"/v1/{kind}/jobs", files=files)
        assert response.status_code == 422, (kind, response.text)
        assert response.json()["errors"][0]["loc"][0] == "file" and "appears twice" in response.text, kind
    # the same key in two different objects is no duplicate
    fine = {"units": "mm", "components": [pipe(), {**pipe(), "id": "Q"}]}
    assert client.post("/v1/alignment/jobs", json=fine).status_code == 202


@pytest.mark.parametrize("component, loc", [
    (pipe(direction0=(-1e200, 1.0, 0.0)), ["components", 0, "ports", 0, "direction", 0]),
    (pipe(position1=(1e13, 0.0, 0.0)), ["components", 0, "ports", 1, "position", 0]),
    ({**pipe(), "radius": 1e300}, ["components", 0, "radius"]),
])
def test_extreme_magnitudes_are_refused_by_the_schema(client, component, loc):
    response = client.post("/v1/alignment/jobs", json={"components": [component]})
    assert response.status_code == 422
    assert response.json()["errors"][0]["loc"] == loc


def test_pcf_with_a_two_coordinate_end_point_is_accepted_and_the_item_reported(client):
    text = ("UNITS-CO-ORDS MM\nPIPE\n    END-POINT 0 0 0 100\n    END-POINT 1000 0 0 100\n"
            "PIPE\n    END-POINT 1000 0 0 100\n    END-POINT 2000 0\n")
    response = client.post("/v1/alignment/jobs", files={"file": ("x.pcf", text.encode(), "text/plain")})
    assert response.status_code == 202, response.text
    done = wait_for(client, response.json()["id"])
    assert done["status"] == "succeeded"
    held = [w for w in done["report"]["warnings"] if w["code"] == "pcf_items_held"]
    assert held and held[0]["details"]["items"][0]["line"] == 5


def test_input_download_never_echoes_a_path_in_its_file_name(client):
    files = {"file": ("../../../../tmp/evil name;.txt", b"1\n2\n", "text/plain")}
    job = client.post("/v1/test-compute/jobs", files=files).json()
    disposition = client.get(f"/v1/jobs/{job['id']}/input/file").headers["content-disposition"]
    assert "/" not in disposition and ".." not in disposition and "evil_name" in disposition


def test_wrong_method_is_a_405_with_allow(client):
    for method in ("PUT", "OPTIONS", "DELETE"):
        response = client.request(method, "/v1/jobs")
        assert response.status_code == 405 and response.headers["content-type"] == PROBLEM
        assert response.headers["allow"] == "GET"


def test_an_upload_above_the_file_limit_is_a_413(tmp_path):
    with TestClient(create_app(service_settings(tmp_path, max_upload_bytes=1000))) as client:
        files = {"file": ("numbers.txt", b"1\n" * 600, "text/plain")}
        response = client.post("/v1/test-compute/jobs", files=files)
        assert response.status_code == 413 and response.headers["content-type"] == PROBLEM
        assert client.post("/v1/test-compute/jobs", files={"file": ("n.txt", b"1\n" * 10, "text/plain")}).status_code == 202


def test_multipart_with_too_many_fields_is_a_documented_400(client):
    data = {f"f{i}": "x" for i in range(10)}
    response = client.post("/v1/test-compute/jobs", files={"file": ("n.txt", b"1\n", "text/plain")}, data=data)
    assert response.status_code == 400 and response.headers["content-type"] == PROBLEM
    spec = client.get("/openapi.json").json()
    assert "400" in spec["paths"]["/v1/test-compute/jobs"]["post"]["responses"]
    assert json.dumps(response.json())


def test_an_operation_body_that_is_not_text_is_a_422_naming_the_body(client):
    job = client.post("/v1/perfmap/jobs", json=perfmap_example()).json()
    response = client.post(f"/v1/perfmap/jobs/{job['id']}/query", content=b"\x8b\xff\xfe{",
                           headers={"Content-Type": "application/json"})
    assert response.status_code == 422 and response.headers["content-type"].startswith("application/problem+json")
    assert response.json()["errors"][0]["type"] == "json_invalid"


def test_numbers_are_numbers_in_a_json_submission(client):
    body = perfmap_example()
    body["options"] = {"envelope_points": True}
    response = client.post("/v1/perfmap/jobs", json=body)
    assert response.status_code == 422 and response.json()["errors"][0]["loc"] == ["options", "envelope_points"]
    body["options"] = {"envelope_points": "50"}
    assert client.post("/v1/perfmap/jobs", json=body).status_code == 422
    body["options"] = {"envelope_points": 50.0}  # JSON Schema's integer: no fraction
    assert client.post("/v1/perfmap/jobs", json=body).status_code == 202
    body["options"] = {"envelope_points": 50.5}
    assert client.post("/v1/perfmap/jobs", json=body).json()["errors"][0]["type"] == "int_from_float"


def test_a_table_far_beyond_any_rig_is_refused_before_it_is_parsed(client):
    rows = b"theta,phi,flow,pressure,efficiency\n" + b"0,0,1.0,2.0,0.8\n" * 250_000
    response = client.post("/v1/perfmap/jobs", files={"file": ("rig.csv", rows, "text/csv")})
    assert response.status_code == 422
    (error,) = response.json()["errors"]
    assert error["loc"] == ["file"] and "250,001 lines" in error["msg"] and "200,000" in error["msg"]


def test_tube_and_perfmap_values_beyond_1e12_are_refused_naming_the_value(client):
    from plantsolve.solvers.tube.synthetic import example as tube_example

    body = tube_example()
    body["points"][5] = [1e13, 0.0, 0.0]
    response = client.post("/v1/tube/jobs", json=body)
    assert response.status_code == 422 and response.json()["errors"][0]["loc"] == ["points", 5, 0]
    body = perfmap_example()
    body["positions"][1]["flow"][2] = 1e200
    response = client.post("/v1/perfmap/jobs", json=body)
    assert response.status_code == 422 and response.json()["errors"][0]["loc"] == ["positions", 1, "flow", 2]


@pytest.mark.parametrize("points, pointers", [
    ("abc", ["/points"]),  # pydantic's location is points -> list[...] (the union member tried): no such key
    (17, ["/points"]),
    ([[1, 2, "x"]], ["/points/0/2"]),
    ({"a": 1}, ["/points/npy_base64", "/points/a"]),  # an object is the other member: its missing and extra keys
])
def test_an_error_inside_a_union_field_points_into_the_document(client, points, pointers):
    problem = client.post("/v1/tube/jobs", json={"points": points}).json()
    assert [e["pointer"] for e in problem["errors"]] == pointers, problem


def test_a_form_part_nothing_reads_is_a_422_naming_it(client):
    """A 'units' part beside the file was ignored: the file read in the default unit, the job accepted."""
    files = {"file": ("n.txt", b"1\n", "text/plain")}
    response = client.post("/v1/test-compute/jobs", files=files, data={"units": "m"})
    assert response.status_code == 422 and response.headers["content-type"] == PROBLEM
    assert [e["loc"] for e in response.json()["errors"]] == [["units"]]
    assert "options" in response.json()["detail"]
    assert client.post("/v1/test-compute/jobs", files=files, data={"options": "{}"}).status_code == 202
