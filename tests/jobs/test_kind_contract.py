"""Every kind in the kind map through the same checks, so a new kind is covered the day it is
registered: garbage in gives a 422 problem document naming the field, never a 500; its example
solves; request and result schemas round-trip."""

from __future__ import annotations

import copy
import functools
import json
import math

import pytest

from plantsolve.solvers.kinds import KINDS
from tests.conftest import wait_for

PROBLEM = "application/problem+json"
KIND_NAMES = sorted(KINDS)


def _number_paths(value, path=()):
    """Paths of the numeric leaves of a JSON value, depth first, with their values."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        yield path, value
    elif isinstance(value, dict):
        for key, item in value.items():
            yield from _number_paths(item, (*path, key))
    elif isinstance(value, list):
        for index, item in enumerate(value):
            yield from _number_paths(item, (*path, index))


def _first_number(value):
    """The first float leaf (else the first int) of a JSON value: the field to spoil."""
    leaves = list(_number_paths(value))
    floats = [path for path, number in leaves if isinstance(number, float)]
    return (floats or [path for path, _ in leaves] or [None])[0]


def _replace(body, path, new):
    body = copy.deepcopy(body)
    target = body
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = new
    return body


def _problem(response, status=422):
    assert response.status_code == status, response.text[:500]
    assert response.headers["content-type"] == PROBLEM
    problem = response.json()
    assert problem["status"] == status and problem["title"]
    return problem


@functools.cache
def _example_json(kind: str) -> str:
    spec = KINDS[kind]
    assert spec.example is not None, f"kind {kind!r} declares no example request"
    return json.dumps(spec.example(), allow_nan=False)  # a JSON body


@pytest.fixture(scope="module")
def examples():
    class Examples:
        def __getitem__(self, kind):
            return json.loads(_example_json(kind))

    return Examples()


@pytest.mark.parametrize("kind", KIND_NAMES)
def test_example_validates_and_the_request_schema_round_trips(kind, examples):
    spec = KINDS[kind]
    request = spec.request_model.model_validate(examples[kind])
    again = spec.request_model.model_validate_json(request.model_dump_json(by_alias=True))
    assert again == request
    spec.check_input(spec.input_of(request))


@pytest.mark.parametrize("kind", KIND_NAMES)
def test_malformed_and_mistyped_json_is_422(client, kind, examples):
    url = f"/v1/{kind}/jobs"
    headers = {"Content-Type": "application/json"}
    _problem(client.post(url, content=b'{"oops": ', headers=headers))
    for wrong in (b"[]", b'"text"', b"1", b"null", b"{}"):
        _problem(client.post(url, content=wrong, headers=headers))
    body = examples[kind]
    path = _first_number(body)
    assert path is not None, "the example has no number to spoil"
    text = json.dumps(_replace(body, path, "__NAN__")).replace('"__NAN__"', "NaN").encode()
    problem = _problem(client.post(url, content=text, headers=headers))
    assert any(tuple(e["loc"][: len(path)]) == path or e["loc"][:1] == [path[0]] for e in problem["errors"]), problem
    for bad in ("not a number", 1e999, [1, 2]):
        payload = json.dumps(_replace(body, path, bad)).replace("Infinity", "1e999").encode()
        problem = _problem(client.post(url, content=payload, headers=headers))
        assert all(e["loc"] for e in problem["errors"]), problem
    unknown = _replace(body, ("no_such_field_anywhere",), 1)
    problem = _problem(client.post(url, json=unknown))
    assert any("no_such_field_anywhere" in e["loc"] for e in problem["errors"]), problem


@pytest.mark.parametrize("kind", KIND_NAMES)
def test_garbage_uploads_are_422_naming_the_file(client, kind):
    url = f"/v1/{kind}/jobs"
    for extension in KINDS[kind].upload_extensions:
        for content in (b"", b"\x00\x01\x02\xff garbage \xfe", "\u00e9t\u00e9;;;\n1,2\n".encode("utf-16")):
            problem = _problem(client.post(url, files={"file": (f"input{extension}", content, "application/octet-stream")}))
            assert problem["errors"] and problem["errors"][0]["loc"][0] == "file", (extension, problem)
    unknown = client.post(url, files={"file": ("input.exe", b"MZ", "application/octet-stream")})
    _problem(unknown, 415)


@pytest.mark.parametrize("kind", KIND_NAMES)
def test_the_example_solves_and_the_result_schema_round_trips(client, kind, examples):
    spec = KINDS[kind]
    response = client.post(f"/v1/{kind}/jobs", json=examples[kind])
    assert response.status_code == 202, response.text[:500]
    view = wait_for(client, response.json()["id"], timeout=120)
    assert view["status"] == "succeeded", view["report"]
    assert view["report"]["status"] in ("ok", "warning")
    payload = client.get(f"/v1/jobs/{view['id']}/result").json()
    result = spec.result_model.model_validate(payload)
    assert spec.result_model.model_validate_json(result.model_dump_json(by_alias=True)) == result
    assert not [p for p in _floats(payload) if not math.isfinite(p)]
    for artifact in view["artifacts"]:
        got = client.get(artifact["url"])
        assert got.status_code == 200 and len(got.content) == artifact["size"]


def _floats(value):
    if isinstance(value, float):
        yield value
    elif isinstance(value, dict):
        for item in value.values():
            yield from _floats(item)
    elif isinstance(value, list):
        for item in value:
            yield from _floats(item)


def test_openapi_documents_every_kind_with_its_schemas(client):
    schema = client.get("/openapi.json").json()
    for kind, spec in KINDS.items():
        assert f"/v1/{kind}/jobs" in schema["paths"]
        assert spec.request_model.__name__ in schema["components"]["schemas"]
        assert spec.result_model.__name__ in schema["components"]["schemas"]
        for operation in spec.operations:
            assert f"/v1/{kind}/jobs/{{job_id}}/{operation.name}" in schema["paths"]
