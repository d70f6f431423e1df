"""A bounded property-based run of the whole OpenAPI document (schemathesis), every check on.

Each operation is fed schema-valid and schema-invalid requests; the service must never answer
5xx, must answer only documented status codes, content types and headers, must refuse what the
schema refuses and accept what the schema allows. Where validity depends on what the schema
cannot state, the check that needs it is left out for those cases only, each for its reason:

- an uploaded file's content: random bytes are never a valid PCF, CSV or scan, whatever the name;
- an opaque pagination cursor: only cursors this API returned are valid;
- the stream of every job's changes (``GET /v1/jobs/events``) never ends by design, so no call to it can
  complete: it is left out here and tested in ``tests/app/test_events.py`` (its answers and its 422s);
- a JSON request that breaks a rule across fields or a reference (a position needs as many
  setting values as there are setting names, a fixed component must exist, a nominal LRA ends
  on a straight): such a request may be refused, but only with a 422 whose every error is of
  type ``value_error`` (a rule of the solver). An error the schema could have stated (a wrong
  type, a missing or unknown field, a bound) on schema-valid input fails the test.
"""

from __future__ import annotations

import os
import tempfile
import uuid
from pathlib import Path

import pytest
import schemathesis
from hypothesis import HealthCheck
from hypothesis import settings as hypothesis_settings
from schemathesis.checks import positive_data_acceptance

from plantsolve.app.main import create_app
from tests.conftest import service_settings

pytestmark = pytest.mark.slow



def _stored_only_app():
    # jobs are stored, never run: the run checks the HTTP contract, not the solvers
    app = create_app(service_settings(Path(tempfile.mkdtemp(prefix="plantsolve-schemathesis-"))), run_jobs=False)
    app.state.ctx.db.migrate()
    return app


schema = schemathesis.openapi.from_asgi("/openapi.json", _stored_only_app()).exclude(operation_id="streamJobListEvents")


@schema.parametrize()
@hypothesis_settings(max_examples=int(os.environ.get("SCHEMATHESIS_EXAMPLES", "25")), deadline=None, derandomize=True,
                     suppress_health_check=list(HealthCheck))
def test_the_openapi_contract_holds(case):
    excluded = []
    if case.media_type == "multipart/form-data":
        excluded.append(positive_data_acceptance)
    if (case.query or {}).get("cursor") is not None:
        excluded.append(positive_data_acceptance)
    if case.headers and "Idempotency-Key" in case.headers:
        # a key reused with another body is a 422 by design: each generated case gets its own key
        case.headers["Idempotency-Key"] = f"st-{uuid.uuid4()}"
    json_submit = case.method == "POST" and case.media_type == "application/json" and case.path.endswith("/jobs")
    if json_submit:
        excluded.append(positive_data_acceptance)
    response = case.call()
    case.validate_response(response, excluded_checks=excluded)
    if json_submit and case.meta is not None and case.meta.generation.mode.is_positive and response.status_code == 422:
        kinds = {error["type"] for error in response.json()["errors"]}
        assert kinds <= {"value_error"}, (
            f"schema-valid input refused for a reason the schema could state: {response.text[:600]}")
