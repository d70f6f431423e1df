"""The FastAPI application: ``create_app()`` wires settings, database, dispatcher and routes."""

from __future__ import annotations

import logging
from contextlib import asynccontextmanager
from typing import Any

from asgi_correlation_id import correlation_id
from fastapi import FastAPI, Request
from fastapi.openapi.utils import get_openapi
from fastapi.responses import JSONResponse, RedirectResponse

from plantsolve.app import problems
from plantsolve.app.auth import KeyRing
from plantsolve.app.dashboard import install_dashboard
from plantsolve.app.docs import install_docs
from plantsolve.app.edge import EdgeMiddleware
from plantsolve.app.jobs.endpoints import build_unknown_kind_router, declares_kind, jobs_router, upload_options_model
from plantsolve.app.jobs.lean import LeanRoutes
from plantsolve.app.jobs.operations import build_operations_router
from plantsolve.app.metrics import build_metrics
from plantsolve.app.settings import AppSettings, get_settings
from plantsolve.app.webhooks import WebhookNotifier, WebhookSecrets
from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.dispatch import NoWorkers
from plantsolve.jobs.service import JobService
from plantsolve.schemas.jobs import HealthStatus, Problem, UploadedInput
from plantsolve.workers.dispatch import make_dispatcher
from plantsolve.workers.logs import configure_logging

log = logging.getLogger("plantsolve.api")


class RequestIdFilter(logging.Filter):
    """Puts the request id of the HTTP request being served (if any) on each log record."""

    def filter(self, record: logging.LogRecord) -> bool:
        if getattr(record, "request_id", None) is None:
            record.request_id = correlation_id.get()
        return True


def create_app(settings: AppSettings | None = None, *, run_jobs: bool = True) -> FastAPI:
    """Build the app. ``run_jobs=False`` keeps the embedded pool stopped (tests that drive
    the runner by hand)."""
    settings = settings or get_settings()
    configure_logging(settings.log_format, settings.log_level, filters=(RequestIdFilter(),))
    ctx = ServiceContext.create(settings)
    dispatcher = make_dispatcher(ctx)

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        if settings.auto_migrate:
            ctx.db.migrate()
        if run_jobs:
            dispatcher.start()
            app.state.webhooks.start()
        try:
            yield
        finally:
            if run_jobs:
                app.state.webhooks.stop()
                dispatcher.stop()
            if getattr(dispatcher, "enqueues_on_loop", False):
                await dispatcher.close_on_loop()
            ctx.close()

    app = FastAPI(
        title="plantsolve",
        version="0.1.0",
        summary="Engineering solvers for measured plant geometry and test-rig data, run as jobs.",
        description=(
            "Submit a job with `POST /v1/<kind>/jobs` (JSON or a file upload), poll `GET /v1/jobs/{id}`, "
            "then fetch `/result` and `/artifacts/{name}`. Errors are RFC 9457 problem documents. "
            "Lengths are in the request's `units` (default mm), angles in degrees, quaternions `[w, x, y, z]`."
        ),
        lifespan=lifespan,
        docs_url=None,  # served from the package's own assets: see install_docs
        redoc_url=None,
    )
    app.state.settings = settings
    app.state.ctx = ctx
    app.state.dispatcher = dispatcher
    app.state.jobs = JobService(ctx, dispatcher)
    app.state.keys = KeyRing(settings.api_keys, settings.admin_keys)
    app.state.webhook_secrets = WebhookSecrets(settings.webhook_secrets, app.state.keys)
    app.state.webhooks = WebhookNotifier(app.state.jobs, app.state.webhook_secrets, settings)
    # one layer for request id, security headers, CORS, the caller and the body limit (in that order, see
    # edge.py), which also answers the hot submit and status routes without the router
    lean = LeanRoutes(app.state.jobs, ctx.kinds, inline_reads=ctx.db.is_sqlite)
    app.add_middleware(EdgeMiddleware, keys=app.state.keys, protect_docs=settings.protect_docs,
                       max_body_bytes=settings.max_body_bytes, cors_origins=settings.cors_origins, lean=lean,
                       body_idle_seconds=settings.body_idle_seconds)
    problems.install(app)
    app.include_router(jobs_router(ctx.kinds))
    app.include_router(build_operations_router(ctx.kinds))
    install_dashboard(app)
    app.include_router(build_metrics(app.state.jobs, ctx.kinds))
    app.include_router(build_unknown_kind_router(ctx.kinds))
    install_docs(app)
    _install_health(app)
    app.openapi = lambda: _openapi(app)
    return app


