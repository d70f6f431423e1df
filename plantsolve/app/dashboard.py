"""The server-rendered dashboard: job list (filters, paging, live), a page per job, a submit form
per kind, and the login that opens the browser's session (see ``auth``).

Pages are Jinja2 templates (``templates/``) with one small script (``static/dashboard.js``) that
follows the job events (``/v1/jobs/events``, ``/v1/jobs/{id}/events``) and falls back to polling.
The form posts go through the same :class:`JobService` calls as ``POST /v1/<kind>/jobs``; a
browser authorised by its cookie must send the form's anti-forgery token (see ``auth``).
"""

from __future__ import annotations

import hmac
import json
import uuid
from pathlib import Path
from typing import Annotated, Any
from urllib.parse import urlencode

from fastapi import APIRouter, Depends, FastAPI, Form, Query, Request
from fastapi.responses import HTMLResponse, RedirectResponse, Response
from fastapi.staticfiles import StaticFiles
from fastapi.templating import Jinja2Templates
from starlette.concurrency import run_in_threadpool
from starlette.datastructures import UploadFile

from plantsolve.app import dashboard_views as views
from plantsolve.app.auth import (COOKIE, LOGIN_COOKIE, LoginTokens, Sessions, cookie_key, form_token, principal,
                                 require_api_key)
from plantsolve.app.deps import service_of
from plantsolve.app.problems import PayloadTooLarge
from plantsolve.app.verdicts import report_warnings
from plantsolve.jobs.errors import Conflict, NotFound, ProblemError, Unprocessable, field_problem
from plantsolve.jobs.lifecycle import STATUSES, is_finished
from plantsolve.jobs.service import JobService, decode_cursor, encode_cursor
from plantsolve.schemas.common import verdicts_of
from plantsolve.solvers.base import SolverSpec

HERE = Path(__file__).parent
STATIC = "/dashboard-static"  # outside /dashboard/: the login page needs its style before any key
PAGE_SIZE = 25

Kind = Annotated[str | None, Query(max_length=64)]
Status = Annotated[str | None, Query(max_length=16)]
Text = Annotated[str | None, Query(max_length=200, description="text in the id, kind, message or report")]
Cursor = Annotated[str | None, Query(max_length=512, pattern=r"^[A-Za-z0-9_-]*$")]
Limit = Annotated[int, Query(ge=1, le=200)]

templates = Jinja2Templates(directory=HERE / "templates")
templates.env.globals.update(static=STATIC, statuses=STATUSES)
templates.env.filters.update(when=views.when, seconds=views.seconds, pretty=views.pretty)


class Forbidden(ProblemError):
    status, title, slug = 403, "Forbidden", "forbidden"


def install_dashboard(app: FastAPI) -> None:
    # the login sessions live in the store's session table (see auth.Sessions)
    app.state.sessions = Sessions(app.state.ctx.store.sessions, app.state.keys)
    settings = app.state.settings
    app.state.login_tokens = LoginTokens.for_settings(settings.login_secret, settings.api_keys, settings.admin_keys)
    app.include_router(build_dashboard())
    app.mount(STATIC, StaticFiles(directory=HERE / "static"), name="dashboard-static")


def _page(request: Request, name: str, status_code: int = 200, **context: Any) -> HTMLResponse:
    context.setdefault("kinds", sorted(service_of(request).kinds))
    context.setdefault("keys", bool(request.app.state.keys))
    return templates.TemplateResponse(request, name, context, status_code=status_code)


def _with_headers(page: HTMLResponse, error: ProblemError) -> HTMLResponse:
    """The page showing ``error`` with the headers its problem carries, as the API's answer has them (a 503's
    ``Retry-After``: disk space low)."""
    page.headers.update(error.headers)
    return page


def _login_page(request: Request, status_code: int, message: str, csrf: str | None = None) -> HTMLResponse:
    """The login form with a CSRF token the server signed (see ``auth.LoginTokens``), also set as a cookie scoped
    to the login: the post must send both, they must match, and the server must have issued the token (signed
    and dated, so any API process checks it without state)."""
    tokens: LoginTokens = request.app.state.login_tokens
    csrf = csrf if csrf and tokens.valid(csrf) else tokens.issue()
    response = _page(request, "login.html", status_code, message=message, csrf=csrf)
    response.set_cookie(LOGIN_COOKIE, csrf, max_age=int(tokens.lifetime_seconds), httponly=True, samesite="strict",
                        secure=request.url.scheme == "https", path="/dashboard/login")
    return response


def _not_found(request: Request, error: NotFound) -> HTMLResponse:
    return _page(request, "error.html", 404, title="Not found", message=error.detail)


