"""JSON's ``true`` and ``false`` are no number, in any kind and any path by which a request arrives.

A JSON body is validated strictly as a whole, but an uploaded .json file, an upload form's options and a kind
operation's body are validated from parsed JSON in pydantic's lax mode, where a bare ``float`` took ``true`` as 1.0:
a flowmeter's radius of 1 (refused for a liner it made 300 radii long), a polyhedra vertex at x = 1, a perfmap query
at flow 1 answered 'infeasible'. Every number of a request is now strict (``schemas.common.Number``); an option an
upload form may type as text (``"6"``) is still read as that number."""

from __future__ import annotations

import json
import types
import typing
import uuid
from pathlib import Path

import pytest
from pydantic import BaseModel, ValidationError
from pydantic.fields import FieldInfo

from plantsolve.jobs import intake
from plantsolve.jobs.errors import Unprocessable
from plantsolve.schemas.common import json_integer
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.kinds import load_kinds
from tests.support.documents import with_value

REPO = Path(__file__).resolve().parents[2]
KINDS = load_kinds(())
PROBLEM = "application/problem+json"


def _example(path: str) -> dict:
    return json.loads((REPO / path).read_text())


def _tetrahedron() -> dict:
    """Four vertices and four index loops: the polyhedra form whose numbers are the shared vertex list."""
    return {"units": "m", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]],
            "faces": [{"id": "a", "loops": [[0, 2, 1]]}, {"id": "b", "loops": [[0, 1, 3]]},
                      {"id": "c", "loops": [[0, 3, 2]]}, {"id": "d", "loops": [[1, 2, 3]]}]}


def _dedup() -> dict:
    return {**_example("plantsolve/solvers/dedup/example.json"), "options": {"tolerance": 1e-4}}


BODIES = {
    "perfmap": lambda: _example("examples/perfmap/n3_fan_map.json"),
    "flowmeter": lambda: _example("examples/flowmeter/meter.json"),
    "polyhedra": _tetrahedron,
    "rigidity": lambda: _example("examples/rigidity/four_bar_and_door.json"),
    "rigidity-parts": lambda: {"units": "mm", "parts": [{"id": "a", "part": "3001", "position": [0, 0, 0]},
                                                         {"id": "b", "part": "3001", "position": [0, -24, 0]}]},
    "alignment": lambda: _example("examples/alignment/ladder.json"),
    "tube": lambda: _example("examples/tube/scan_request.json"),
    "dedup": _dedup,
}

# (body, path of a scalar or an array's number): one of each per kind, and the paths the brief named
NUMBERS = [
    ("perfmap", ("positions", 0, "theta")), ("perfmap", ("positions", 0, "flow", 3)),
    ("flowmeter", ("pipe", "radius")), ("flowmeter", ("reynolds", 0)), ("flowmeter", ("options", "tolerance")),
    ("polyhedra", ("vertices", 2, 0)), ("polyhedra", ("options", "merge_tolerance")),
    ("rigidity", ("options", "contact_tolerance")), ("rigidity", ("joints", 1, "point", 0)),
    ("rigidity", ("bodies", 0, "shape", "box", "size", 2)), ("rigidity-parts", ("parts", 1, "position", 1)),
    ("alignment", ("components", 0, "radius")), ("alignment", ("components", 0, "ports", 1, "position", 0)),
    ("alignment", ("components", 0, "ports", 0, "direction", 2)),
    ("tube", ("options", "tolerance")), ("tube", ("points", 7, 2)),
    ("dedup", ("options", "tolerance")),
]


def _at(value, path: tuple):
    for step in path:
        value = getattr(value, step) if isinstance(value, BaseModel) else value[step]
    return value


def _spec(name: str):
    return KINDS[name.split("-")[0]]


def _body_refusal(name: str, body: dict) -> list:
    with pytest.raises(Unprocessable) as refused:
        intake.read_json(_spec(name), json.dumps(body).encode())
    return refused.value.errors


def _upload_refusal(name: str, body: dict, options: dict | None = None) -> list:
    source = StoredInput.from_bytes("request.json", json.dumps(body).encode())
    with pytest.raises(Unprocessable) as refused:
        intake.read_upload(_spec(name), source, options)
    return refused.value.errors


