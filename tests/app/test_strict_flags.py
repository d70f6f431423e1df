"""A yes/no of a request is JSON's ``true`` or ``false``, whichever way the request came.

An uploaded .json file and an upload form's options are validated from parsed JSON in pydantic's lax mode, where a
``bool`` field read ``1``, ``0``, ``"yes"``, ``"on"``, ``"true"`` and ``"1"`` as booleans: ``{"list_faces": "no"}``
listed no faces because "no" happened to be a word pydantic knows, ``{"common_bend_radius": 1}`` fitted one radius.
Every bool of a request is now :data:`plantsolve.schemas.common.Flag` (strict, its own message)."""

from __future__ import annotations

import json
import tempfile
import typing
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from pydantic import BaseModel, Strict

from plantsolve.app.main import create_app
from plantsolve.solvers.kinds import load_kinds
from tests.conftest import service_settings
from tests.support.documents import with_value

REPO = Path(__file__).resolve().parents[2]
KINDS = load_kinds(())
LAX_TRUTHS = ["yes", "on", "true", "1", 1, 0, "no", "off", "false", "0", 1.0]


def _example(path: str) -> dict:
    return json.loads((REPO / path).read_text())


def _file(path: str) -> tuple[str, bytes]:
    return Path(path).name, (REPO / path).read_bytes()


@pytest.fixture(scope="module")
def client():
    """Submissions only: no job runs (what is judged is the intake's answer)."""
    with tempfile.TemporaryDirectory() as folder:
        with TestClient(create_app(service_settings(Path(folder)), run_jobs=False)) as test_client:
            yield test_client


# (kind, example request, path of a bool in it) for an uploaded .json file
JSON_FILES = [
    ("tube", "examples/tube/scan_request.json", ("options", "common_bend_radius")),
    ("alignment", "examples/alignment/ladder.json", ("components", 0, "fixed")),
    ("alignment", "examples/alignment/ladder.json", ("options", "anchor")),
    ("perfmap", "examples/perfmap/n3_fan_map.json", ("options", "map")),
    ("perfmap", "examples/perfmap/n3_fan_map.json", ("options", "concave_efficiency")),
    ("polyhedra", "examples/polyhedra/gable_house.json", ("options", "list_faces")),
    ("polyhedra", "examples/polyhedra/gable_house.json", ("options", "faces_csv")),
]

# (kind, uploaded file, option) for a form's options beside a file of the kind's own format
FORM_OPTIONS = [
    ("tube", "examples/tube/scan.xyz", "common_bend_radius"),
    ("alignment", "examples/alignment/ladder.pcf", "anchor"),
    ("perfmap", "examples/perfmap/n3_fan_map.csv", "concave_efficiency"),
    ("perfmap", "examples/perfmap/n3_fan_map.csv", "map"),
    ("polyhedra", "examples/polyhedra/two_offices.idf", "faces_csv"),
    ("polyhedra", "examples/polyhedra/two_offices.idf", "list_faces"),
]


def _refused_naming(response, loc: list) -> None:
    """One 422 of type bool_type naming ``loc``: as its location, or (perfmap names a JSON file's errors by the
    file) as ``file`` with the path at the start of the message."""
    assert response.status_code == 422, response.text
    errors = response.json()["errors"]
    assert len(errors) == 1, errors
    named_in_message = loc[:1] == ["file"] and errors[0]["loc"] == ["file"] and \
        errors[0]["msg"].startswith("/".join(map(str, loc[1:])) + ":")
    assert errors[0]["loc"] == loc or named_in_message, errors
    assert errors[0]["type"] == "bool_type" and "true or false" in errors[0]["msg"], errors


@pytest.mark.parametrize(("kind", "example", "path"), JSON_FILES)
@pytest.mark.parametrize("value", LAX_TRUTHS[:6])
def test_a_lax_boolean_in_an_uploaded_json_file_is_refused_naming_it(client, kind, example, path, value):
    """On main each of these was a 202: the file's "yes" or 1 read as true."""
    body = with_value(_example(example), path, value)
    response = client.post(f"/v1/{kind}/jobs", files={"file": (f"{kind}.json", json.dumps(body).encode())})
    _refused_naming(response, ["file", *path])