def _listing(request: Request, kind: str | None, status: str | None, q: str | None, cursor: str | None,
             limit: int) -> dict[str, Any]:
    """One page of the list (the repository's cursor paging) with the counts by status."""
    service, who = service_of(request), principal(request)
    kind, status, q = kind or None, status or None, (q or "").strip() or None
    after = decode_cursor(cursor) if cursor else None
    jobs = service.search(kind=kind, status=status, text=q, after=after, limit=limit + 1, sees=who.sees)
    more = len(jobs) > limit
    jobs = jobs[:limit]
    filters = {"kind": kind or "", "status": status or "", "q": q or ""}
    # the stream filters by kind and status only (the text is applied when the rows reload); no empty values
    stream = {name: value for name, value in (("kind", kind), ("status", status)) if value}
    return {
        "rows": [views.row(service.view(job, with_artifacts=False), views.input_label(job)) for job in jobs],
        "counts": service.count_by_status(who.sees),
        "filters": filters,
        "cursor": cursor or "",
        "next_cursor": encode_cursor(jobs[-1]) if more and jobs else None,
        "limit": limit,
        "embedded": service.ctx.settings.embedded,
        "events": "/v1/jobs/events" + (f"?{urlencode(stream)}" if stream else ""),
    }


def _job_context(request: Request, job_id: uuid.UUID) -> dict[str, Any]:
    service = service_of(request)
    job = service.get(job_id, principal(request).sees)
    view = service.view(job)
    artifacts = view.artifacts
    return {
        "job": view,
        "progress": views.progress_text(view.status, view.progress.fraction),
        "finished": is_finished(view.status),
        "warnings": view.report.warnings if view.report is not None else [],
        "verdicts": verdicts_of(report_warnings(view.report)) if view.status == "succeeded" else [],
        "plots": views.plots(artifacts),
        "artifacts": artifacts,
        "input": views.input_view(job),
        "summary": (views.result_summary(job.result, _result_model(service, view.kind))
                    if job.status == "succeeded" else []),
        "token": _token_for(request),
    }


def _result_model(service: JobService, kind: str) -> Any:
    """The kind's result model (the units of its fields), or ``None`` for a kind this process no longer has."""
    return service.ctx.kinds[kind].result_model if kind in service.ctx.kinds else None


def _token_for(request: Request) -> str:
    key = cookie_key(request)
    return form_token(key) if key else ""


def _check_form(request: Request, token: str) -> None:
    """A dashboard form post must come from the dashboard: not from another site, and, when the
    cookie authorises it, with the token only a page of this service knows."""
    if request.headers.get("sec-fetch-site", "same-origin") in ("cross-site", "same-site"):
        raise Forbidden("Dashboard forms are accepted from the dashboard only.")
    key = cookie_key(request)
    if key and request.app.state.keys and not hmac.compare_digest(token.encode(), form_token(key).encode()):
        raise Forbidden("The form's token is missing or stale: reload the page and send it again.")


