"""/v1 routes: submit per solver kind, read, list, cancel, result, artifacts, input."""

from __future__ import annotations

import re
import uuid
from typing import Annotated, Any, Mapping, get_args
from urllib.parse import quote

from fastapi import APIRouter, Depends, Header, Query, Request, Response
from fastapi.responses import JSONResponse, StreamingResponse
from pydantic import BaseModel, ConfigDict, create_model
from starlette.concurrency import run_in_threadpool
from starlette.datastructures import UploadFile

from plantsolve.app.auth import require_api_key
from plantsolve.app.deps import Caller, Service, known_query
from plantsolve.app.jobs.events import add_event_routes
from plantsolve.app.jobs.lean import is_json
from plantsolve.app.problems import PayloadTooLarge, responses
from plantsolve.app.webhooks import check_callback_url
from plantsolve.jobs.errors import NotFound, Unprocessable, UnsupportedMediaType, field_problem
from plantsolve.jobs.service import JobService, safe_filename
from plantsolve.schemas.jobs import JobList, JobStatus, JobView, UploadedInput
from plantsolve.solvers.base import SolverSpec

IdempotencyKey = Annotated[
    str | None,
    Header(
        alias="Idempotency-Key",
        min_length=1,
        max_length=255,
        pattern=r"^[\x21-\x7e][\x20-\x7e]*$",
        description="Same key and same body return the same job (200); same key with another body is a 422.",
    ),
]

# the parts of a multipart submission: the file and the JSON of its options
FORM_PARTS = ("file", "options")


def _json(model, status_code: int = 200, headers: dict[str, str] | None = None) -> Response:
    """Serialise an already-validated model once (the route's response_model documents it)."""
    return Response(model.model_dump_json(), status_code=status_code, headers=headers, media_type="application/json")


def _json_input(request: Request, job, service: JobService) -> Response:
    """A JSON request as it was stored: inline in the row, or in a blob when it was large."""
    if job.input_kind == "json":
        return JSONResponse(job.input)
    return _stream(request, service.input_file(job), "application/json")


def _stream(request: Request, stored, media_type: str, *, filename: str | None = None,
            headers: dict[str, str] | None = None) -> Response:
    """A stored file streamed from the blob store in chunks, with its Content-Length (the service opened it:
    a missing blob was a 404 and an unreachable store a 503 before this response started); HEAD: the
    headers alone."""
    headers = {"content-length": str(stored.size), **(headers or {})}
    if filename is not None:  # as Starlette's FileResponse writes it
        quoted = quote(filename)
        headers["content-disposition"] = (f"attachment; filename*=utf-8''{quoted}" if quoted != filename
                                          else f'attachment; filename="{filename}"')
    if request.method == "HEAD":
        stored.close()
        return Response(headers=headers, media_type=media_type)
    return StreamingResponse(stored.chunks(), media_type=media_type, headers=headers)


CallbackUrl = Annotated[
    str | None,
    Query(
        max_length=2048,
        description="Completion webhook: when the job has finished, the job view is POSTed to this http(s) URL, signed "
        "per Standard Webhooks ('webhook-id', 'webhook-timestamp', 'webhook-signature: v1,<base64 HMAC-SHA256 of "
        "\"{id}.{timestamp}.{body}\">' with the key's webhook secret) and retried with backoff until the receiver "
        "answers 2xx; the id stays the same on every retry.",
    ),
]


