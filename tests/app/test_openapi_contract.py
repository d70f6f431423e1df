"""The OpenAPI document is a typed contract: explicit operationIds, each kind's result schema,
an example on every request body, every error declared as a problem document; and a client
generated from it (openapi-python-client) imports and talks to the app."""

from __future__ import annotations

import importlib
import io
import os
import re
import shutil
import subprocess
import sys
import uuid
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import update

from plantsolve.app.main import create_app
from plantsolve.jobs.runner import run_job
from plantsolve.schemas.tube import EndPointCheck, InspectionRow, LengthCheck
from plantsolve.solvers.kinds import KINDS
from plantsolve.store.models import Job as JobRow
from tests.conftest import service_settings, wait_for

METHODS = {"get", "post", "put", "patch", "delete", "head"}


@pytest.fixture(scope="module")
def spec(tmp_path_factory):
    app = create_app(service_settings(tmp_path_factory.mktemp("spec")), run_jobs=False)
    return app.openapi()


def _operations(spec):
    for path, item in spec["paths"].items():
        for method, operation in item.items():
            if method in METHODS:
                yield path, method, operation


def test_operation_ids_are_explicit_and_unique(spec):
    ids = [operation["operationId"] for _, _, operation in _operations(spec)]
    assert len(ids) == len(set(ids))
    # FastAPI's generated ids look like submit_tube_job_v1_tube_jobs_post
    assert all(re.fullmatch(r"[a-z][A-Za-z0-9]*", op_id) for op_id in ids), ids
    assert {"getJob", "listJobs", "cancelJob", "getJobResult", "getJobArtifact", "getJobInput", "streamJobEvents",
            "streamJobListEvents", "getHealth", "getReadiness", "queryPerfmapJob"} <= set(ids)
    for kind in ("alignment", "tube", "perfmap", "polyhedra", "flowmeter"):
        assert f"submit{kind.capitalize()}Job" in ids and f"get{kind.capitalize()}JobResult" in ids
    assert "submitTestComputeJob" in ids  # a kind with a hyphen


@pytest.fixture(scope="module")
def shipped(tmp_path_factory):
    """The document of the shipped kinds only (no test plugins)."""
    app = create_app(service_settings(tmp_path_factory.mktemp("shipped"), plugins=[]), run_jobs=False)
    return app.openapi()


def test_each_kind_has_its_result_schema(spec):
    schemas = spec["components"]["schemas"]
    generic = spec["paths"]["/v1/jobs/{job_id}/result"]["get"]["responses"]["200"]["content"]["application/json"]["schema"]
    # the test plugins' results carry no 'kind': nothing tells them apart, so a plain anyOf
    refs = {entry["$ref"].rsplit("/", 1)[-1] for entry in generic["anyOf"]}
    for kind, kind_spec in KINDS.items():
        name = kind_spec.result_model.__name__
        assert name in refs and schemas[name]["properties"], kind
        typed = spec["paths"][f"/v1/{kind}/jobs/{{job_id}}/result"]["get"]["responses"]["200"]["content"]
        assert typed["application/json"]["schema"] == {"$ref": f"#/components/schemas/{name}"}
        # the result's own parts are typed too, not {}
        assert schemas[name]["properties"]["report"] == {"$ref": "#/components/schemas/Report"}


def test_results_are_told_apart_by_their_kind(shipped):
    """getJobResult is a oneOf with a discriminator on 'kind', which every result carries (required, one value)."""
    answer = shipped["paths"]["/v1/jobs/{job_id}/result"]["get"]["responses"]["200"]
    generic = answer["content"]["application/json"]["schema"]
    mapping = {kind: f"#/components/schemas/{kind_spec.result_model.__name__}" for kind, kind_spec in KINDS.items()}
    assert generic["discriminator"] == {"propertyName": "kind", "mapping": mapping}
    assert sorted(entry["$ref"] for entry in generic["oneOf"]) == sorted(mapping.values())
    for kind, kind_spec in KINDS.items():
        result = shipped["components"]["schemas"][kind_spec.result_model.__name__]
        assert result["properties"]["kind"]["const"] == kind and "kind" in result["required"], kind