def _names(error: dict, path: tuple) -> bool:
    """The refusal names ``path`` of the uploaded document: as its location, or, for a kind that names a JSON
    file's errors by the file, at the start of its message."""
    loc = error["loc"][1:] if error["loc"][:1] == ["file"] else error["loc"]
    return loc == list(path) or \
        error["msg"].startswith("/".join(map(str, path)) + ":")


@pytest.mark.parametrize(("name", "path"), NUMBERS)
@pytest.mark.parametrize("value", [True, False])
def test_true_and_false_in_a_json_body_are_refused_naming_the_path(name, path, value):
    errors = _body_refusal(name, with_value(BODIES[name](), path, value))
    assert [e["loc"] for e in errors] == [list(path)], errors
    assert errors[0]["type"] == "float_type"


@pytest.mark.parametrize(("name", "path"), NUMBERS)
def test_true_in_an_uploaded_json_file_is_refused_naming_the_path(name, path):
    """The upload path validated in lax mode: on main most of these were read as 1.0 and accepted, or refused for
    what the 1 made (a flowmeter liner 300 radii long), not for the true."""
    body = with_value(BODIES[name](), path, True)
    errors = _upload_refusal(name, body)
    assert len(errors) == 1 and _names(errors[0], path), errors
    assert errors[0]["type"] == "float_type"


def _field_of(model: type[BaseModel], path: tuple):
    """The FieldInfo of the last named field on ``path``."""
    field = None
    for step in path:
        if isinstance(step, str):
            field = model.model_fields[step]
            inner = [a for a in _flat(field.annotation) if isinstance(a, type) and issubclass(a, BaseModel)]
            model = inner[0] if inner else model
    return field


def _flat(annotation) -> list:
    args = typing.get_args(annotation)
    return [annotation] + [a for arg in args for a in _flat(arg)]


def _within(field, value: float) -> bool:
    """Whether ``value`` is within the bounds of ``field`` (its own, or its array items')."""
    found = list(field.metadata)
    for arg in _flat(field.annotation):  # an array's items carry their bounds in their own Annotated
        found += getattr(arg, "__metadata__", ())
    found += [m for info in found if isinstance(info, FieldInfo) for m in info.metadata]
    bounds = {type(m).__name__: m for m in found}
    return not (("Gt" in bounds and value <= bounds["Gt"].gt) or ("Ge" in bounds and value < bounds["Ge"].ge) or
                ("Lt" in bounds and value >= bounds["Lt"].lt) or ("Le" in bounds and value > bounds["Le"].le))


ACCEPTED = [(name, path, value) for name, path in NUMBERS for value in (6, 6.0, -1e3)
            if _within(_field_of(_spec(name).request_model, path), value)]


@pytest.mark.parametrize(("name", "path", "value"), ACCEPTED)
def test_numbers_are_read_as_written_in_a_body_and_an_upload(name, path, value):
    """6, 6.0 and -1e3 are still numbers (strict floats take JSON's integers) wherever the field's bounds allow
    them: the same value read by the JSON body's validation and by the upload's."""
    spec = _spec(name)
    text = json.dumps(with_value(BODIES[name](), path, value)).encode()
    request = spec.request_model.model_validate_json(text, strict=True)  # what intake.read_json validates with
    assert _at(request, path) == float(value) and type(_at(request, path)) is float
    uploaded = spec.parse_upload(StoredInput.from_bytes("request.json", text), None)
    if name != "tube" or path[0] != "points":  # a tube file's points are read into an array
        assert _at(uploaded, path) == float(value)


