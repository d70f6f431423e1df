"""Request-body size limit, enforced before the body is read whole; security headers on every answer.

A declared ``Content-Length`` above the limit is refused at once; a body without one (chunked)
is counted as it streams and refused as soon as it passes the limit.
"""

from __future__ import annotations

import base64
import hashlib
import re

from starlette.datastructures import MutableHeaders
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from plantsolve.app.problems import PayloadTooLarge, problem_response


class BodyLimitMiddleware:
    def __init__(self, app: ASGIApp, max_bytes: int):
        self.app = app
        self.max_bytes = max_bytes

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        limit = self.max_bytes
        declared = dict(scope.get("headers") or []).get(b"content-length")
        if declared is not None:
            try:
                too_large = int(declared) > limit
            except ValueError:
                too_large = False
            if too_large:
                response = problem_response(
                    PayloadTooLarge(f"The body declares {int(declared)} bytes; the limit is {limit} bytes.")
                )
                await response(scope, receive, send)
                return
        received = 0

        async def counting_receive() -> Message:
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > limit:
                    raise PayloadTooLarge(f"The body passed the limit of {limit} bytes.")
            return message

        await self.app(scope, counting_receive, send)


# ---- security headers -----------------------------------------------------------------------------------

# The pages' own policy: scripts only from this origin (the dashboard's dashboard.js, the docs' packaged
# bundles); styles may also be inline (the progress bars' widths are style attributes, ReDoc writes <style>
# elements); images and workers also from data:/blob: URLs (Swagger UI's icons, ReDoc's search worker);
# nothing may frame a page, no plugin runs, forms post only here.
PAGE_POLICY = ("default-src 'self'; script-src 'self'{scripts}; style-src 'self' 'unsafe-inline'; "
               "img-src 'self' data: blob:; font-src 'self' data:; connect-src 'self'; worker-src 'self' blob:; "
               "object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'")
# an SVG artifact opened on its own is a document too: it runs nothing
SVG_POLICY = "default-src 'none'; style-src 'unsafe-inline'; img-src data:; sandbox"
INLINE_SCRIPT = re.compile(rb"<script>(.*?)</script>", re.DOTALL | re.IGNORECASE)


class SecurityHeadersMiddleware:
    """Every answer carries ``X-Content-Type-Options: nosniff``; every HTML page (dashboard, docs, errors)
    also ``Content-Security-Policy``, ``X-Frame-Options: DENY`` and ``Referrer-Policy: no-referrer``.

    The pages named in ``inline_script_paths`` (Swagger UI's, whose bootstrap script FastAPI writes inline)
    get the SHA-256 of each of their inline scripts in ``script-src``: those pages are made from the app's
    configuration alone (nothing of the request is echoed into them), so the hash admits exactly the script
    the service wrote, where ``'unsafe-inline'`` would admit an injected one too. Every other page runs
    no inline script at all."""

    def __init__(self, app: ASGIApp, inline_script_paths: tuple[str, ...] = ("/docs", "/docs/oauth2-redirect")):
        self.app, self.inline_script_paths = app, inline_script_paths

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        hashed = scope.get("path") in self.inline_script_paths
        start: Message | None = None
        body: list[bytes] = []

        async def sending(message: Message) -> None:
            nonlocal start
            if message["type"] == "http.response.start":
                headers = MutableHeaders(scope=message)
                headers["X-Content-Type-Options"] = "nosniff"
                media = headers.get("content-type", "").split(";")[0].strip().lower()
                if media == "image/svg+xml":
                    headers["Content-Security-Policy"] = SVG_POLICY
                if media != "text/html":
                    hashed_html = False
                else:
                    headers["X-Frame-Options"] = "DENY"
                    headers["Referrer-Policy"] = "no-referrer"
                    hashed_html = hashed
                    if not hashed:
                        headers["Content-Security-Policy"] = PAGE_POLICY.format(scripts="")
                if hashed_html:  # held back until the body (a small page) has been seen
                    start = message
                    return
            elif message["type"] == "http.response.body" and start is not None:
                body.append(message.get("body", b""))
                if message.get("more_body", False):
                    return
                page = b"".join(body)
                hashes = "".join(f" 'sha256-{base64.b64encode(hashlib.sha256(script).digest()).decode()}'"
                                 for script in INLINE_SCRIPT.findall(page))
                MutableHeaders(scope=start)["Content-Security-Policy"] = PAGE_POLICY.format(scripts=hashes)
                await send(start)
                await send({"type": "http.response.body", "body": page, "more_body": False})
                return
            await send(message)

        await self.app(scope, receive, sending)