def _install_health(app: FastAPI) -> None:
    @app.get("/", include_in_schema=False)
    def root() -> RedirectResponse:
        return RedirectResponse("/dashboard")

    @app.get("/healthz", response_model=HealthStatus, tags=["health"], operation_id="getHealth",
             responses=problems.responses(500), summary="The process is up")
    def healthz() -> HealthStatus:
        return HealthStatus(status="ok")

    @app.get(
        "/readyz",
        response_model=HealthStatus,
        tags=["health"],
        summary="Whether the service can take a job now: the database takes a write, the blob store a file, its disks "
                "have room, and a job can start",
        operation_id="getReadiness",
        responses={503: {"model": HealthStatus, "description": "A part cannot (named in checks; details in the log)"},
                   **problems.responses(500)},
    )
    def readyz(request: Request) -> Any:
        status = readiness(request.app.state.ctx, request.app.state.dispatcher)
        return JSONResponse(status.model_dump(), status_code=200 if status.status == "ok" else 503)


READINESS_PROBE = ".readiness-probe"


def readiness(ctx: ServiceContext, dispatcher) -> HealthStatus:
    """Each part ``ok`` or ``unavailable``; why a part is unavailable goes to the log only (it may hold addresses and
    driver messages)."""
    probes = (("database", ctx.db.ping), ("files", lambda: ctx.files.put(READINESS_PROBE, b"ok")),
              ("disk", ctx.store.check_disk), ("jobs", dispatcher.ping))
    checks: dict[str, str] = {}
    for name, probe in probes:
        try:
            probe()
            checks[name] = "ok"
        except NoWorkers as error:  # the queue takes jobs, nobody runs them
            checks[name] = "ok"
            checks["workers"] = "unavailable"
            log.warning("not ready: workers: %s", error)
        except Exception as error:
            checks[name] = "unavailable"
            log.warning("not ready: %s: %s: %s", name, type(error).__name__, " ".join(str(error).split())[:500])
    if getattr(dispatcher, "workers_apart", False):  # Celery: the queue's answer told whether a worker is there
        checks.setdefault("workers", "ok" if checks["jobs"] == "ok" else "unavailable")
    ok = all(value == "ok" for value in checks.values())
    return HealthStatus(status="ok" if ok else "unavailable", checks=checks)


def _openapi(app: FastAPI) -> dict[str, Any]:
    """OpenAPI with every solver's request and result schema among the components (the
    submit routes read their body by hand to accept JSON or multipart), each kind's multipart
    ``options`` part, and ``kind`` required on results that carry it: the server always sends it,
    and the result union's discriminator needs it."""
    if app.openapi_schema:
        return app.openapi_schema
    schema = get_openapi(title=app.title, version=app.version, summary=app.summary, description=app.description, routes=app.routes)
    components = schema.setdefault("components", {}).setdefault("schemas", {})
    models: list[tuple[type, dict | None]] = [(Problem, None), (UploadedInput, None)]
    for spec in app.state.ctx.kinds.values():
        models += [(spec.request_model, spec.example() if spec.example else None), (spec.result_model, None)]
        upload_options = upload_options_model(spec) if spec.upload_extensions else None
        if upload_options is not None:
            models.append((upload_options, None))
    for model, example in models:
        definition = model.model_json_schema(ref_template="#/components/schemas/{model}", by_alias=True)
        for name, sub in definition.pop("$defs", {}).items():
            components.setdefault(name, sub)
        if example is not None:
            definition["examples"] = [example]
        components[model.__name__] = definition
    for spec in app.state.ctx.kinds.values():
        if declares_kind(spec):
            result = components[spec.result_model.__name__]
            result["required"] = ["kind", *[name for name in result.get("required", []) if name != "kind"]]
    app.openapi_schema = schema
    return schema