def _unguarded_numbers(schema, path=(), guarded=False) -> list[str]:
    """Places in a pydantic core schema where a float or an int is validated laxly (so that true reads as 1):
    neither strict nor behind :func:`json_integer` (which refuses true and false itself)."""
    found = []
    if isinstance(schema, dict):
        kind = schema.get("type")
        if kind == "function-before" and schema.get("function", {}).get("function") is json_integer:
            guarded = True
        if kind in ("float", "int") and not schema.get("strict") and not guarded:
            found.append(".".join(path) or "(root)")
        for key, value in schema.items():
            if key in ("serialization", "metadata", "ref"):
                continue
            step = (*path, key) if key not in ("schema", "items_schema", "fields", "choices", "definitions",
                                               "values_schema", "type") else path
            found += _unguarded_numbers(value, step, guarded and key == "schema")
    elif isinstance(schema, (list, tuple)):
        for item in schema:
            found += _unguarded_numbers(item, path, guarded)
    return found


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_every_number_of_every_request_refuses_true_in_every_mode(kind):
    """The schema walked, not sampled: every float and int of the kind's request and of its operations' requests
    is strict or an ``Integer`` (main had 87 lax places: every flowmeter number, every coordinate, the options)."""
    spec = KINDS[kind]
    for model in (spec.request_model, *(operation.request_model for operation in spec.operations)):
        assert _unguarded_numbers(model.__pydantic_core_schema__) == [], model.__name__


def _options_models(model: type[BaseModel], seen: set | None = None) -> list[type[BaseModel]]:
    """An options model and the models nested in it (a tube's inspection tolerances, a rigidity dock)."""
    seen = set() if seen is None else seen
    if model in seen:
        return []
    seen.add(model)
    found = [model]
    for field in model.model_fields.values():
        for arg in _flat(field.annotation):
            if isinstance(arg, type) and issubclass(arg, BaseModel):
                found += _options_models(arg, seen)
    return found


def _one_number(annotation) -> bool:
    """A float, or a float or None (not a list of them)."""
    members = typing.get_args(annotation) if typing.get_origin(annotation) in (typing.Union, types.UnionType) \
        else (annotation,)
    members = [typing.get_args(m)[0] if typing.get_origin(m) is typing.Annotated else m for m in members]
    return float in members and all(m in (float, type(None)) for m in members)


def _number_fields(model: type[BaseModel]) -> list[str]:
    """Fields holding one number (or none): what an upload form's user may type as text."""
    return [name for name, field in model.model_fields.items() if _one_number(field.annotation)]


FORM_OPTIONS = [(kind, model, name) for kind in sorted(KINDS)
                for model in _options_models(KINDS[kind].request_model.model_fields["options"].annotation)
                for name in _number_fields(model)]


def test_the_form_options_walk_finds_the_options_a_form_sets():
    found = {(kind, model.__name__, name) for kind, model, name in FORM_OPTIONS}
    assert {("tube", "TubeOptions", "tolerance"), ("tube", "InspectionTolerances", "end_point"),
            ("tube", "XyzClrPoint", "x"), ("alignment", "AlignmentOptions", "position_tolerance"),
            ("flowmeter", "FlowmeterOptions", "tolerance"), ("perfmap", "PerfmapOptions", "surge_margin"),
            ("polyhedra", "PolyhedraOptions", "planarity_tolerance"),
            ("rigidity", "RigidityOptions", "contact_tolerance"), ("dedup", "DedupOptions", "tolerance")} <= found


def _errors_at(model: type[BaseModel], data: dict, name: str, json_body: bool = False) -> list[dict]:
    try:
        if json_body:  # as intake.read_json validates a JSON body
            model.model_validate_json(json.dumps(data), strict=True)
        else:
            model.model_validate(data)
    except ValidationError as error:  # other fields' errors (a missing required one) are not asked
        return [e for e in error.errors() if e["loc"][:1] == (name,)]
    return []


@pytest.mark.parametrize(("kind", "model", "name"), FORM_OPTIONS,
                         ids=[f"{k}-{m.__name__}.{n}" for k, m, n in FORM_OPTIONS])
def test_an_option_typed_as_text_in_a_form_is_still_that_number_and_true_is_refused(kind, model, name):
    """A form's options are parsed JSON validated in Python's mode: "6" is the 6 it was on main (its bounds may still
    refuse it, naming the option), true is no number; a JSON body is held to its schema: "6" is a string there."""
    field = model.model_fields[name]
    typed = next(text for text in ("6", "0.5", "1e-4", "2e-9") if _within(field, float(text)))
    assert _errors_at(model, {name: typed}, name) == [], (kind, name, typed)
    validated = model.model_validate({**_required(model), name: typed})
    assert getattr(validated, name) == float(typed)
    for value in (True, False):
        (error,) = _errors_at(model, {name: value}, name)
        assert error["type"] == "float_type", error
    (error,) = _errors_at(model, {name: "6_0"}, name)
    assert error["type"] == "float_parsing"
    assert [e["type"] for e in _errors_at(model, {name: typed}, name, json_body=True)] == ["float_type"]


