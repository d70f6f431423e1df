"""A JSON body written for another kind, posted to this kind's route, is one 422 naming the kind it was written for."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from plantsolve.jobs import intake
from plantsolve.jobs.errors import Unprocessable
from plantsolve.solvers.kinds import KINDS


@pytest.mark.parametrize("written_for, posted_to", [("tube", "polyhedra"), ("flowmeter", "alignment"),
                                                    ("perfmap", "tube"), ("alignment", "rigidity")])
def test_another_kinds_example_is_refused_naming_its_kind(written_for, posted_to):
    body = json.dumps(KINDS[written_for].example()).encode()
    with pytest.raises(Unprocessable) as refused:
        intake.read_json(KINDS[posted_to], body)
    (error,) = refused.value.errors
    assert error["type"] == "wrong_kind" and error["loc"] == []
    assert f"{written_for} request" in error["msg"] and f"not a {posted_to} request" in error["msg"]


def test_a_request_of_the_right_kind_with_one_stray_field_still_names_the_field():
    body = KINDS["flowmeter"].example() | {"colour": "red"}
    with pytest.raises(Unprocessable) as refused:
        intake.read_json(KINDS["flowmeter"], json.dumps(body).encode())
    assert [e["loc"] for e in refused.value.errors] == [["colour"]]


@pytest.mark.parametrize("example, path", [("query.json", "query"), ("beta_query.json", "beta")])
@pytest.mark.parametrize("posted_to", ["perfmap", "tube"])
def test_a_perfmap_question_posted_as_a_job_is_refused_naming_where_it_goes(example, path, posted_to):
    """A map's duty points are what a finished perfmap job answers: posted as a new job they were called a tube
    request (their key 'points' is a tube request's field)."""
    body = (Path(__file__).parents[2] / "examples" / "perfmap" / example).read_bytes()
    with pytest.raises(Unprocessable) as refused:
        intake.read_json(KINDS[posted_to], body)
    (error,) = refused.value.errors
    assert error["type"] == "wrong_kind" and "tube request" not in error["msg"].split("not a")[0]
    assert f"POST it to /v1/perfmap/jobs/<job id>/{path}" in error["msg"]