def submit_route(kind: str):
    """The POST /v1/<kind>/jobs handler: JSON body or multipart upload (``file`` + ``options``)."""

    async def submit(request: Request, service: Service, caller: Caller, idempotency_key: IdempotencyKey = None,
                     callback_url: CallbackUrl = None) -> Response:
        if callback_url is not None:
            # the check resolves the host's name: off the event loop
            callback_url = await run_in_threadpool(check_callback_url, callback_url, caller.owner,
                                                   request.app.state.webhook_secrets,
                                                   request.app.state.settings.webhook_private_targets)
        content_type = request.headers.get("content-type", "").split(";")[0].strip().lower()
        if is_json(content_type):
            body = await request.body()
            submitted = await run_in_threadpool(service.with_view, service.submit_json, kind, body, idempotency_key,
                                                owner=caller.owner, callback_url=callback_url)
        elif content_type == "multipart/form-data":
            limit = request.app.state.settings.max_body_bytes
            form = await request.form(max_files=1, max_fields=4, max_part_size=min(limit, 16 * 1024 * 1024))
            upload = form.get("file")
            if not isinstance(upload, UploadFile):
                raise Unprocessable(
                    "A multipart submission needs a 'file' part.",
                    errors=[field_problem(["file"], "missing file part", "missing")],
                )
            strays = sorted(set(form.keys()) - set(FORM_PARTS))
            if strays:  # a 'units' part beside the file would be ignored: the file read in the default unit
                raise Unprocessable(
                    f"A multipart submission has the parts {', '.join(FORM_PARTS)}; "
                    f"{', '.join(repr(name) for name in strays)} is read by nothing: put request settings such as "
                    "units inside 'options' (a JSON object).",
                    errors=[field_problem([name], "form part read by nothing", "extra_forbidden") for name in strays],
                )
            upload_limit = request.app.state.settings.max_upload_bytes
            if upload.size is not None and upload.size > upload_limit:
                raise PayloadTooLarge(f"The uploaded file has {upload.size} bytes; the limit is {upload_limit} bytes.")
            content = await upload.read()
            options = form.get("options")
            if options is not None and not isinstance(options, str):
                options = (await options.read()).decode("utf-8", "replace")
            submitted = await run_in_threadpool(service.with_view, service.submit_upload, kind,
                                                upload.filename or "upload", content, options, idempotency_key,
                                                owner=caller.owner, callback_url=callback_url)
        else:
            raise UnsupportedMediaType(
                f"Content-Type {content_type or '(none)'!r} is not accepted: send application/json or multipart/form-data."
            )
        job, view = submitted.job, submitted.view
        return _json(view, status_code=202 if submitted.created else 200, headers={"Location": f"/v1/jobs/{job.id}"})

    submit.__name__ = f"submit_{kind}_job"
    return submit


def camel(kind: str) -> str:
    """A kind as it appears in operationIds: ``test-compute`` -> ``TestCompute``."""
    return "".join(part[:1].upper() + part[1:] for part in re.split(r"[-_]", kind) if part)


def result_schema_name(spec: SolverSpec) -> str:
    return spec.result_model.__name__


def declares_kind(spec: SolverSpec) -> bool:
    """Whether the kind's result model carries ``kind: Literal["<kind>"]`` (every shipped kind's does)."""
    field = spec.result_model.model_fields.get("kind")
    return field is not None and get_args(field.annotation) == (spec.kind,)


def result_union(kinds: Mapping[str, SolverSpec]) -> dict[str, Any]:
    """The schema of GET /v1/jobs/{id}/result: one of the kinds' result schemas, told apart by ``kind``. Should a
    plugin kind's result not carry ``kind``, nothing can tell the results apart: then a plain anyOf."""
    refs = {kind: f"#/components/schemas/{result_schema_name(kinds[kind])}" for kind in sorted(kinds)}
    if not all(declares_kind(spec) for spec in kinds.values()):
        return {"anyOf": [{"$ref": ref} for ref in refs.values()]}
    return {"oneOf": [{"$ref": ref} for ref in refs.values()],
            "discriminator": {"propertyName": "kind", "mapping": refs}}


def with_kind(result: Any, spec: SolverSpec | None) -> Any:
    """A stored result as the contract describes it: results stored before results carried ``kind`` get it here."""
    if spec is not None and isinstance(result, dict) and "kind" not in result and declares_kind(spec):
        return {"kind": spec.kind, **result}
    return result


