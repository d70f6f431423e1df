"""A small server-rendered dashboard: job counts and the latest jobs, refreshed every 5 s."""

from __future__ import annotations

from html import escape

from fastapi import APIRouter, Depends, Request
from fastapi.responses import HTMLResponse

from plantsolve.app.auth import require_api_key
from plantsolve.store.repository import as_utc

_STYLE = """
body{font-family:system-ui,sans-serif;margin:2rem;color:#222}
table{border-collapse:collapse;width:100%}td,th{padding:.3rem .6rem;border-bottom:1px solid #ddd;text-align:left}
.succeeded{color:#17692c}.failed{color:#b00020}.running{color:#0b5cad}.cancelled{color:#777}
.counts span{margin-right:1.5rem}code{font-size:.85em}
"""


def build_dashboard() -> APIRouter:
    router = APIRouter(include_in_schema=False, dependencies=[Depends(require_api_key)])

    @router.get("/dashboard", response_class=HTMLResponse)
    def dashboard(request: Request, kind: str | None = None, status: str | None = None) -> HTMLResponse:
        ctx = request.app.state.ctx
        counts = ctx.repo.count_by_status()
        jobs = ctx.repo.list(kind=kind or None, status=status or None, limit=50)
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
