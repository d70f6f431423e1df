"""API keys and tenants, checked before any body is read; the dashboard's login sessions.

With ``API_KEYS`` set, every ``/v1`` call, ``/metrics``, the dashboard and (with ``PROTECT_DOCS``) the docs need
``Authorization: Bearer <key>``; a browser may instead log in at ``/dashboard/login``. Each key is a tenant: an
entry ``name:key`` names it, a bare ``key`` is named by the first 16 hex digits of its SHA-256. Jobs belong to
the tenant that created them; keys in ``ADMIN_KEYS`` see every tenant's jobs. Without keys there is one
anonymous tenant (``""``).

A login opens a server-side session (:class:`Sessions`): the cookie holds a random token (never the key), the
database its SHA-256 with an expiry (``SESSION_SECONDS``); logging out deletes the row, so a copied cookie
is dead from then on, and removing a key from ``API_KEYS`` ends its sessions. The cookie is HTTP-only,
``SameSite=Strict`` (``Secure`` over https) and honoured for reads (GET/HEAD) and for the dashboard's own
forms (POST under ``/dashboard/``), never for a ``/v1`` write. A dashboard form must also carry the token
:func:`form_token` derives from the session (a page of another site cannot know it) and must not come from
another site (``Sec-Fetch-Site``). The login form itself carries a CSRF token the server issued
(:class:`LoginTokens`: signed with a server secret and dated, so a token a page of another site makes up is
refused, cookie or not), which must also match the login cookie set with it; an address with
``LOGIN_FAILURES`` failed logins within ``LOGIN_WINDOW_SECONDS`` is answered 429 with ``Retry-After`` until
the oldest of them leaves the window (counted in the database: every API process sees the same count). The
address is the connection's peer, or what a proxy named in ``FORWARDED_ALLOW_IPS`` says it is: a header
from anyone else cannot choose the key it is counted under.
"""

from __future__ import annotations

import hashlib
import hmac
import ipaddress
import logging
import math
import secrets
import time
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone

from fastapi import Request
from fastapi.responses import RedirectResponse
from starlette.concurrency import run_in_threadpool
from starlette.types import ASGIApp, Receive, Scope, Send

from plantsolve.app.problems import Unauthorized, problem_response

log = logging.getLogger("plantsolve.api")

COOKIE = "plantsolve_session"  # the session token (the former plantsolve_key cookie held the key: no longer read)
LOGIN_COOKIE = "plantsolve_login"  # the login form's CSRF token, sent back with the form
DOCS = ("/docs", "/redoc", "/openapi.json")
PUBLIC_ASSETS = "/dashboard-static/"  # the dashboard's style and script: no session is looked up for them
SESSION_SECONDS = 8 * 3600.0  # a session's lifetime from login (absolute: a working day)
LOGIN_FAILURES = 10  # failed logins of one client address ...
LOGIN_WINDOW_SECONDS = 60.0  # ... within this sliding window, before it is answered 429
LOGIN_FORM_SECONDS = 3600  # how long a login form's CSRF token is honoured


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

    def find_hash(self, key_hash: str) -> Principal | None:
        """The tenant of the key whose :func:`digest` is ``key_hash`` (a session's key), if it is still configured."""
        found = None
        for owner, key, admin in self.entries:
            if hmac.compare_digest(digest(key).encode(), key_hash.encode()):
                found = Principal(owner=owner, admin=admin, authenticated=True)
        return found


def digest(secret: str) -> str:
    """SHA-256 hex: what the database keeps of a session token or of the key behind it."""
    return hashlib.sha256(secret.encode()).hexdigest()


class Sessions:
    """The dashboard's server-side sessions and the login rate limit, over the store's session table
    (reached as ``store.sessions``: the app does not import the store). Blocking calls: run them off
    the event loop."""

    def __init__(self, table, keys: KeyRing, lifetime_seconds: float = SESSION_SECONDS,
                 failures: int = LOGIN_FAILURES, window_seconds: float = LOGIN_WINDOW_SECONDS):
        self.table, self.keys = table, keys
        self.lifetime_seconds, self.failures, self.window_seconds = lifetime_seconds, failures, window_seconds

    def open(self, key: str) -> str:
        """A new session for a valid ``key``: the token for the cookie (256 random bits)."""
        token = secrets.token_urlsafe(32)
        now = datetime.now(timezone.utc)
        self.table.open(digest(token), digest(key), now, now + timedelta(seconds=self.lifetime_seconds))
        return token

    def principal(self, token: str) -> Principal | None:
        """Who an open, unexpired session is, while its key is still configured; else None."""
        key_hash = self.table.key_of(digest(token), datetime.now(timezone.utc))
        return self.keys.find_hash(key_hash) if key_hash else None

    def close(self, token: str) -> bool:
        return self.table.close(digest(token))

    def retry_after(self, address: str) -> int | None:
        """Seconds until ``address`` may try to log in again, or None when it may now."""
        now = datetime.now(timezone.utc)
        count, oldest = self.table.failures_since(address, now - timedelta(seconds=self.window_seconds))
        if count < self.failures or oldest is None:
            return None
        return max(1, math.ceil(self.window_seconds - (now - oldest).total_seconds()))

    def failed(self, address: str) -> None:
        now = datetime.now(timezone.utc)
        self.table.record_failure(address, now, now - timedelta(seconds=self.window_seconds))


