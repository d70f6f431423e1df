"""A 422 names the bad field by the path the user wrote, without the tags pydantic puts in a location for the
member of a union: ``file.points.0.0``, not ``file.points.list.0.0`` (an uploaded tube scan), ``file.magnetic_field
.magnitude``, not ``...magnetic_field.uniform.magnitude`` (a flowmeter's field), in a JSON body, an uploaded .json
file and a kind operation's body alike (one function, :func:`plantsolve.jobs.errors.user_path`)."""

from __future__ import annotations

import copy
import json
import random
import tempfile
import uuid
from pathlib import Path
from typing import Annotated, Union

import pytest
from fastapi.testclient import TestClient
from pydantic import AfterValidator, BaseModel, ValidationError

from plantsolve.app.main import create_app
from plantsolve.jobs.errors import user_path
from plantsolve.schemas.perfmap import PerfmapBetaQueryRequest
from plantsolve.solvers.kinds import load_kinds
from tests.conftest import service_settings

REPO = Path(__file__).resolve().parents[2]
KINDS = load_kinds(())


def _example(path: str) -> dict:
    return json.loads((REPO / path).read_text())


def _changed(body, path: tuple, value):
    body = copy.deepcopy(body)
    node = body
    for step in path[:-1]:
        node = node[step]
    node[path[-1]] = value
    return body


@pytest.fixture(scope="module")
def client():
    with tempfile.TemporaryDirectory() as folder:
        with TestClient(create_app(service_settings(Path(folder)), run_jobs=False)) as test_client:
            yield test_client


def _upload(client, kind: str, body: dict) -> list[dict]:
    response = client.post(f"/v1/{kind}/jobs", files={"file": (f"{kind}.json", json.dumps(body).encode())})
    assert response.status_code == 422, response.text
    return response.json()["errors"]


# (kind, example, a path in it, a bad value there, the error type): places behind a union in the schema
BEHIND_UNIONS = [
    ("tube", "examples/tube/scan_request.json", ("points", 0, 0), "x", "float_type"),
    ("tube", "examples/tube/scan_request.json", ("points", 3), [1.0, 2.0], "too_short"),
    ("tube", "examples/tube/scan_request.json", ("points", 5, 2), 1e300, "less_than_equal"),
    ("flowmeter", "examples/flowmeter/meter.json", ("magnetic_field", "magnitude"), "x", "float_type"),
    ("flowmeter", "examples/flowmeter/meter.json", ("magnetic_field", "magnitude"), True, "float_type"),
]


@pytest.mark.parametrize(("kind", "example", "path", "value", "type_"), BEHIND_UNIONS)
def test_an_uploaded_json_files_error_behind_a_union_names_the_users_path(client, kind, example, path, value, type_):
    """On main: file.points.list.0.0, file.points.list.3, file.magnetic_field.uniform.magnitude."""
    errors = _upload(client, kind, _changed(_example(example), path, value))
    assert [(e["loc"], e["type"]) for e in errors] == [(["file", *path], type_)], errors
    assert errors[0]["pointer"] == "/file/" + "/".join(map(str, path))


@pytest.mark.parametrize(("kind", "example", "path", "value", "type_"), BEHIND_UNIONS)
def test_a_json_bodys_error_behind_a_union_names_the_same_path(client, kind, example, path, value, type_):
    response = client.post(f"/v1/{kind}/jobs", json=_changed(_example(example), path, value))
    assert response.status_code == 422
    assert [(e["loc"], e["type"]) for e in response.json()["errors"]] == [(list(path), type_)]


def test_the_polyhedra_loop_forms_tags_are_left_out(client):
    """A loop is vertex indices or points (a discriminated union tagged 'indices' / 'points')."""
    body = _changed(_example("examples/polyhedra/gable_house.json"), ("faces", 1, "loops", 0, 2, 1), "x")
    for errors in (_upload(client, "polyhedra", body),
                   [*client.post("/v1/polyhedra/jobs", json=body).json()["errors"]]):
        assert [e["loc"][-6:] for e in errors] == [["faces", 1, "loops", 0, 2, 1]], errors
        assert "points" not in errors[0]["loc"][:-6] and "indices" not in errors[0]["loc"]


