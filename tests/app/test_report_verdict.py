"""A result with a verdict against it says so in the API itself: the job view's and the result's
``report.verdict`` (and the webhook's body, which is the job view), not only the dashboard or the CLI."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from plantsolve.schemas.common import VERDICT_CODES, Diagnostic, Report
from tests.conftest import service_settings, wait_for


@pytest.fixture
def client(tmp_path):
    settings = service_settings(tmp_path, plugins=["tests.support.kinds", "tests.cli.verdict_kind"])
    with TestClient(create_app(settings)) as test_client:
        yield test_client


def _finished(client, codes: list[str]) -> dict:
    submitted = client.post("/v1/test-verdict/jobs", json={"codes": codes})
    assert submitted.status_code == 202, submitted.text
    return wait_for(client, submitted.json()["id"])


def test_the_job_view_and_the_result_state_the_verdict(client):
    view = _finished(client, ["scan_gap", "inspection_failed", "not_converged"])
    assert view["status"] == "succeeded"
    assert view["report"]["verdict"] == {"label": "FAIL", "code": "inspection_failed",
                                         "message": "the inspection_failed sentence"}
    assert "FAIL" in view["summary"] and "inspection_failed" in view["summary"]
    result = client.get(view["links"]["result"]).json()
    assert result["report"]["verdict"]["code"] == "inspection_failed"

    caveat = _finished(client, ["scan_gap"])
    assert caveat["report"]["verdict"] is None and caveat["summary"] == "judged"


def test_the_openapi_document_states_the_verdict():
    schema = Report.model_json_schema(mode="serialization")
    assert "verdict" in schema["properties"] and "verdict" in schema.get("required", ["verdict"])


@pytest.mark.parametrize("code", sorted(VERDICT_CODES))
def test_every_verdict_code_is_a_verdict_and_a_failure_has_none(code):
    warnings = [Diagnostic(code="rotation_rounded", message="a caveat"), Diagnostic(code=code, message="no")]
    assert Report(status="warning", warnings=warnings).verdict.label == VERDICT_CODES[code]
    assert Report(status="failed", warnings=warnings).verdict is None
    assert Report(status="warning", warnings=warnings[:1]).verdict is None
