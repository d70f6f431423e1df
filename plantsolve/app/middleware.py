"""Request-body size limit, enforced before the body is read whole; security headers on every answer (both
applied by :class:`~plantsolve.app.edge.EdgeMiddleware`).

A declared ``Content-Length`` above the limit is refused at once; a body without one (chunked)
is counted as it streams and refused as soon as it passes the limit.
"""

from __future__ import annotations

import asyncio
import base64
import hashlib
import re

from starlette.datastructures import MutableHeaders
from starlette.types import Message, Receive, Scope, Send

from plantsolve.app.problems import PayloadTooLarge, RequestTimeout
from plantsolve.jobs.errors import UnsupportedMediaType, field_problem


def declared_too_large(declared: bytes | None, limit: int) -> PayloadTooLarge | None:
    """The 413 of a body whose ``Content-Length`` is above ``limit`` (None when it is not, or says nothing)."""
    if declared is None:
        return None
    try:
        too_large = int(declared) > limit
    except ValueError:
        return None
    return PayloadTooLarge(f"The body declares {int(declared)} bytes; the limit is {limit} bytes.") if too_large else None


def limited(receive: Receive, limit: int, idle_seconds: float) -> Receive:
    """``receive`` that counts the body as it streams and raises the 413 once it passes ``limit``, and the 408 when
    the next part of a body under way takes longer than ``idle_seconds`` (a client that stops half way, or declared
    more than it sends, would hold the connection and the request's memory for as long as it likes).
    Once the body is complete, ``receive`` waits unbounded again (a route listens for the client's disconnect)."""
    received = 0
    complete = False

    async def counting_receive() -> Message:
        nonlocal received, complete
        if complete:
            return await receive()
        try:
            async with asyncio.timeout(idle_seconds):
                message = await receive()
        except TimeoutError:
            raise RequestTimeout(f"No part of the request body arrived for {idle_seconds:g} s after {received} bytes; "
                                 "send the body without pauses (and no more bytes than Content-Length declares).") \
                from None
        if message["type"] == "http.request":
            received += len(message.get("body", b""))
            if received > limit:
                raise PayloadTooLarge(f"The body passed the limit of {limit} bytes.")
            complete = not message.get("more_body", False)
        return message

    return counting_receive


def unsupported_encoding(headers: list[tuple[bytes, bytes]]) -> UnsupportedMediaType | None:
    """The 415 of a body sent with a ``Content-Encoding`` (gzip, say): the service reads bodies as they are, so a
    compressed body would be read as garbage and refused naming the wrong thing, and a plain body labelled compressed
    would be taken while the label says otherwise."""
    for name, value in headers:
        if name.lower() == b"content-encoding":
            coding = value.decode("latin-1").strip().lower()
            if coding and coding != "identity":
                return UnsupportedMediaType(
                    f"Content-Encoding {coding!r} is not supported: send the body uncompressed.",
                    errors=[field_problem(["header", "Content-Encoding"], "send the body uncompressed")])
    return None


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
INLINE_SCRIPT_PATHS = ("/docs", "/docs/oauth2-redirect")  # Swagger UI's pages: FastAPI writes their bootstrap inline


NOSNIFF = (b"x-content-type-options", b"nosniff")
# a year; sent only on answers that came over TLS (a browser ignores it on http, and a plain-http deployment
# must not be told to refuse itself)
HSTS = (b"strict-transport-security", b"max-age=31536000")
NO_STORE = (b"cache-control", b"no-store")
# answers that may hold a tenant's data (pages, jobs, results, metrics): no shared cache, no disk cache keeps them
PRIVATE_PATHS = ("/dashboard/", "/v1/", "/metrics")


def _extra_headers(scope: Scope, raw: list[tuple[bytes, bytes]], media: bytes) -> list[tuple[bytes, bytes]]:
    """HSTS over TLS; ``Cache-Control: no-store`` on every page and every private answer that sets no cache
    policy of its own."""
    extra = []
    if scope.get("scheme") == "https":
        extra.append(HSTS)
    path = scope.get("path", "")
    if (media == b"text/html" or path == "/dashboard" or path.startswith(PRIVATE_PATHS)) \
            and not any(name.lower() == NO_STORE[0] for name, _ in raw):
        extra.append(NO_STORE)
    return extra


def secured(scope: Scope, send: Send, inline_script_paths: tuple[str, ...] = INLINE_SCRIPT_PATHS) -> Send:
    """``send`` with the security headers put on the answer's start. Every answer carries
    ``X-Content-Type-Options: nosniff``; every HTML page (dashboard, docs, errors) also ``Content-Security-Policy``, ``X-Frame-Options: DENY`` and ``Referrer-Policy: no-referrer``;
    every page and every answer under ``/v1/``, ``/dashboard`` and ``/metrics`` ``Cache-Control: no-store``
    (unless it sets a cache policy itself); every answer over https ``Strict-Transport-Security``.

    The pages named in ``inline_script_paths`` (Swagger UI's, whose bootstrap script FastAPI writes inline)
    get the SHA-256 of each of their inline scripts in ``script-src``: those pages are made from the app's
    configuration alone (nothing of the request is echoed into them), so the hash admits exactly the script
    the service wrote, where ``'unsafe-inline'`` would admit an injected one too. Every other page runs
    no inline script at all."""
    hashed = scope.get("path") in inline_script_paths
    start: Message | None = None
    body: list[bytes] = []

    async def sending(message: Message) -> None:
        nonlocal start
        if message["type"] == "http.response.start":
            raw = message.setdefault("headers", [])
            media = next((value for name, value in raw if name.lower() == b"content-type"), b"")
            media = media.split(b";")[0].strip().lower()
            extra = _extra_headers(scope, raw, media)
            if media not in (b"text/html", b"image/svg+xml") and not any(name.lower() == NOSNIFF[0] for name, _ in raw):
                # the common answer (JSON, files): headers appended to the raw list, no header object built
                message["headers"] = [*raw, NOSNIFF, *extra]
                await send(message)
                return
            message["headers"] = raw = [*raw, *extra]
            headers = MutableHeaders(scope=message)
            headers["X-Content-Type-Options"] = "nosniff"
            if media == b"image/svg+xml":
                headers["Content-Security-Policy"] = SVG_POLICY
            if media != b"text/html":
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

    return sending