def build_dashboard() -> APIRouter:
    router = APIRouter(include_in_schema=False)
    authorised = [Depends(require_api_key)]

    @router.get("/dashboard/login", response_class=HTMLResponse)
    def login_form(request: Request) -> HTMLResponse:
        return _login_page(request, 200, "This service needs an API key.")

    @router.post("/dashboard/login")
    def login(request: Request, key: str = Form(default="", max_length=512),
              csrf: str = Form(default="", max_length=128)) -> Response:
        """CSRF token first (a page of another site cannot log a browser in under the attacker's key), then
        the rate limit per client address, then the key; a valid key opens a server-side session."""
        keys, sessions = request.app.state.keys, request.app.state.sessions
        sent = request.cookies.get(LOGIN_COOKIE, "")
        if (request.headers.get("sec-fetch-site", "same-origin") in ("cross-site", "same-site")
                or not csrf or not hmac.compare_digest(csrf.encode(), sent.encode())
                or not request.app.state.login_tokens.valid(csrf)):
            raise Forbidden("The login form's token is missing or stale: reload the login page and send it again.")
        if not keys:  # no keys: nothing to log in to
            return RedirectResponse("/dashboard", status_code=303)
        address = request.client.host if request.client else "unknown"
        wait = sessions.retry_after(address)
        if wait is not None:
            response = _login_page(request, 429, f"Too many failed logins from {address}: try again in {wait} s.",
                                   csrf=sent)
            response.headers["Retry-After"] = str(wait)
            return response
        if keys.find(key) is None:
            sessions.failed(address)
            return _login_page(request, 401, "That key is not valid.", csrf=sent)
        response = RedirectResponse("/dashboard", status_code=303)
        # HTTP-only and same-site: scripts cannot read it, other sites cannot send it (see auth)
        response.set_cookie(COOKIE, sessions.open(key), max_age=int(sessions.lifetime_seconds), httponly=True,
                            samesite="strict", secure=request.url.scheme == "https", path="/")
        response.delete_cookie(LOGIN_COOKIE, path="/dashboard/login")
        return response

    @router.post("/dashboard/logout")
    def logout(request: Request) -> RedirectResponse:
        """Ends the session on the server (the cookie is dead even where a copy of it survives)."""
        if request.headers.get("sec-fetch-site", "same-origin") in ("cross-site", "same-site"):
            raise Forbidden("Log out from the dashboard itself.")
        session = cookie_key(request)
        if session and request.app.state.keys:
            request.app.state.sessions.close(session)
        response = RedirectResponse("/dashboard/login", status_code=303)
        response.delete_cookie(COOKIE, path="/")
        return response

    @router.get("/dashboard", response_class=HTMLResponse, dependencies=authorised)
    def dashboard(request: Request, kind: Kind = None, status: Status = None, q: Text = None, cursor: Cursor = None,
                  limit: Limit = PAGE_SIZE) -> HTMLResponse:
        return _page(request, "jobs.html", **_listing(request, kind, status, q, cursor, limit))

    @router.get("/dashboard/rows", response_class=HTMLResponse, dependencies=authorised)
    def rows(request: Request, kind: Kind = None, status: Status = None, q: Text = None, cursor: Cursor = None,
             limit: Limit = PAGE_SIZE) -> HTMLResponse:
        """The list's live part alone: the script swaps it in when jobs change."""
        return _page(request, "_jobs_live.html", **_listing(request, kind, status, q, cursor, limit))

    @router.get("/dashboard/jobs/{job_id}", response_class=HTMLResponse, dependencies=authorised)
    def job_page(request: Request, job_id: uuid.UUID) -> HTMLResponse:
        try:
            return _page(request, "job.html", **_job_context(request, job_id))
        except NotFound as error:
            return _not_found(request, error)

    @router.get("/dashboard/jobs/{job_id}/detail", response_class=HTMLResponse, dependencies=authorised)
    def job_detail(request: Request, job_id: uuid.UUID) -> HTMLResponse:
        """The job page's body alone: the script swaps it in when the job's status changes."""
        try:
            return _page(request, "_job_detail.html", **_job_context(request, job_id))
        except NotFound as error:
            return _not_found(request, error)

    @router.post("/dashboard/jobs/{job_id}/cancel", dependencies=authorised)
    async def cancel(request: Request, job_id: uuid.UUID, token: str = Form(default="", max_length=128)) -> Response:
        _check_form(request, token)
        service = service_of(request)
        try:
            await run_in_threadpool(service.cancel, job_id, principal(request).sees)
        except NotFound as error:
            return _not_found(request, error)
        except ProblemError:  # already finished: the page shows how
            pass
        return RedirectResponse(f"/dashboard/jobs/{job_id}", status_code=303)

    @router.post("/dashboard/jobs/{job_id}/rerun", dependencies=authorised)
    async def rerun(request: Request, job_id: uuid.UUID, token: str = Form(default="", max_length=128)) -> Response:
        """The same input submitted again as a new job (a finished job's 'Re-run'): the JSON body, or the
        stored file under its name with the same options, through the calls of ``POST /v1/<kind>/jobs``."""
        _check_form(request, token)
        service, who = service_of(request), principal(request)
        try:
            submitted = await run_in_threadpool(_submit_again, service, job_id, who)
        except NotFound as error:
            return _not_found(request, error)
        except ProblemError as error:  # the kind changed since and refuses the input, or the disk is low: say so
            return _with_headers(_page(request, "error.html", error.status, title=error.title, message=error.detail),
                                 error)
        return RedirectResponse(f"/dashboard/jobs/{submitted.job.id}", status_code=303)

    @router.get("/dashboard/submit/{kind}", response_class=HTMLResponse, dependencies=authorised)
    def submit_form(request: Request, kind: str) -> HTMLResponse:
        try:
            spec = service_of(request).spec(kind)
        except NotFound as error:
            return _not_found(request, error)
        return _page(request, "submit.html", **_form_context(request, spec))

    @router.post("/dashboard/submit/{kind}", response_class=HTMLResponse, dependencies=authorised)
    async def submit(request: Request, kind: str) -> Response:
        service, who = service_of(request), principal(request)
        try:
            spec = service.spec(kind)
        except NotFound as error:
            return _not_found(request, error)
        settings = request.app.state.settings
        form = await request.form(max_files=1, max_fields=7, max_part_size=min(settings.max_body_bytes, 16 * 1024 * 1024))
        source = str(form.get("source") or "json")
        options, body = str(form.get("options") or ""), str(form.get("body") or "")
        defaults = str(form.get("option_defaults") or "")
        units = str(form.get("units") or "")
        try:
            _check_form(request, str(form.get("token") or ""))
            if source == "upload":
                upload = form.get("file")
                if not isinstance(upload, UploadFile) or not upload.filename:
                    raise Unprocessable("Choose a file to upload.", errors=[field_problem(["file"], "no file chosen", "missing")])
                if upload.size is not None and upload.size > settings.max_upload_bytes:
                    raise PayloadTooLarge(f"The file has {upload.size} bytes; the limit is {settings.max_upload_bytes} bytes.")
                content = await upload.read()
                chosen = _with_units(_changed_options(options, defaults), units)
                submitted = await run_in_threadpool(
                    lambda: service.submit_upload(kind, upload.filename, content, chosen, None, owner=who.owner))
            else:
                submitted = await run_in_threadpool(
                    lambda: service.submit_json(kind, body.encode(), None, owner=who.owner))
        except ProblemError as error:
            problem = error.to_problem(instance=str(request.url.path))
            sent = {"options": options} if source == "upload" else {"body": body}  # the other form keeps its example
            sent["source"] = source
            sent["units"] = units
            return _with_headers(_page(request, "submit.html", error.status,
                                       **_form_context(request, spec, problem=problem, **sent)), error)
        return RedirectResponse(f"/dashboard/jobs/{submitted.job.id}", status_code=303)

    return router