def a_or_an(word: str) -> str:
    """The indefinite article for ``word`` (kinds start with a vowel sound exactly when they start with a vowel)."""
    return "an" if word[:1].lower() in "aeiou" else "a"


def upload_options_name(spec: SolverSpec) -> str:
    """Component name of the schema of a kind's multipart ``options`` part."""
    return f"{camel(spec.kind)}UploadOptions"


def upload_options_model(spec: SolverSpec) -> type[BaseModel] | None:
    """What a kind's multipart ``options`` part holds, as a model for the OpenAPI document only: the fields of the
    request's ``options``, flat. Open to further keys: some kinds' file readers take keys of their own from the form
    (the request's ``units``, the file's unit); keys nothing reads are refused with a 422 naming them. None for a
    kind whose request has no ``options`` object (plugin kinds): the part is then documented as a JSON object."""
    model = _options_of(spec)
    if model is None:
        return None
    fields: dict[str, Any] = {name: (field.annotation, field) for name, field in model.model_fields.items()}
    config = ConfigDict(**{**model.model_config, "extra": "allow", "title": upload_options_name(spec)})
    return create_model(upload_options_name(spec), __config__=config, __doc__=(
        f"The multipart 'options' part of {a_or_an(spec.kind)} {spec.kind} upload: the request's options, flat; "
        "further keys a file reader takes (e.g. 'units') are passed on."), **fields)


def _options_of(spec: SolverSpec) -> type[BaseModel] | None:
    options = spec.request_model.model_fields.get("options")
    model = options.annotation if options is not None else None
    return model if isinstance(model, type) and issubclass(model, BaseModel) else None


def submit_openapi(spec: SolverSpec) -> dict[str, Any]:
    name = spec.request_model.__name__
    extensions = ", ".join(spec.upload_extensions) or "none"
    content: dict[str, Any] = {"application/json": {"schema": {"$ref": f"#/components/schemas/{name}"}}}
    if spec.example is not None:
        content["application/json"]["example"] = spec.example()
    if spec.upload_extensions:
        typed = _options_of(spec) is not None
        options = ({"$ref": f"#/components/schemas/{upload_options_name(spec)}"} if typed else
                   {"type": "object", "additionalProperties": True})
        content["multipart/form-data"] = {
            "schema": {
                "type": "object",
                "required": ["file"],
                "additionalProperties": False,
                "properties": {
                    "file": {"type": "string", "format": "binary",
                             "description": f"Accepted file types (by the file name's extension): {extensions}."},
                    "options": {**options, "description": "The request's options as a JSON object (sent as a part "
                                "of type application/json, or as a plain form field holding the JSON text)."},
                },
            },
            # the part is JSON, not a string: generated clients send it typed and serialised
            "encoding": {"options": {"contentType": "application/json"}},
        }
    return {"requestBody": {"required": True, "content": content}}


ROUTERS: dict[tuple[tuple[str, int], ...], tuple[Mapping[str, SolverSpec], APIRouter]] = {}


def jobs_router(kinds: Mapping[str, SolverSpec]) -> APIRouter:
    """:func:`build_router`'s router, built once per process for one set of kinds. Its routes depend on the kinds
    alone (a request finds its service, settings and secrets through its own app), and FastAPI makes each route's
    validators as it is added: three quarters of an app's start, for every app a process makes (a test suite makes
    hundreds). The entry keeps the kinds it was built for, so the ids in its key stay theirs."""
    key = tuple((kind, id(kinds[kind])) for kind in sorted(kinds))
    if key not in ROUTERS:
        ROUTERS[key] = (kinds, build_router(kinds))
    return ROUTERS[key][1]