@pytest.mark.parametrize(("kind", "upload", "option"), FORM_OPTIONS)
@pytest.mark.parametrize("value", LAX_TRUTHS)
def test_a_lax_boolean_in_the_form_options_is_refused_naming_it(client, kind, upload, option, value):
    response = client.post(f"/v1/{kind}/jobs", files={"file": _file(upload)},
                           data={"options": json.dumps({option: value})})
    _refused_naming(response, ["options", option])


@pytest.mark.parametrize(("kind", "upload", "option"), FORM_OPTIONS)
def test_true_and_false_in_the_form_options_are_taken(client, kind, upload, option):
    for value in (True, False):
        response = client.post(f"/v1/{kind}/jobs", files={"file": _file(upload)},
                               data={"options": json.dumps({option: value})})
        assert response.status_code == 202, (value, response.text)
        stored = client.get(response.headers["Location"] + "/input").json()
        assert stored["options"] == {option: value}


@pytest.mark.parametrize(("kind", "example", "path"), JSON_FILES)
def test_a_json_body_stays_strict_and_takes_true(client, kind, example, path):
    body = _example(example)
    response = client.post(f"/v1/{kind}/jobs", json=with_value(body, path, "true"))
    assert response.status_code == 422 and response.json()["errors"][0]["loc"] == list(path), response.text
    assert client.post(f"/v1/{kind}/jobs", json=with_value(body, path, True)).status_code == 202


def _flat(annotation) -> list:
    return [annotation] + [a for arg in typing.get_args(annotation) for a in _flat(arg)]


def _lax_bools(model: type[BaseModel], seen: set | None = None, prefix: str = "") -> list[str]:
    """The bool fields of ``model`` and the models it holds that pydantic would read laxly."""
    seen = set() if seen is None else seen
    if model in seen:
        return []
    seen.add(model)
    found = []
    for name, field in model.model_fields.items():
        parts = _flat(field.annotation)
        strict_inside = any(typing.get_origin(a) is typing.Annotated and bool in typing.get_args(a)[:1]
                            and any(isinstance(m, Strict) for m in a.__metadata__) for a in parts)
        if bool in parts and not strict_inside and not any(isinstance(m, Strict) for m in field.metadata):
            found.append(f"{prefix}{name}")
        for inner in parts:
            if isinstance(inner, type) and issubclass(inner, BaseModel):
                found += _lax_bools(inner, seen, f"{prefix}{name}.")
    return found


def _request_models(kind: str) -> list[type[BaseModel]]:
    spec = KINDS[kind]
    return [spec.request_model, *(operation.request_model for operation in spec.operations)]


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_every_bool_of_every_request_is_strict(kind):
    """A walk of the request models (and the kind operations' bodies): a new bool field that is a plain ``bool``
    fails here."""
    assert [field for model in _request_models(kind) for field in _lax_bools(model)] == []


def test_the_walk_finds_a_lax_bool():
    class Inner(BaseModel):
        on: bool | None = None

    class Outer(BaseModel):
        inner: Inner
        strict: typing.Annotated[bool, Strict()] = False

    assert _lax_bools(Outer) == ["inner.on"]


def test_the_openapi_document_keeps_every_flag_a_boolean(client):
    schemas = client.get("/openapi.json").json()["components"]["schemas"]
    for model, field in (("TubeOptions", "common_bend_radius"), ("AlignmentOptions", "anchor"),
                         ("Component", "fixed"), ("PolyhedraOptions", "faces_csv")):
        prop = schemas[model]["properties"][field]
        kinds = [prop.get("type")] + [member.get("type") for member in prop.get("anyOf", ())]
        assert "boolean" in kinds and not {"integer", "string", "number"} & set(kinds), (model, prop)
