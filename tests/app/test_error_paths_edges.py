"""The edges of naming a 422 by the user's path: a body missing or not an object is named ``body``, as FastAPI
names it (the path's walk left an empty location and a detail of ``(body)``), and a location no document has
(a negative index into a fixed tuple, a step that is no name or number) is passed on as it is, never a 500."""

from __future__ import annotations

import uuid

import pytest
from fastapi.testclient import TestClient
from pydantic import BaseModel

from plantsolve.app.main import create_app
from plantsolve.jobs.errors import user_path
from tests.conftest import service_settings


@pytest.fixture
def client(tmp_path):
    with TestClient(create_app(service_settings(tmp_path), run_jobs=False)) as test_client:
        yield test_client


@pytest.mark.parametrize("content", [None, '"str"', "1", "[]"])
def test_a_body_missing_or_not_an_object_is_named_body(client, content):
    response = client.post(f"/v1/perfmap/jobs/{uuid.uuid4()}/beta", content=content,
                           headers={"Content-Type": "application/json"})
    assert response.status_code == 422, response.text
    error = response.json()["errors"][0]
    assert error["loc"] == ["body"], error


class _Pair(BaseModel):
    pair: tuple[int, int]
    tagged: dict[str, int]


@pytest.mark.parametrize("loc", [("pair", -5), ("pair", 7), ("pair", ["x"]), ("tagged", {"k": 1}), (None, "pair"),
                                 ("pair", 1.5)])
def test_a_location_no_document_has_is_passed_on_as_it_is(loc):
    assert user_path(loc, _Pair) == list(loc)
