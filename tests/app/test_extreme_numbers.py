"""Extreme numbers posted to every submit route — the lean path and the routed one, the JSON body and a
multipart ``options`` field — are answered, never a 500: an integer longer than Python converts from text
(more than 4,300 digits) is a 422 naming its field; other extremes are a 422 or an accepted job."""

from __future__ import annotations

import json
import sys

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from tests.conftest import service_settings
from tests.support.routed import routed_by

LIMIT = sys.get_int_max_str_digits()
TOO_LONG = "9" * (LIMIT + 1)
# written into a JSON document as they are: each a number JSON allows
EXTREMES = ["1" + "0" * (LIMIT - 1), "-" + "9" * LIMIT, "1e400", "-1e400", "4.9e-325", "1" + "0" * 400 + ".5",
            "123456789012345678901234567890", "0." + "0" * 5000 + "1"]


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    settings = service_settings(tmp_path_factory.mktemp("extreme"))
    with routed_by("routed"):  # the routes take ?routed=1, which sends a request past the lean path
        app = create_app(settings, run_jobs=False)
    with TestClient(app, raise_server_exceptions=False) as client:
        yield client


def _kinds(client) -> dict:
    return dict(client.app.state.ctx.kinds)


def _first_number(document, path=()):
    """The path of the first number in a JSON document (depth first), or None."""
    if isinstance(document, bool):
        return None
    if isinstance(document, (int, float)):
        return path
    items = document.items() if isinstance(document, dict) else enumerate(document) \
        if isinstance(document, list) else ()
    for key, value in items:
        found = _first_number(value, (*path, key))
        if found is not None:
            return found
    return None


def _with_number(document, path, literal: str) -> bytes:
    """``document`` as JSON text with the number at ``path`` replaced by the number ``literal`` (as written)."""
    marker = "\u2603marker\u2603"
    copy = json.loads(json.dumps(document))
    node = copy
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = marker
    return json.dumps(copy).replace(json.dumps(marker), literal).encode()


def _pointer(path) -> str:
    return "".join(f"/{step}" for step in path)


def _body_of(spec):
    example = spec.example() if spec.example else None
    document = example if isinstance(example, dict) else {}
    path = _first_number(document)
    if path is None:  # a request without numbers in its example: a number where the schema has none
        document, path = {**document, "extreme": 0}, ("extreme",)
    return document, path


@pytest.mark.parametrize("route", ["/v1/{kind}/jobs", "/v1/{kind}/jobs?routed=1"], ids=["lean", "routed"])
def test_an_integer_too_long_to_read_is_a_422_naming_its_field_on_every_submit_route(client, route):
    for kind, spec in _kinds(client).items():
        document, path = _body_of(spec)
        response = client.post(route.format(kind=kind), content=_with_number(document, path, TOO_LONG),
                               headers={"Content-Type": "application/json"})
        assert response.status_code == 422, (kind, response.status_code, response.text[:300])
        problem = response.json()
        assert [e["pointer"] for e in problem["errors"]] == [_pointer(path)], (kind, problem)
        assert f"{LIMIT + 1} digits" in problem["errors"][0]["msg"]


@pytest.mark.parametrize("route", ["/v1/{kind}/jobs", "/v1/{kind}/jobs?routed=1"], ids=["lean", "routed"])
def test_extreme_numbers_are_never_a_server_error(client, route):
    for kind, spec in _kinds(client).items():
        document, path = _body_of(spec)
        for literal in EXTREMES:
            response = client.post(route.format(kind=kind), content=_with_number(document, path, literal),
                                   headers={"Content-Type": "application/json"})
            assert response.status_code in (200, 202, 422), (kind, literal[:20], response.status_code,
                                                             response.text[:300])
            if response.status_code == 422:
                assert all(e["pointer"].startswith("/") or e["pointer"] == "" for e in response.json()["errors"])


def test_an_integer_too_long_in_the_multipart_options_is_a_422_naming_it(client):
    uploads = {kind: spec for kind, spec in _kinds(client).items() if spec.upload_extensions}
    assert uploads
    for kind, spec in uploads.items():
        for options in (f'{{"scale": {TOO_LONG}}}', f'{{"nested": {{"values": [1, {TOO_LONG}]}}}}'):
            response = client.post(f"/v1/{kind}/jobs", data={"options": options},
                                   files={"file": (f"input{spec.upload_extensions[0]}", b"1\n", "application/octet-stream")})
            assert response.status_code == 422, (kind, response.status_code, response.text[:300])
            pointers = [e["pointer"] for e in response.json()["errors"]]
            assert pointers in (["/options/scale"], ["/options/nested/values/1"]), (kind, pointers)