def build_router(kinds: Mapping[str, SolverSpec]) -> APIRouter:
    router = APIRouter(prefix="/v1", dependencies=[Depends(require_api_key), Depends(known_query)],
                       responses=responses(401, 500))

    for kind in sorted(kinds):
        spec = kinds[kind]
        router.add_api_route(
            f"/{kind}/jobs",
            submit_route(kind),
            methods=["POST"],
            status_code=202,
            response_model=JobView,
            tags=[kind],
            operation_id=f"submit{camel(kind)}Job",
            summary=f"Submit {a_or_an(kind)} {kind} job",
            description=(spec.description or f"Run the {kind} solver.")
            + "\n\nAnswers 202 with the job and a Location header; 200 with the existing job for a repeated Idempotency-Key.",
            responses={200: {"model": JobView, "description": "Same Idempotency-Key and body: the existing job"}, **responses(400, 413, 415, 422, 503)},
            openapi_extra=submit_openapi(spec),
        )

    add_event_routes(router)  # before /jobs/{job_id}: "events" is no job id

    @router.get("/jobs", response_model=JobList, tags=["jobs"], responses=responses(422), operation_id="listJobs",
                summary="List jobs, newest first")
    def list_jobs(
        service: Service,
        caller: Caller,
        kind: str | None = None,
        status: JobStatus | None = None,
        cursor: str | None = Query(default=None, max_length=512, pattern=r"^[A-Za-z0-9_-]+$",
                                   description="next_cursor of the previous page (opaque)"),
        limit: int = Query(default=50, ge=1, le=200),
    ) -> JobList:
        return service.list(kind, status, cursor, limit, caller.sees)

    @router.get("/jobs/{job_id}", response_model=JobView, tags=["jobs"], responses=responses(404, 422), operation_id="getJob",
                summary="Job status")
    def get_job(job_id: uuid.UUID, service: Service, caller: Caller) -> Response:
        return _json(service.view(service.get(job_id, caller.sees, brief=True)))

    any_result = result_union(kinds)

    @router.get(
        "/jobs/{job_id}/result",
        tags=["jobs"],
        operation_id="getJobResult",
        responses={200: {"description": "The solver's result: the result schema of the job's kind (typed per kind at "
                                        "GET /v1/<kind>/jobs/{id}/result)",
                         "content": {"application/json": {"schema": any_result}}},
                   **responses(404, 409, 422)},
        summary="Result of a succeeded job (any kind)",
    )
    def get_result(job_id: uuid.UUID, service: Service, caller: Caller) -> JSONResponse:
        result = service.result(job_id, caller.sees)
        if isinstance(result, dict) and "kind" not in result:  # stored before results carried their kind
            result = with_kind(result, kinds.get(service.get(job_id, caller.sees, brief=True).kind))
        return JSONResponse(result)

    @router.post("/jobs/{job_id}/cancel", response_model=JobView, tags=["jobs"], responses=responses(404, 409, 413, 422),
                 operation_id="cancelJob", summary="Cancel a queued or running job")
    def cancel_job(job_id: uuid.UUID, service: Service, caller: Caller) -> JobView:
        return service.view(service.cancel(job_id, caller.sees))

    def get_artifact(job_id: uuid.UUID, name: str, request: Request, service: Service, caller: Caller) -> Response:
        artifact, stored = service.artifact(job_id, name, caller.sees)
        return _stream(request, stored, artifact.media_type, filename=artifact.name,
                       headers={"X-Content-SHA256": artifact.sha256})

    artifact_file = {"description": "The file, with its media type (Content-Length, X-Content-SHA256)",
                     "content": {"application/octet-stream": {"schema": {"type": "string", "format": "binary"}}}}
    router.add_api_route("/jobs/{job_id}/artifacts/{name}", get_artifact, methods=["GET"], tags=["jobs"],
                         response_class=StreamingResponse, operation_id="getJobArtifact", summary="Download an artifact",
                         responses={200: artifact_file, **responses(404, 422)})
    router.add_api_route("/jobs/{job_id}/artifacts/{name}", get_artifact, methods=["HEAD"], tags=["jobs"],
                         response_class=StreamingResponse, operation_id="headJobArtifact",
                         summary="An artifact's headers (size, media type, SHA-256) without its body",
                         responses={200: {"description": "The headers GET would send, no body"}, **responses(404, 422)})

    any_request = [{"$ref": f"#/components/schemas/{kinds[k].request_model.__name__}"} for k in sorted(kinds)]

    @router.get(
        "/jobs/{job_id}/input",
        tags=["jobs"],
        operation_id="getJobInput",
        responses={200: {"description": "A JSON request as it was stored; for a file upload, an UploadedInput document "
                                        "(file name, the multipart 'options', a link to the file)",
                         "content": {"application/json": {"schema": {
                             "anyOf": [{"$ref": "#/components/schemas/UploadedInput"}, *any_request]}}}},
                   **responses(404, 422)},
        summary="What was submitted",
    )
    def get_input(job_id: uuid.UUID, request: Request, service: Service, caller: Caller) -> Response:
        job = service.get(job_id, caller.sees)
        if job.input_kind != "upload":
            return _json_input(request, job, service)
        stored = service.input_file(job)
        stored.close()
        uploaded = UploadedInput(filename=job.input_filename or "", options=job.input_options,
                                 size=stored.size, file=f"/v1/jobs/{job_id}/input/file")
        return _json(uploaded)

    @router.get(
        "/jobs/{job_id}/input/file",
        tags=["jobs"],
        operation_id="getJobInputFile",
        responses={200: {"description": "The submitted bytes: the uploaded file, or the JSON request",
                         "content": {"application/octet-stream": {"schema": {"type": "string", "format": "binary"}}}},
                   **responses(404, 422)},
        summary="The submitted file, byte for byte",
    )
    def get_input_file(job_id: uuid.UUID, request: Request, service: Service, caller: Caller) -> Response:
        job = service.get(job_id, caller.sees)
        if job.input_kind != "upload":
            return _json_input(request, job, service)
        return _stream(request, service.input_file(job), "application/octet-stream",
                       filename=safe_filename(job.input_filename or ""))

    for kind in sorted(kinds):
        spec = kinds[kind]
        router.add_api_route(
            f"/{kind}/jobs/{{job_id}}/result",
            kind_result_route(spec),
            methods=["GET"],
            response_model=kinds[kind].result_model,
            tags=[kind],
            operation_id=f"get{camel(kind)}JobResult",
            responses={**responses(404, 409, 422)},
            summary=f"Result of a succeeded {kind} job",
            description=f"The same document as GET /v1/jobs/{{id}}/result, typed as the {kind} result; 404 for a job "
                        f"of another kind.",
        )
    return router


def build_unknown_kind_router(kinds: Mapping[str, SolverSpec]) -> APIRouter:
    """``/v1/<kind>/jobs…`` for a kind that does not exist: a 404 that lists the kinds. Include it after every
    other router, so that only paths no kind serves get here."""
    router = APIRouter(prefix="/v1", dependencies=[Depends(require_api_key)], include_in_schema=False)

    async def unknown_kind(kind: str) -> Response:
        if kind in kinds:
            raise NotFound("Not Found")
        raise NotFound(f"No solver kind {kind!r}. Known kinds: {', '.join(sorted(kinds))}.",
                       extra={"kinds": sorted(kinds)})

    router.add_api_route("/{kind}/jobs", unknown_kind, methods=["POST"])
    router.add_api_route("/{kind}/jobs/{rest:path}", unknown_kind, methods=["GET", "POST"])
    return router


def kind_result_route(spec: SolverSpec):
    kind = spec.kind

    def get_kind_result(job_id: uuid.UUID, service: Service, caller: Caller) -> JSONResponse:
        return JSONResponse(with_kind(service.result(job_id, caller.sees, kind=kind), spec))

    get_kind_result.__name__ = f"get_{kind.replace('-', '_')}_result"
    return get_kind_result
