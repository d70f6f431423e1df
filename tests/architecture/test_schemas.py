"""The shared schemas: round trips through JSON, finite floats, strict request models."""

from __future__ import annotations

import uuid
from datetime import datetime, timezone

import pytest
from pydantic import ValidationError

from plantsolve.schemas.common import Diagnostic, FiniteFloat, Report, StrictModel, Vec3
from plantsolve.schemas.jobs import ArtifactInfo, JobList, JobProgress, JobTimings, JobView, Problem


def test_job_view_round_trips_through_json():
    now = datetime(2026, 11, 24, 12, 0, tzinfo=timezone.utc)
    view = JobView(
        id=uuid.uuid4(), kind="tube", status="succeeded", attempt=2, max_attempts=3,
        progress=JobProgress(fraction=1.0, message="done"),
        timings=JobTimings(created_at=now, started_at=now, finished_at=now, queued_seconds=0.5, run_seconds=1.25),
        solver_version="1.0.0", summary="Succeeded.",
        report=Report(status="warning", warnings=[Diagnostic(code="c", message="m", details={"x": [1, 2.5]})]),
        artifacts=[ArtifactInfo(name="a.png", media_type="image/png", size=3, sha256="0" * 64, url="/v1/jobs/x/artifacts/a.png")],
        links={"self": "/v1/jobs/x"},
    )
    assert JobView.model_validate_json(view.model_dump_json()) == view
    listing = JobList(items=[view], next_cursor="abc")
    assert JobList.model_validate_json(listing.model_dump_json()) == listing


def test_problem_document_round_trips():
    problem = Problem(title="Invalid input", status=422, errors=[{"loc": ["a", 0], "pointer": "/a/0", "msg": "m", "type": "t"}])
    assert Problem.model_validate_json(problem.model_dump_json()) == problem


def test_requests_refuse_non_finite_numbers_and_unknown_fields():
    class Probe(StrictModel):
        value: FiniteFloat
        point: Vec3

    assert Probe(value=1.5, point=[0, 1, 2]).point == [0.0, 1.0, 2.0]
    for bad in (float("nan"), float("inf"), -float("inf")):
        with pytest.raises(ValidationError) as error:
            Probe(value=bad, point=[0, 0, 0])
        assert error.value.errors()[0]["loc"] == ("value",)
    with pytest.raises(ValidationError):
        Probe(value=1, point=[0, 0])
    with pytest.raises(ValidationError) as error:
        Probe(value=1, point=[0, 0, 0], extra=1)
    assert error.value.errors()[0]["type"] == "extra_forbidden"


def test_every_bound_of_every_kind_reaches_its_json_schema():
    """A bound pydantic cannot place in the JSON schema is emitted under its Python name (``ge``, ``lt``):
    clients and generated tests would then not see it."""
    from plantsolve.solvers.kinds import KINDS

    stray: list[str] = []

    def walk(node, path):
        if isinstance(node, dict):
            stray.extend(f"{path}: {key}" for key in ("ge", "gt", "le", "lt", "multiple_of") if key in node)
            for key, value in node.items():
                walk(value, f"{path}/{key}")
        elif isinstance(node, list):
            for i, value in enumerate(node):
                walk(value, f"{path}/{i}")

    for kind, spec in KINDS.items():
        for model in (spec.request_model, spec.result_model):
            walk(model.model_json_schema(), f"{kind}:{model.__name__}")
    assert not stray


def test_schema_models_carry_no_private_attributes():
    """A request or result is its fields: no side channel travels on a model (a kind's decoded arrays or
    file handles live in its own input value; a solve's extra payloads travel in ``Solved``)."""
    import importlib
    import inspect
    import pkgutil

    import plantsolve.schemas
    from pydantic import BaseModel

    offenders = []
    for info in pkgutil.iter_modules(plantsolve.schemas.__path__):
        module = importlib.import_module(f"plantsolve.schemas.{info.name}")
        for name, value in vars(module).items():
            if inspect.isclass(value) and issubclass(value, BaseModel) and value.__module__ == module.__name__:
                if value.__private_attributes__:
                    offenders.append(f"{module.__name__}.{name}: {sorted(value.__private_attributes__)}")
    assert not offenders, offenders