def _submit_again(service: JobService, job_id: uuid.UUID, who: Any) -> Any:
    job = service.get(job_id, who.sees)
    if not is_finished(job.status):
        raise Conflict(f"Job {job_id} is still {job.status}: re-run it once it has finished.")
    if job.input_kind == "upload":
        content = service.input_file(job).read()
        options = json.dumps(job.input_options) if job.input_options else None
        return service.submit_upload(job.kind, job.input_filename, content, options, None, owner=who.owner)
    body = service.input_file(job).read() if job.input_kind == "json_file" else json.dumps(job.input).encode()
    return service.submit_json(job.kind, body, None, owner=who.owner)


def _changed_options(options: str, defaults: str) -> str | None:
    """The options text to submit: only the options that differ from the kind's defaults, so that a
    default never silently overrides an uploaded JSON file's own option. Text that is not a JSON object goes on
    as it is, for the intake to refuse naming the field."""
    if not options.strip():
        return None
    try:
        sent, before = json.loads(options), json.loads(defaults) if defaults.strip() else None
    except json.JSONDecodeError:
        return options
    if not isinstance(sent, dict) or not isinstance(before, dict):
        return options
    changed = views.changed_options(sent, before)
    return json.dumps(changed) if changed else None


def _with_units(options: str | None, units: str) -> str | None:
    """The options text with the form's result unit (the request's ``units``) among them, where their readers take
    it; left out, the kind's default applies (and the upload's report says the default was taken). A ``units`` in
    the options text that names another unit is a contradiction: refused naming both."""
    if not units:
        return options
    try:
        sent = json.loads(options) if options else {}
    except json.JSONDecodeError:
        return options  # the intake refuses it, naming the field
    if not isinstance(sent, dict):
        return options
    if sent.get("units", units) != units:
        raise Unprocessable("The result unit is given twice.", errors=[field_problem(
            ["units"], f"the form's result unit is {units!r}, the options say {sent['units']!r}: choose one",
            "value_error")])
    return json.dumps({**sent, "units": units})


def _form_context(request: Request, spec: SolverSpec, **values: Any) -> dict[str, Any]:
    """The submit page: the JSON form prefilled with the kind's example; the upload form's options at their
    defaults (what the kind does with none sent: an uploaded request file's own options are not contradicted by
    values nobody typed) and the schema its fields are generated from."""
    example = spec.example() if spec.example is not None else None
    defaults = views.option_defaults(spec)
    context = {
        "spec": spec,
        "token": _token_for(request),
        "problem": None,
        "options": views.pretty(defaults),
        # what the kind does anyway: an option left at its default is not sent (see _changed_options)
        "option_defaults": json.dumps(defaults),
        "options_schema": views.options_schema(spec),
        "units_choices": views.upload_units(spec),
        "units": "",
        "body": views.pretty(example) if example is not None else "",
    }
    return {**context, **values}
