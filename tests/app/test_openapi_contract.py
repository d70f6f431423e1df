"""The OpenAPI document is a typed contract: explicit operationIds, each kind's result schema,
an example on every request body, every error declared as a problem document; and a client
generated from it (openapi-python-client) imports and talks to the app."""

from __future__ import annotations

import importlib
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from plantsolve.solvers.kinds import KINDS
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


def test_each_kind_has_its_result_schema(spec):
    schemas = spec["components"]["schemas"]
    generic = spec["paths"]["/v1/jobs/{job_id}/result"]["get"]["responses"]["200"]["content"]["application/json"]["schema"]
    refs = {entry["$ref"].rsplit("/", 1)[-1] for entry in generic["anyOf"]}
    for kind, kind_spec in KINDS.items():
        name = kind_spec.result_model.__name__
        assert name in refs and schemas[name]["properties"], kind
        typed = spec["paths"][f"/v1/{kind}/jobs/{{job_id}}/result"]["get"]["responses"]["200"]["content"]
        assert typed["application/json"]["schema"] == {"$ref": f"#/components/schemas/{name}"}
        # the result's own parts are typed too, not {}
        assert schemas[name]["properties"]["report"] == {"$ref": "#/components/schemas/Report"}


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
    env = {**os.environ, "PATH": f"{binary.parent}{os.pathsep}{os.environ.get('PATH', '')}"}  # its ruff hook
    package = tmp_path / "plantsolve_generated"
    run = subprocess.run([str(binary), "generate", "--path", str(tmp_path / "openapi.json"), "--meta", "none",
                          "--output-path", str(package)], capture_output=True, text=True, env=env, timeout=300)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "Warning" not in run.stdout + run.stderr, run.stdout + run.stderr  # no endpoint or model left out
    sys.path.insert(0, str(tmp_path))
    try:
        generated = importlib.import_module("plantsolve_generated")
        models = importlib.import_module("plantsolve_generated.models")
        submit = importlib.import_module("plantsolve_generated.api.polyhedra.submit_polyhedra_job")
        get_job = importlib.import_module("plantsolve_generated.api.jobs.get_job")
        typed_result = importlib.import_module("plantsolve_generated.api.polyhedra.get_polyhedra_job_result")
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
    finally:
        sys.path.remove(str(tmp_path))
        for name in [n for n in sys.modules if n.startswith("plantsolve_generated")]:
            del sys.modules[name]
        shutil.rmtree(package, ignore_errors=True)
