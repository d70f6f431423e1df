"""API keys and tenants, checked before any body is read.

With ``API_KEYS`` set, every ``/v1`` call, ``/metrics``, the dashboard and (with ``PROTECT_DOCS``) the docs need
``Authorization: Bearer <key>``; a browser may instead log in at ``/dashboard/login``, which sets
an HTTP-only, same-site cookie honoured for reads (GET/HEAD) and for the dashboard's own forms
(POST under ``/dashboard/``), never for a ``/v1`` write. A dashboard form must also carry the token
:func:`form_token` derives from the key (a page of another site cannot know it) and must not come
from another site (``Sec-Fetch-Site``); the cookie is ``SameSite=Strict`` besides. Each key is a tenant: an entry ``name:key`` names it, a bare ``key`` is
named by the first 16 hex digits of its SHA-256. Jobs belong to the tenant that created them; keys
in ``ADMIN_KEYS`` see every tenant's jobs. Without keys there is one anonymous tenant (``""``).
"""

from __future__ import annotations

import hashlib
import hmac
import ipaddress
import logging
from dataclasses import dataclass

from fastapi import Request
from fastapi.responses import RedirectResponse
from starlette.types import ASGIApp, Receive, Scope, Send

from plantsolve.app.problems import Unauthorized, problem_response

log = logging.getLogger("plantsolve.api")

COOKIE = "plantsolve_key"
DOCS = ("/docs", "/redoc", "/openapi.json")


@dataclass(frozen=True)
class Principal:
    owner: str  # the tenant: "" when the service runs without keys
    admin: bool  # sees every tenant's jobs
    authenticated: bool  # a valid key was presented (or no keys are configured)

    @property
    def sees(self) -> str | None:
        """The owner filter for reads: None sees all."""
        return None if self.admin else self.owner


ANONYMOUS = Principal(owner="", admin=True, authenticated=True)
NOBODY = Principal(owner="", admin=False, authenticated=False)


def _entry(entry: str) -> tuple[str, str]:
    name, sep, key = entry.partition(":")
    if sep and name and key:
        return name[:64], key
    return hashlib.sha256(entry.encode()).hexdigest()[:16], entry


class KeyRing:
    def __init__(self, api_keys: list[str], admin_keys: list[str]):
        self.entries = [(*_entry(e), False) for e in api_keys] + [(*_entry(e), True) for e in admin_keys]

    def __bool__(self) -> bool:
        return bool(self.entries)

    def find(self, token: str) -> Principal | None:
        found = None
        for owner, key, admin in self.entries:  # compare with every key: no early exit to time
            if hmac.compare_digest(token.encode(), key.encode()):
                found = Principal(owner=owner, admin=admin, authenticated=True)
        return found


def _token(scope: Scope) -> str | None:
    headers = dict(scope.get("headers") or [])
    header = headers.get(b"authorization", b"").decode("latin-1")
    scheme, _, token = header.partition(" ")
    if scheme.lower() == "bearer" and token.strip():
        return token.strip()
    if scope.get("method") in ("GET", "HEAD") or dashboard_form(scope):
        for part in headers.get(b"cookie", b"").decode("latin-1").split(";"):
            name, _, value = part.strip().partition("=")
            if name == COOKIE and value:
                return value
    return None


def dashboard_form(scope: Scope) -> bool:
    """A POST of one of the dashboard's forms (the login form needs no key)."""
    path = scope.get("path", "")
    return scope.get("method") == "POST" and path.startswith("/dashboard/") and not path.startswith("/dashboard/log")


def form_token(key: str) -> str:
    """The anti-forgery token of the dashboard's forms for a browser logged in with ``key``:
    stateless (any API process can check it) and unknowable without the key."""
    return hmac.new(key.encode(), b"plantsolve dashboard form", hashlib.sha256).hexdigest()


def cookie_key(request: Request) -> str | None:
    """The key of the login cookie, when the caller is authenticated by it (not by a header)."""
    if request.headers.get("authorization"):
        return None
    return request.cookies.get(COOKIE) or None


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False  # a host name other than localhost: reachable from elsewhere


def warn_if_exposed(host: str, keys: KeyRing) -> bool:
    """Log a warning when the service answers on a non-loopback address without API keys. ``plantsolve serve``
    may call it with its --host at start; the auth middleware calls it with the server address of each request
    until one arrives on a non-loopback address (a published port), then warns once."""
    if keys or is_loopback(host):
        return False
    log.warning("API_KEYS is empty and the service answers on %s: anyone who can reach it can submit, read and "
                "cancel every job. Set API_KEYS (and ADMIN_KEYS), or bind to 127.0.0.1.", host)
    return True


class AuthMiddleware:
    """Resolves the caller before the route (and before any body is read) and refuses protected paths."""

    def __init__(self, app: ASGIApp, keys: KeyRing, protect_docs: bool):
        self.app, self.keys, self.protect_docs = app, keys, protect_docs
        self._warned = False  # once per process
        self._loopback: set[str] = set()  # server addresses seen to be loopback (a health check's, say)

    def protected(self, path: str) -> bool:
        if path.startswith("/v1/") or path == "/v1" or path == "/metrics":
            return True
        if path == "/dashboard" or (path.startswith("/dashboard/") and not path.startswith("/dashboard/log")):
            return True
        return self.protect_docs and path.startswith(DOCS)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        if not self.keys:
            if not self._warned:  # the server's own address as this request reached it: loopback, or exposed?
                server = scope.get("server")
                if server and server[0] not in self._loopback:
                    if warn_if_exposed(str(server[0]), self.keys):
                        self._warned = True
                    else:
                        self._loopback.add(server[0])
            principal = ANONYMOUS
        else:
            token = _token(scope)
            principal = self.keys.find(token) if token else None
            path = scope.get("path", "")
            if principal is None and path == "/dashboard" and token is None:
                await RedirectResponse("/dashboard/login", status_code=303)(scope, receive, send)  # a browser
                return
            if principal is None and self.protected(path):
                detail = "Send 'Authorization: Bearer <key>'." if token is None else "The API key is not valid."
                await problem_response(Unauthorized(detail))(scope, receive, send)
                return
            principal = principal or NOBODY
        scope.setdefault("state", {})["principal"] = principal
        await self.app(scope, receive, send)


def principal(request: Request) -> Principal:
    return getattr(request.state, "principal", ANONYMOUS)


async def require_api_key(request: Request) -> Principal:
    """Route dependency: the caller (the middleware has already refused unknown keys). Async
    because it never blocks: FastAPI would run a plain function in a worker thread, one thread
    hop per request for nothing."""
    who = principal(request)
    if not who.authenticated:
        raise Unauthorized("Send 'Authorization: Bearer <key>'.")
    return who
