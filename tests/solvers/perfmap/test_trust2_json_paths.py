"""A bad value in an uploaded perfmap .json file is named by its path in the file (``file.options.map``,
``file.positions.3.flow.2``), as every other kind's .json upload names it; it was named ``file`` alone, with the
path only in the message. A value the upload form gave is named as the form names it (``options.map``)."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from tests.conftest import service_settings
from tests.support.documents import with_value

EXAMPLE = json.loads((Path(__file__).resolve().parents[3] / "examples" / "perfmap" / "n3_fan_map.json").read_text())


@pytest.fixture(scope="module")
def client():
    with tempfile.TemporaryDirectory() as folder:
        with TestClient(create_app(service_settings(Path(folder)), run_jobs=False)) as test_client:
            yield test_client


def _refused(client, document, options: dict | None = None) -> list[dict]:
    response = client.post("/v1/perfmap/jobs", files={"file": ("map.json", json.dumps(document).encode())},
                           data={"options": json.dumps(options)} if options is not None else None)
    assert response.status_code == 422, response.text
    return response.json()["errors"]


# (a place in the request, a bad value there, pydantic's error type)
BAD = [
    (("options", "map"), 1, "bool_type"),
    (("positions", 3, "flow", 2), "x", "float_type"),
    (("positions", 0, "theta"), [1.0], "float_type"),
    (("units", "flow"), 5, "string_type"),
    (("setting_units", 1), 3, "string_type"),
    (("options", "result_units", "flow"), 5, "string_type"),
]


@pytest.mark.parametrize(("path", "value", "type_"), BAD)
def test_a_bad_value_in_the_file_is_named_by_its_path_in_the_file(client, path, value, type_):
    errors = _refused(client, with_value(EXAMPLE, path, value))
    assert [(e["loc"], e["type"]) for e in errors] == [(["file", *path], type_)], errors
    assert errors[0]["pointer"] == "/file/" + "/".join(map(str, path))
    assert "/".join(map(str, path)) not in errors[0]["msg"]  # the place is the loc's, not repeated in the words


@pytest.mark.parametrize(("path", "value", "type_"), BAD)
def test_the_file_names_the_place_a_json_body_names(client, path, value, type_):
    document = with_value(EXAMPLE, path, value)
    body = client.post("/v1/perfmap/jobs", json=document)
    assert body.status_code == 422
    assert [["file", *e["loc"]] for e in body.json()["errors"]] == [e["loc"] for e in _refused(client, document)]


def test_a_bare_list_of_positions_is_named_without_the_requests_field(client):
    """A list of positions saved on its own: the user's path starts at the list."""
    positions = with_value(EXAMPLE["positions"], (3, "flow", 2), "x")
    assert [e["loc"] for e in _refused(client, positions)] == [["file", 3, "flow", 2]]


def test_a_bad_form_option_is_named_as_the_form_names_it_and_the_files_own_by_the_file(client):
    document = with_value(EXAMPLE, ("options", "result_units"), {"flow": 5})
    errors = _refused(client, document, {"map": 1})
    assert sorted(e["loc"] for e in errors) == [["file", "options", "result_units", "flow"], ["options", "map"]]


def test_a_files_options_that_are_no_object_under_form_options_are_named(client):
    """Laid under the form's options, a list failed as an unreadable file ('malformed', no place named)."""
    errors = _refused(client, {**EXAMPLE, "options": [1]}, {"map": False})
    assert [(e["loc"], e["msg"]) for e in errors] == [(["file", "options"], "options must be an object")]


NCP01 = (Path(__file__).parent / "data" / "pycycle" / "ncp01.py").read_text()


@pytest.mark.parametrize("word", ["1e9999x", "1.2.3", "None", '"1.3114"', "-x"])
def test_a_pycycle_maps_word_that_is_no_number_is_named_by_its_line(word):
    """It was named by the array alone ('file.PRmap: not a numeric array literal'), in a table of hundreds of
    numbers."""
    from plantsolve.solvers.base import InputRejected, StoredInput
    from plantsolve.solvers.perfmap.upload import parse_upload

    lines = NCP01.split("\n")
    assert "1.3114" in lines[71] and "PRmap" in "".join(lines[60:71])
    lines[71] = lines[71].replace("1.3114", word, 1)
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("ncp01.py", "\n".join(lines).encode()), None)
    (error,) = refused.value.errors
    assert error.loc == ("file", "line", 72) and error.msg.startswith(f"PRmap, line 72: {word!r} is not a number")


def test_finding_the_first_word_that_is_no_number_is_linear_in_the_cells(monkeypatch):
    """Each bad cell was checked against every other for being inside it: 4,000 'nan' cells outran the reader's 8
    CPU seconds, so the user got a time-out instead of the line. The walk now goes down through brackets only."""
    import ast

    from plantsolve.solvers.perfmap import upload

    visited = []
    real_walk = ast.walk

    def counted_walk(node):
        for inner in real_walk(node):
            visited.append(inner)
            yield inner

    monkeypatch.setattr(upload.ast, "walk", counted_walk)
    cells = 4000
    literal = "[[" + ", ".join(["nan"] * cells) + "],\n [f(x), 1.0]]"
    assert upload._not_a_number(literal) == (1, "nan")
    assert len(visited) <= 10 * cells