def _required(model: type[BaseModel]) -> dict:
    """A value for each required field of ``model`` (a dock's part, a nominal row's length, a point's x, y, z)."""
    return {name: 1.0 if _one_number(field.annotation) else "3001"
            for name, field in model.model_fields.items() if field.is_required()}


@pytest.mark.parametrize(("name", "path"), [(n, p) for n, p in NUMBERS if p[0] == "options"])
def test_true_in_a_forms_options_is_refused_naming_the_option_and_text_is_read(name, path):
    """The multipart ``options`` field laid over an uploaded .json file: true refused naming the option; "0.001"
    read as the number (as on main)."""
    body = BODIES[name]()
    errors = _upload_refusal(name, body, {path[1]: True})
    assert len(errors) == 1 and errors[0]["loc"][-1] == path[1] and errors[0]["type"] == "float_type", errors
    body.get("options", {}).pop(path[1], None)  # a file's own value differing from the form's is refused naming both
    request = _spec(name).parse_upload(StoredInput.from_bytes("request.json", json.dumps(body).encode()),
                                       {path[1]: "0.001"})
    assert request.options.model_dump()[path[1]] == 0.001


def test_the_api_answers_a_problem_document_naming_the_path(client):
    """Through HTTP: an uploaded flowmeter file's radius true (main: refused for a liner 300 radii long, the radius
    read as 1), a tube form's tolerance true, and a perfmap query's flow true (main: answered, 'infeasible at flow
    1'). The query's body is validated before its job is looked up: no job is needed to see it refused. Some 10 s:
    the app, and the upload readers' forkserver the first upload starts (the path under test)."""
    meter = with_value(BODIES["flowmeter"](), ("pipe", "radius"), True)
    response = client.post("/v1/flowmeter/jobs", files={"file": ("meter.json", json.dumps(meter).encode())})
    assert response.status_code == 422 and response.headers["content-type"] == PROBLEM
    assert [e["pointer"] for e in response.json()["errors"]] == ["/file/pipe/radius"]

    scan = (REPO / "examples/tube/scan.xyz").read_bytes()
    response = client.post("/v1/tube/jobs", files={"file": ("scan.xyz", scan)}, data={"options": '{"tolerance": true}'})
    assert response.status_code == 422 and response.headers["content-type"] == PROBLEM
    assert [e["loc"] for e in response.json()["errors"]] == [["options", "tolerance"]]

    for query, pointer in (({"points": [{"flow": True, "pressure": 1.2}]}, "/points/0/flow"),
                           ({"flow": 2000, "pressure": False}, "/pressure")):
        response = client.post(f"/v1/perfmap/jobs/{uuid.uuid4()}/query", json=query)
        assert response.status_code == 422 and response.headers["content-type"] == PROBLEM, response.text
        assert [e["pointer"] for e in response.json()["errors"]] == [pointer]


def test_a_parsed_upload_still_validates_its_own_numbers():
    """The readers build requests from files (a perfmap CSV's floats, a tube scan's counts): those stay valid under
    the strict types (a reader that put a string or a numpy bool in a number would now be refused here)."""
    csv = KINDS["perfmap"].parse_upload(StoredInput.from_path(REPO / "examples/perfmap/n3_fan_map.csv"), None)
    assert csv.positions and all(type(v) is float for p in csv.positions for v in p.flow)
    scan = KINDS["tube"].parse_upload(StoredInput.from_path(REPO / "examples/tube/scan.xyz"), {"tolerance": "0.5"})
    assert scan.options.tolerance == 0.5 and scan.source.points > 100
    with pytest.raises(InputRejected):
        KINDS["tube"].parse_upload(StoredInput.from_path(REPO / "examples/tube/scan.xyz"), {"tolerance": "0_5"})