def test_a_stored_result_validates_and_is_served_with_its_kind(tmp_path):
    """A result stored before results carried 'kind' still validates (the default) and is served with it."""
    app = create_app(service_settings(tmp_path, plugins=[]), run_jobs=False)
    with TestClient(app) as client:
        job_id = uuid.UUID(client.post("/v1/polyhedra/jobs", json=KINDS["polyhedra"].example()).json()["id"])
        assert run_job(app.state.ctx, job_id, worker="test", requeue=lambda *_: None) == "succeeded"
        fresh = client.get(f"/v1/jobs/{job_id}/result").json()
        assert fresh["kind"] == "polyhedra"
        old = {k: v for k, v in fresh.items() if k != "kind"}
        assert KINDS["polyhedra"].result_model.model_validate(old).kind == "polyhedra"
        with app.state.ctx.db.engine.begin() as connection:  # the row as written before the field existed
            connection.execute(update(JobRow).where(JobRow.id == job_id).values(result=old))
        assert "kind" not in app.state.jobs.result(job_id)
        assert client.get(f"/v1/jobs/{job_id}/result").json() == fresh
        assert client.get(f"/v1/polyhedra/jobs/{job_id}/result").json() == fresh


def test_multipart_options_are_typed_with_the_kinds_options(shipped):
    """The upload's 'options' part is the kind's options object, sent as JSON: not a string."""
    schemas = shipped["components"]["schemas"]
    for kind, kind_spec in KINDS.items():
        if not kind_spec.upload_extensions:
            continue
        multipart = shipped["paths"][f"/v1/{kind}/jobs"]["post"]["requestBody"]["content"]["multipart/form-data"]
        assert multipart["encoding"] == {"options": {"contentType": "application/json"}}
        options = multipart["schema"]["properties"]["options"]
        name = options["$ref"].rsplit("/", 1)[-1]
        own = kind_spec.request_model.model_fields["options"].annotation.model_json_schema()["properties"]
        assert set(own) <= set(schemas[name]["properties"]), kind  # every option, typed as in the request
        for field, definition in own.items():
            if "$ref" not in definition and "anyOf" not in definition:
                assert schemas[name]["properties"][field] == definition, (kind, field)
        assert multipart["schema"]["properties"]["file"] == {**multipart["schema"]["properties"]["file"],
                                                              "type": "string", "format": "binary"}


def test_summaries_use_the_right_article(shipped):
    summaries = {operation["operationId"]: operation["summary"] for _, _, operation in _operations(shipped)}
    assert summaries["submitAlignmentJob"] == "Submit an alignment job"
    assert summaries["submitTubeJob"] == "Submit a tube job"
    assert not [s for s in summaries.values() if re.search(r"\ba [aeiou]", s)], summaries


def test_every_request_body_has_a_valid_example(tmp_path):
    app = create_app(service_settings(tmp_path, plugins=[]), run_jobs=False)  # the shipped kinds only
    spec = app.openapi()
    bodies = [(path, operation) for path, method, operation in _operations(spec) if "requestBody" in operation]
    assert len(bodies) >= len(KINDS) + 1
    for path, operation in bodies:
        assert operation["requestBody"]["content"]["application/json"].get("example"), path
    for kind, kind_spec in KINDS.items():
        request_schema = spec["components"]["schemas"][kind_spec.request_model.__name__]
        assert request_schema["examples"] == [kind_spec.example()]
    # the examples are accepted as they stand
    with TestClient(app) as client:
        for path, operation in bodies:
            if path.endswith("/jobs"):
                response = client.post(path, json=operation["requestBody"]["content"]["application/json"]["example"])
                assert response.status_code == 202, (path, response.text)


def test_every_error_is_declared_as_a_problem_document(spec):
    for path, method, operation in _operations(spec):
        codes = set(operation["responses"])
        assert "500" in codes, path
        if path.startswith("/v1/"):
            assert {"401", "422"} <= codes, path
        if "{job_id}" in path:
            assert "404" in codes, path
        if method == "post":
            assert "413" in codes, path
        for code, response in operation["responses"].items():
            if code.startswith(("4", "5")) and path != "/readyz":
                assert response["content"]["application/problem+json"]["schema"] == {"$ref": "#/components/schemas/Problem"}


def test_per_kind_result_route_matches_the_generic_one(client):
    job = wait_for(client, client.post("/v1/test-compute/jobs", json={"values": [3.0, 4.0]}).json()["id"])
    typed = client.get(f"/v1/test-compute/jobs/{job['id']}/result")
    assert typed.status_code == 200 and typed.json() == client.get(f"/v1/jobs/{job['id']}/result").json()
    assert typed.json()["norm"] == 5.0
    other = client.get(f"/v1/test-fail/jobs/{job['id']}/result")
    assert other.status_code == 404 and "test-compute" in other.json()["detail"]