class LoginTokens:
    """The login form's CSRF tokens: ``<issued>-<nonce>-<HMAC-SHA256>`` (hex digits and dashes), made and checked with a server secret,
    so a token is one this service issued (within ``lifetime_seconds``) and nothing a client chose. Stateless:
    every API process with the same secret checks the others' tokens."""

    def __init__(self, secret: bytes, lifetime_seconds: float = LOGIN_FORM_SECONDS):
        self.secret, self.lifetime_seconds = secret, lifetime_seconds

    @classmethod
    def for_settings(cls, login_secret: str | None, api_keys: list[str], admin_keys: list[str]) -> "LoginTokens":
        """``LOGIN_SECRET``, else a key derived from the configured API keys (shared by every API process; a
        client that does not hold them all cannot derive it)."""
        if login_secret:
            return cls(login_secret.encode())
        keys = "\0".join(sorted([*api_keys, *admin_keys]))
        return cls(hashlib.sha256(b"plantsolve login form\0" + keys.encode()).digest())

    def _signature(self, body: str) -> str:
        return hmac.new(self.secret, body.encode(), hashlib.sha256).hexdigest()

    def issue(self) -> str:
        body = f"{int(time.time())}-{secrets.token_hex(16)}"
        return f"{body}-{self._signature(body)}"

    def valid(self, token: str) -> bool:
        body, _, signature = token.rpartition("-")
        issued, _, nonce = body.partition("-")
        if not (issued.isdigit() and nonce and signature):
            return False
        if not hmac.compare_digest(signature.encode(), self._signature(body).encode()):
            return False
        return 0 <= time.time() - int(issued) <= self.lifetime_seconds


def _credentials(scope: Scope) -> tuple[str | None, str | None]:
    """(the bearer key, the session token of the cookie where it is honoured): at most one of them."""
    headers = dict(scope.get("headers") or [])
    header = headers.get(b"authorization", b"").decode("latin-1")
    scheme, _, token = header.partition(" ")
    if scheme.lower() == "bearer" and token.strip():
        return token.strip(), None
    if scope.get("method") in ("GET", "HEAD") or dashboard_form(scope):
        for part in headers.get(b"cookie", b"").decode("latin-1").split(";"):
            name, _, value = part.strip().partition("=")
            if name == COOKIE and value:
                return None, value
    return None, None


def dashboard_form(scope: Scope) -> bool:
    """A POST of one of the dashboard's forms (the login form needs no key)."""
    path = scope.get("path", "")
    return scope.get("method") == "POST" and path.startswith("/dashboard/") and not path.startswith("/dashboard/log")


def form_token(session: str) -> str:
    """The anti-forgery token of the dashboard's forms for a browser with the session token ``session``:
    stateless (any API process can check it) and unknowable without the cookie."""
    return hmac.new(session.encode(), b"plantsolve dashboard form", hashlib.sha256).hexdigest()


def cookie_key(request: Request) -> str | None:
    """The session token of the login cookie, when the caller is authenticated by it (not by a header).
    (The name is historical: the cookie no longer holds the key.)"""
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

    def __init__(self, app: ASGIApp | None, keys: KeyRing, protect_docs: bool):
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
        if await self.admit(scope, receive, send) is not None:
            await self.app(scope, receive, send)

    async def admit(self, scope: Scope, receive: Receive, send: Send) -> Principal | None:
        """The caller of an HTTP request, also put in ``scope["state"]["principal"]``; None when the request was
        refused (or redirected to the login page): then the answer has been sent."""
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
            key, session = _credentials(scope)
            token = key or session
            if key:
                principal = self.keys.find(key)
            elif session and not scope.get("path", "").startswith(PUBLIC_ASSETS):
                # one indexed read of the session table, off the event loop
                principal = await run_in_threadpool(scope["app"].state.sessions.principal, session)
            else:
                principal = None
            path = scope.get("path", "")
            if principal is None and path == "/dashboard" and key is None:  # no session, or one that has ended
                await RedirectResponse("/dashboard/login", status_code=303)(scope, receive, send)  # a browser
                return None
            if principal is None and self.protected(path):
                detail = ("Send 'Authorization: Bearer <key>'." if token is None else "The API key is not valid."
                          if key else "The dashboard session has ended: log in again.")
                await problem_response(Unauthorized(detail))(scope, receive, send)
                return None
            principal = principal or NOBODY
        scope.setdefault("state", {})["principal"] = principal
        return principal


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
