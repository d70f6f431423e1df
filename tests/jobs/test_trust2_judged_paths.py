"""A stored input that no longer validates (the schema changed under a queued job), or that a worker's reader
refuses, fails the job with a report naming each bad field by the path the user wrote, as the submission's 422
would: pydantic's tags for the member of a union (``points.list.0.0``) were reported as they are."""

from __future__ import annotations

import json
import uuid
from pathlib import Path

import pytest
from pydantic import ValidationError

from plantsolve.jobs.attempts import judge
from plantsolve.schemas.perfmap import PerfmapRequest
from plantsolve.schemas.tube import TubeRequest
from plantsolve.solvers.base import InputRejected, validated

SCAN = json.loads((Path(__file__).resolve().parents[2] / "examples" / "tube" / "scan_request.json").read_text())


def _judged(error: Exception, model):
    return judge(error, job_id=uuid.uuid4(), attempt=1, max_attempts=3, limits=(1.0, 2.0), elapsed=0.1, model=model)


def _scan_with(index: int, value) -> dict:
    points = [list(p) for p in SCAN["points"]]
    points[index] = value
    return {**SCAN, "points": points}


@pytest.mark.parametrize(("value", "loc", "type_"), [(["x", 0.0, 0.0], ["points", 2, 0], "float_type"),
                                                     ([1.0, 2.0], ["points", 2], "too_short")])
def test_a_stored_input_that_no_longer_validates_is_reported_at_the_users_paths(value, loc, type_):
    with pytest.raises(ValidationError) as refused:
        TubeRequest.model_validate(_scan_with(2, value))
    assert any("list" in e["loc"] for e in refused.value.errors())  # pydantic's own: with the union's tag
    verdict = _judged(refused.value, TubeRequest)
    assert verdict.outcome == "failed" and not verdict.retry
    assert [(e["loc"], e["type"]) for e in verdict.report["details"]["errors"]] == [(loc, type_)]


def test_a_workers_reader_refusal_is_reported_at_the_users_paths():
    with pytest.raises(InputRejected) as refused:
        validated(TubeRequest, _scan_with(4, [1.0, 2.0]))  # as a reader validates an uploaded .json file
    assert refused.value.errors[0].loc == ("file", "points", "list", 4)
    verdict = _judged(refused.value, TubeRequest)
    assert [e["loc"] for e in verdict.report["details"]["errors"]] == [["file", "points", 4]]


def test_another_models_error_keeps_its_own_paths():
    """A result that fails its model is no input: its paths are not the request's."""
    with pytest.raises(ValidationError) as refused:
        TubeRequest.model_validate(_scan_with(2, [1.0, 2.0]))
    verdict = _judged(refused.value, PerfmapRequest)
    assert [e["loc"] for e in verdict.report["details"]["errors"]] == [["points", "list", 2]]
