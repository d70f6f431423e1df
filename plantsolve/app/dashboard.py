"""A small server-rendered dashboard: job counts and the latest jobs, refreshed every 5 s."""

from __future__ import annotations

from html import escape

from fastapi import APIRouter, Depends, Form, Request
from fastapi.responses import HTMLResponse, RedirectResponse

from plantsolve.app.auth import COOKIE, Principal, principal, require_api_key
from plantsolve.store.repository import as_utc

_STYLE = """
body{font-family:system-ui,sans-serif;margin:2rem;color:#222}
table{border-collapse:collapse;width:100%}td,th{padding:.3rem .6rem;border-bottom:1px solid #ddd;text-align:left}
.succeeded{color:#17692c}.failed{color:#b00020}.running{color:#0b5cad}.cancelled{color:#777}
.counts span{margin-right:1.5rem}code{font-size:.85em}
"""


_LOGIN = """<!doctype html><html><head><meta charset='utf-8'><title>plantsolve: log in</title><style>{style}</style>
</head><body><h1>plantsolve</h1><form method='post' action='/dashboard/login'><p>{message}</p>
<label>API key <input type='password' name='key' autocomplete='current-password' autofocus></label>
<button type='submit'>Log in</button></form></body></html>"""


def build_dashboard() -> APIRouter:
    router = APIRouter(include_in_schema=False)

    @router.get("/dashboard/login", response_class=HTMLResponse)
    def login_form() -> HTMLResponse:
        return HTMLResponse(_LOGIN.format(style=_STYLE, message="This service needs an API key."))

    @router.post("/dashboard/login")
    def login(request: Request, key: str = Form(default="", max_length=512)) -> HTMLResponse:
        keys = request.app.state.keys
        if keys and keys.find(key) is None:
            return HTMLResponse(_LOGIN.format(style=_STYLE, message="That key is not valid."), status_code=401)
        response = RedirectResponse("/dashboard", status_code=303)
        # HTTP-only and same-site: scripts cannot read it, other sites cannot send it; reads only (see auth)
        response.set_cookie(COOKIE, key, httponly=True, samesite="strict", secure=request.url.scheme == "https",
                            path="/")
        return response

    @router.post("/dashboard/logout")
    def logout() -> RedirectResponse:
        response = RedirectResponse("/dashboard/login", status_code=303)
        response.delete_cookie(COOKIE, path="/")
        return response

    @router.get("/dashboard", response_class=HTMLResponse, dependencies=[Depends(require_api_key)])
    def dashboard(request: Request, kind: str | None = None, status: str | None = None) -> HTMLResponse:
        ctx = request.app.state.ctx
        who: Principal = principal(request)
        counts = ctx.repo.count_by_status(owner=who.sees)
        jobs = ctx.repo.list(kind=kind or None, status=status or None, limit=50, owner=who.sees)
        rows = []
        for job in jobs:
            created = as_utc(job.created_at).strftime("%Y-%m-%d %H:%M:%S")
            run = f"{job.run_seconds:.2f} s" if job.run_seconds is not None else ""
            message = (job.report or {}).get("message") or job.progress_message or ""
            link = f"/v1/jobs/{job.id}"
            rows.append(
                f"<tr><td><a href='{link}'><code>{job.id}</code></a></td><td>{escape(job.kind)}</td>"
                f"<td class='{job.status}'>{job.status}</td><td>{job.progress:.0%}</td><td>{job.attempt}/{job.max_attempts}</td>"
                f"<td>{created}</td><td>{run}</td><td>{escape(message[:160])}</td>"
                f"<td>{'<a href=' + chr(39) + link + '/result' + chr(39) + '>result</a>' if job.status == 'succeeded' else ''}</td></tr>"
            )
        count_html = "".join(f"<span class='{s}'>{s}: <b>{counts.get(s, 0)}</b></span>" for s in ("queued", "running", "succeeded", "failed", "cancelled"))
        page = f"""<!doctype html><html><head><meta charset='utf-8'><meta http-equiv='refresh' content='5'>
<title>plantsolve jobs</title><style>{_STYLE}</style></head><body>
<h1>plantsolve</h1><p class='counts'>{count_html}</p>
<p>Mode: {'embedded (in-process pool)' if ctx.settings.embedded else 'scaled (Celery)'} · <a href='/docs'>API docs</a></p>
<table><tr><th>job</th><th>kind</th><th>status</th><th>progress</th><th>attempt</th><th>created (UTC)</th><th>run</th><th>message</th><th></th></tr>
{''.join(rows) or "<tr><td colspan='9'>No jobs yet.</td></tr>"}</table></body></html>"""
        return HTMLResponse(page)

    return router