def test_a_kind_operations_body_names_the_users_path(client):
    """FastAPI validates an operation's body before the job is looked up: the 422 names the body's field."""
    body = {"points": [{"setting": [0.0, 0.9], "beta": 0.5}, {"speed": 0.9, "beta": "half"}]}
    response = client.post(f"/v1/perfmap/jobs/{uuid.uuid4()}/beta", json=body)
    assert response.status_code == 422, response.text
    assert [e["loc"] for e in response.json()["errors"]] == [["points", 1, "beta"]]


def _leaves(value, path=()):
    if isinstance(value, dict):
        for key, item in value.items():
            yield from _leaves(item, (*path, key))
    elif isinstance(value, list):
        for i, item in enumerate(value):
            yield from _leaves(item, (*path, i))
    elif isinstance(value, (int, float)) and not isinstance(value, bool):
        yield path


EXAMPLES = {"tube": "examples/tube/scan_request.json", "flowmeter": "examples/flowmeter/meter.json",
            "polyhedra": "examples/polyhedra/gable_house.json", "alignment": "examples/alignment/ladder.json",
            "perfmap": "examples/perfmap/n3_fan_map.json", "rigidity": "examples/rigidity/four_bar_and_door.json"}


@pytest.mark.parametrize("kind", sorted(EXAMPLES))
def test_every_numbers_refusal_is_named_by_its_place_in_the_document(kind):
    """Each of (up to) 80 numbers of the kind's example, made a word, is refused at its own path (lax mode, as an
    upload is validated), whatever unions the schema has on the way."""
    model = KINDS[kind].request_model
    document = _example(EXAMPLES[kind])
    leaves = list(_leaves(document))
    for path in random.Random(7).sample(leaves, min(80, len(leaves))):
        with pytest.raises(ValidationError) as refused:
            model.model_validate(_changed(document, path, "x"))
        paths = [user_path(e["loc"], model) for e in refused.value.errors()]
        assert list(path) in paths, (path, [e["loc"] for e in refused.value.errors()])


class _Point(BaseModel):
    x: int


class _Made(BaseModel):
    value: Union[list[float], Annotated[list[int], AfterValidator(lambda v: v)], _Point, str]
    items: list[Union[_Point, dict[str, int]]] = []


@pytest.mark.parametrize(("document", "expected"), [
    ({"value": [1, "a"]}, [["value", 1], ["value", 1], ["value"], ["value"]]),
    ({"value": 1, "items": [{"x": "q"}]}, [["value"]] * 4 + [["items", 0, "x"]] * 2),
])
def test_the_names_pydantic_makes_for_unlabelled_members_are_left_out(document, expected):
    with pytest.raises(ValidationError) as refused:
        _Made.model_validate(document)
    assert [user_path(e["loc"], _Made) for e in refused.value.errors()] == expected


@pytest.mark.parametrize("loc", [("file", "line", 7), ("file",), ("options", "units"), ("points", 3, "bogus"),
                                 ("file", "points", 12)])
def test_a_readers_own_location_passes_unchanged(loc):
    from plantsolve.schemas.tube import TubeRequest

    assert user_path(loc, TubeRequest) == list(loc)


def test_a_root_models_tags_are_left_out():
    with pytest.raises(ValidationError) as refused:
        PerfmapBetaQueryRequest.model_validate({"points": [{"speed": 1.0, "beta": 2.0}]})
    (error,) = refused.value.errors()
    assert error["loc"] != ("points", 0, "beta")  # pydantic's: with the tags
    assert user_path(error["loc"], PerfmapBetaQueryRequest) == ["points", 0, "beta"]
