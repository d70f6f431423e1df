"""The one middleware every request passes: request id, security headers, CORS (when configured), the caller,
the body limit, and the lean path of the hot routes.

Each of these was its own ASGI middleware; folded into one layer, a request pays for one wrapper of ``send``
and one scan of its headers instead of five. The order of the checks is the order of the layers it replaces
(outermost first):

1. **request id** (as ``asgi_correlation_id`` did): the caller's ``X-Request-ID`` when it is a UUID, else a new
   one; set for the log lines (:data:`correlation_id`), written back into the request's headers and onto every
   answer, refusals included;
2. **security headers** (:func:`~plantsolve.app.middleware.secured`) on every answer;
3. **CORS** (Starlette's middleware, only with ``CORS_ORIGINS``): outside the caller check, so a preflight needs
   no key;
4. **the caller** (:class:`~plantsolve.app.auth.AuthMiddleware`): refused (401) or redirected to the login
   page before any body is read;
5. **the body limit**: a declared ``Content-Length`` above ``MAX_BODY_BYTES`` is a 413 at once, a streamed body
   is counted as it arrives;
6. the hot routes, ``POST /v1/<kind>/jobs`` with a JSON body and ``GET /v1/jobs/{id}``, answered by
   :mod:`plantsolve.app.jobs.lean` without the router (whose route matching and dependency solving cost more
   than the database work); every other request goes on to the app.

A crash in a lean route propagates exactly as from a route: a problem error is rendered by the app's handler for
its class. An infrastructure failure (an unreachable database, queue or file store) raised by any route is
answered here, 503 with ``Retry-After`` and one log line (:func:`~plantsolve.app.problems.unavailable`): past this
layer Starlette's outermost error middleware would re-raise it to the server, which logs a full traceback per
request of an outage. Anything else reaches that middleware (500, with its traceback in the log).
"""

from __future__ import annotations

import logging
from uuid import UUID, uuid4

from asgi_correlation_id import correlation_id
from starlette.middleware.cors import CORSMiddleware
from starlette.requests import ClientDisconnect, Request
from starlette.types import ASGIApp, Receive, Scope, Send

from plantsolve.app.auth import AuthMiddleware, KeyRing
from plantsolve.app.jobs.lean import LeanRoutes
from plantsolve.app.middleware import declared_too_large, limited, secured, unsupported_encoding
from plantsolve.app.problems import problem_response, unavailable
from plantsolve.jobs.errors import is_infrastructure_failure

REQUEST_ID = b"x-request-id"
log = logging.getLogger("asgi_correlation_id")  # the logger (and message) of the middleware this replaces
log_disconnect = logging.getLogger("plantsolve.api")


def valid_request_id(value: str) -> bool:
    """What the caller may choose as request id: any UUID spelling Python reads (32 hex digits with or without
    dashes), as ``asgi_correlation_id`` accepted."""
    try:
        return bool(UUID(value, version=4))
    except ValueError:
        return False


class EdgeMiddleware:
    def __init__(self, app: ASGIApp, *, keys: KeyRing, protect_docs: bool, max_body_bytes: int,
                 cors_origins: list[str], lean: LeanRoutes | None = None, body_idle_seconds: float = 30.0):
        self.app = app
        self.max_body_bytes = max_body_bytes
        self.body_idle_seconds = body_idle_seconds
        self.auth = AuthMiddleware(None, keys=keys, protect_docs=protect_docs)
        self.lean = lean
        self.entry: ASGIApp = self.guarded
        if cors_origins:
            self.entry = CORSMiddleware(self.guarded, allow_origins=cors_origins, allow_methods=["GET", "POST"],
                                        allow_headers=["Authorization", "Content-Type", "Idempotency-Key", "X-Request-ID"],
                                        expose_headers=["Location", "X-Request-ID"])

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        request_id = self._request_id(scope)
        correlation_id.set(request_id)
        header = (REQUEST_ID, request_id.encode("latin-1"))
        started = False

        async def identified(message) -> None:
            nonlocal started
            if message["type"] == "http.response.start":
                message["headers"] = [*message.get("headers", ()), header]
                started = True
            await send(message)

        try:
            await self.entry(scope, receive, secured(scope, identified))
        except ClientDisconnect:  # the client left before its body was read: nobody to answer, nothing went wrong
            log_disconnect.info("%s %s: the client disconnected before its body was read", scope["method"],
                                scope.get("path", ""))
        except Exception as error:
            if started or not is_infrastructure_failure(error):
                raise
            response = problem_response(unavailable(error, scope.get("path", "")))
            await response(scope, receive, secured(scope, identified))

    @staticmethod
    def _request_id(scope: Scope) -> str:
        headers = scope["headers"]
        given = next((value for name, value in headers if name.lower() == REQUEST_ID), None)
        if given and valid_request_id(given.decode("latin-1")):
            return given.decode("latin-1")
        request_id = uuid4().hex
        if given:
            log.warning("Generated new request ID (%s), since request header value failed validation", request_id)
        # downstream (an error handler, say) reads the id from the request as well
        scope["headers"] = [*(item for item in headers if item[0].lower() != REQUEST_ID), (REQUEST_ID, request_id.encode())]
        return request_id

    async def guarded(self, scope: Scope, receive: Receive, send: Send) -> None:
        principal = await self.auth.admit(scope, receive, send)
        if principal is None:  # refused: the answer has been sent
            return
        refusal = declared_too_large(next((v for k, v in scope["headers"] if k.lower() == b"content-length"), None),
                                     self.max_body_bytes) or unsupported_encoding(scope["headers"])
        if refusal is not None:
            await problem_response(refusal)(scope, receive, send)
            return
        receive = limited(receive, self.max_body_bytes, self.body_idle_seconds)
        route = self.lean.match(scope) if self.lean is not None else None
        if route is None:
            await self.app(scope, receive, send)
            return
        try:
            await route(scope, receive, send, principal)
        except Exception as error:
            handler = self._handler(scope, error)
            if handler is None:
                raise  # to Starlette's outermost error middleware, as from any route
            await (await handler(Request(scope, receive), error))(scope, receive, send)

    @staticmethod
    def _handler(scope: Scope, error: Exception):
        """The app's handler for ``error``'s class, as the router's exception middleware looks it up (the handler
        of ``Exception`` belongs to the outermost error middleware)."""
        handlers = scope["app"].exception_handlers
        for cls in type(error).__mro__:
            if cls is Exception:
                return None
            if cls in handlers:
                return handlers[cls]
        return None