def test_a_generated_client_imports_and_calls_the_app(tmp_path):
    """openapi-python-client turns the document into a typed package; its models parse the app's answers."""
    app = create_app(service_settings(tmp_path / "data", plugins=[]), run_jobs=False)
    (tmp_path / "openapi.json").write_text(__import__("json").dumps(app.openapi()))
    binary = Path(sys.executable).parent / "openapi-python-client"
    from ruff.__main__ import find_ruff_bin  # the test extra's ruff: the generator formats its output with it

    ruff = Path(find_ruff_bin()).parent
    env = {**os.environ, "PATH": f"{ruff}{os.pathsep}{binary.parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    package = tmp_path / "plantsolve_generated"
    run = subprocess.run([str(binary), "generate", "--path", str(tmp_path / "openapi.json"), "--meta", "none",
                          "--output-path", str(package)], capture_output=True, text=True, env=env, timeout=300)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "Warning" not in run.stdout + run.stderr, run.stdout + run.stderr  # no endpoint or model left out
    assert "ruff" not in run.stdout + run.stderr, run.stdout + run.stderr  # formatted, not skipped
    sys.path.insert(0, str(tmp_path))
    try:
        generated = importlib.import_module("plantsolve_generated")
        models = importlib.import_module("plantsolve_generated.models")
        submit = importlib.import_module("plantsolve_generated.api.polyhedra.submit_polyhedra_job")
        get_job = importlib.import_module("plantsolve_generated.api.jobs.get_job")
        typed_result = importlib.import_module("plantsolve_generated.api.polyhedra.get_polyhedra_job_result")
        any_result = importlib.import_module("plantsolve_generated.api.jobs.get_job_result")
        File = importlib.import_module("plantsolve_generated.types").File
        for kind_spec in KINDS.values():
            assert hasattr(models, kind_spec.result_model.__name__) and hasattr(models, kind_spec.request_model.__name__)
        with TestClient(app) as http:
            client = generated.Client(base_url="http://testserver")
            client.set_httpx_client(http)
            body = models.PolyhedraRequest.from_dict(KINDS["polyhedra"].example())
            job = submit.sync(client=client, body=body)
            assert isinstance(job, models.JobView) and job.kind == "polyhedra" and job.status.value == "queued"
            assert get_job.sync(job.id, client=client).id == job.id
            not_ready = typed_result.sync(job.id, client=client)  # no job runs here: 409 as a Problem
            assert isinstance(not_ready, models.Problem) and not_ready.status == 409
            # a file upload with typed options, sent as a JSON part; the result comes back as its kind's model
            cube = "\n".join(["v 0 0 0", "v 2 0 0", "v 2 2 0", "v 0 2 0", "v 0 0 2", "v 2 0 2", "v 2 2 2", "v 0 2 2",
                               "f 1 4 3 2", "f 5 6 7 8", "f 1 2 6 5", "f 2 3 7 6", "f 3 4 8 7", "f 4 1 5 8"]).encode()
            options = models.PolyhedraUploadOptions(merge_tolerance=0.001)
            upload = models.SubmitPolyhedraJobFilesBody(file=File(payload=io.BytesIO(cube), file_name="cube.obj"),
                                                        options=options)
            uploaded = submit.sync(client=client, body=upload)
            assert isinstance(uploaded, models.JobView), uploaded
            assert http.get(f"/v1/jobs/{uploaded.id}/input").json()["options"]["merge_tolerance"] == 0.001
            assert run_job(app.state.ctx, uploaded.id, worker="test", requeue=lambda *_: None) == "succeeded"
            result = any_result.sync(uploaded.id, client=client)
            assert isinstance(result, models.PolyhedraResult) and result.kind == "polyhedra"
            assert result.zones[0].volume == pytest.approx(8.0)  # a 2 x 2 x 2 cube
        # a tube inspection's row and end point the samples do not determine: ok null, read and written as null
        # by the generated models (not dropped, not read as a pass)
        undetermined = LengthCheck(nominal=70.0, measured=30.2, deviation=-39.8, tolerance=1.0, ok=None,
                                   determined=False, sigma=0.4, bound="lower")
        row = InspectionRow(row=4, length=undetermined, undetermined=["length"], ok=None).model_dump(mode="json")
        end = EndPointCheck(end="end", deviation=0.3, tolerance=2.0, ok=None, determined=False).model_dump(mode="json")
        parsed_row, parsed_end = models.InspectionRow.from_dict(row), models.EndPointCheck.from_dict(end)
        assert parsed_row.ok is None and parsed_row.length.ok is None and parsed_end.ok is None
        assert parsed_row.to_dict()["ok"] is None and parsed_end.to_dict()["ok"] is None
        for model in (models.InspectionRow, models.LengthCheck, models.AngleCheck, models.EndPointCheck):
            hint = str(model.__annotations__["ok"])  # a string: the generated modules postpone annotations
            assert "None" in hint and "bool" in hint, (model, hint)
    finally:
        sys.path.remove(str(tmp_path))
        for name in [n for n in sys.modules if n.startswith("plantsolve_generated")]:
            del sys.modules[name]
        shutil.rmtree(package, ignore_errors=True)
