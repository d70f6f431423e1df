"""The completion webhook: ``POST <callback_url>`` with the job view once the job has finished.

A submission may name ``?callback_url=``; the job row keeps it with a delivery state. A notifier
thread in every API process looks for finished jobs whose delivery is due, takes one delivery with a
conditional update (so two API processes never both send it; a lease lets another take over if this
one dies mid-delivery), and sends it from a small thread pool: the job runners never wait for a
receiver. A delivery that fails (no 2xx, a timeout, a refused connection) is retried after
``WEBHOOK_RETRY_SECONDS``, doubled each time, up to ``WEBHOOK_MAX_ATTEMPTS``; the job view shows
how it went (``callback``).

Each delivery is signed per the Standard Webhooks specification (standardwebhooks.com), so that a
receiver can refuse a captured delivery sent again: ``webhook-id`` (``msg_<job id hex>``, the same on
every attempt, for the receiver's de-duplication), ``webhook-timestamp`` (Unix seconds of this attempt)
and ``webhook-signature: v1,<base64 HMAC-SHA256 of "{id}.{timestamp}.{body}">``. The signature is made
by the ``standardwebhooks`` package. The key is the tenant's secret: its ``WEBHOOK_SECRETS`` entry
(``whsec_<base64>`` as the spec writes secrets: the key is the decoded bytes; any other text is used as
its UTF-8 bytes), else derived from its API key as ``HMAC-SHA256(key=<API key>, msg="plantsolve-webhook")``
(32 bytes; ``plantsolve.client.webhook_secret(key)`` gives it as ``whsec_...``). The former
``X-Plantsolve-Signature`` (body only, replayable) is no longer sent.

Targets inside the service's network (loopback, private, link-local, cloud metadata ...) are refused
unless ``WEBHOOK_PRIVATE_TARGETS``: at submission, in every spelling a resolver accepts (``2130706433``,
``0177.0.0.1``, ``0x7f.1``, ``127.1``, ``[::ffff:127.0.0.1]``, ``localhost.``, a name that resolves inside
now), and at delivery by :class:`PinnedTransport`, which resolves the host once, checks every address,
and connects to a checked one (the Host header and TLS name stay the URL's), so a name that changes its
answer between check and connect (DNS rebinding) reaches no inside address. A refused delivery is not
retried.
"""

from __future__ import annotations

import base64
import binascii
import hashlib
import hmac
import ipaddress
import logging
import socket
import ssl
import threading
import uuid
from concurrent.futures import ThreadPoolExecutor
from concurrent.futures import TimeoutError as FutureTimeout
from datetime import datetime, timedelta, timezone
from urllib.parse import urlsplit

import httpcore
import httpx
from standardwebhooks import Webhook

from plantsolve.app.auth import KeyRing
from plantsolve.jobs.errors import NotFound, Unprocessable, field_problem, is_infrastructure_failure

log = logging.getLogger("plantsolve.webhooks")

SECRET_PREFIX = "whsec_"
DERIVATION_MESSAGE = b"plantsolve-webhook"
LEASE_SECONDS = 120.0  # one delivery's claim: longer than its timeout


def derived_secret(api_key: str) -> bytes:
    """The signing key of a tenant that has no WEBHOOK_SECRETS entry (raw bytes)."""
    return hmac.new(api_key.encode(), DERIVATION_MESSAGE, hashlib.sha256).digest()


def secret_bytes(text: str) -> bytes:
    """The signing key a WEBHOOK_SECRETS value stands for: ``whsec_<base64>`` decoded (as the spec
    writes secrets), any other text as its UTF-8 bytes (secrets set before the spec was followed)."""
    if text.startswith(SECRET_PREFIX):
        try:
            return base64.b64decode(text[len(SECRET_PREFIX):], validate=True)
        except binascii.Error as bad:
            raise ValueError(f"WEBHOOK_SECRETS: a whsec_ secret must be base64 ({bad})") from None
    return text.encode()


def _warn_if_plain(text: str, whose: str) -> None:
    """A secret without ``whsec_`` signs with its UTF-8 bytes, but a Standard Webhooks library given the same text
    decodes it as base64 (its secrets are base64, the prefix optional) and refuses every delivery: say so, and what
    to give the receiver instead (the secret itself is not logged)."""
    if not text.startswith(SECRET_PREFIX):
        log.warning("WEBHOOK_SECRETS: the secret of %s is not written as whsec_<base64>: deliveries are signed "
                    "with its UTF-8 bytes, and a Standard Webhooks library given the same text reads it as base64 and refuses "
                    "them; give the receiver 'whsec_' + base64(the text), or set that here", whose)


def message_id(job_id: uuid.UUID) -> str:
    """``webhook-id``: one per event (a job finishes once), the same on every attempt of its delivery."""
    return f"msg_{job_id.hex}"


def signed_headers(secret: bytes, msg_id: str, body: bytes, at: datetime | None = None) -> dict[str, str]:
    """The three Standard Webhooks headers for ``body`` sent at ``at`` (now by default)."""
    at = (at or datetime.now(timezone.utc)).replace(microsecond=0)
    return {"webhook-id": msg_id, "webhook-timestamp": str(int(at.timestamp())),
            "webhook-signature": Webhook(secret).sign(msg_id, at, body.decode())}


class WebhookSecrets:
    def __init__(self, entries: list[str], keys: KeyRing):
        self.named: dict[str, bytes] = {}
        self.default: bytes | None = None
        for entry in entries:
            name, sep, secret = entry.partition(":")
            if sep and secret:
                self.named[name] = secret_bytes(secret)
                _warn_if_plain(secret, f"tenant {name!r}")
            elif entry:
                self.default = secret_bytes(entry)
                _warn_if_plain(entry, "every tenant")
        self.keys = keys

    def secret_for(self, owner: str) -> bytes | None:
        if owner in self.named:
            return self.named[owner]
        if self.default is not None:
            return self.default
        for entry_owner, key, _ in self.keys.entries:
            if entry_owner == owner:
                return derived_secret(key)
        return None


LOCAL_NAMES = ("localhost", "localhost.localdomain", "ip6-localhost", "ip6-loopback")
NAT64 = ipaddress.ip_network("64:ff9b::/96")


class RefusedTarget(Exception):
    """A webhook target that resolves to an address inside the service's network."""


def _inside(ip: ipaddress.IPv4Address | ipaddress.IPv6Address) -> bool:
    """Not a public unicast address: loopback, private, link-local, shared, reserved, unspecified,
    multicast, documentation ... An IPv6 address that carries an IPv4 one (mapped, 6to4, Teredo,
    NAT64) is judged by the IPv4 address a gateway would reach."""
    if isinstance(ip, ipaddress.IPv6Address):
        embedded = [ip.ipv4_mapped, ip.sixtofour, *(ip.teredo or ())]
        if ip in NAT64:
            embedded.append(ipaddress.IPv4Address(int(ip) & 0xFFFFFFFF))
        if any(inner is not None and _inside(inner) for inner in embedded):
            return True
    return not ip.is_global or ip.is_multicast or ip.is_reserved or ip.is_unspecified


def _public(address: str) -> bool:
    return not _inside(ipaddress.ip_address(address.split("%", 1)[0]))


def _ipv4_number(part: str) -> int | None:
    """One dotted part as the URL standard (and inet_aton, and so every resolver) reads it:
    ``0x`` hexadecimal, a leading ``0`` octal, else decimal; None when it is no number."""
    try:
        if part[:2].lower() == "0x":
            return int(part[2:] or "0", 16)
        if len(part) > 1 and part.startswith("0"):
            return int(part[1:], 8)
        return int(part, 10) if part.isascii() and part.isdigit() else None
    except ValueError:
        return None


def host_address(host: str) -> ipaddress.IPv4Address | ipaddress.IPv6Address | None:
    """The address a URL host names when it is an address literal in any spelling, else None (a name).

    IPv4 is read as the WHATWG URL standard reads it: 1 to 4 dot-separated numbers, each decimal,
    octal (``0177``) or hex (``0x7f``), the last one filling the remaining bytes — so ``2130706433``,
    ``0177.0.0.1``, ``0x7f.1`` and ``127.1`` are all 127.0.0.1, as a resolver would connect them."""
    host = host.strip("[]").rstrip(".")
    try:
        return ipaddress.ip_address(host.split("%", 1)[0])
    except ValueError:
        pass
    parts = host.split(".")
    if not host or len(parts) > 4:
        return None
    numbers = [_ipv4_number(part) for part in parts]
    if any(n is None for n in numbers):
        return None
    *leading, last = numbers
    if any(n > 255 for n in leading) or last >= 256 ** (5 - len(numbers)):
        return None  # out of range: no resolver takes it as an address either
    value = last
    for index, n in enumerate(leading):
        value += n << (8 * (3 - index))
    return ipaddress.IPv4Address(value)


def _local_name(host: str) -> bool:
    name = host.rstrip(".").lower()
    return name in LOCAL_NAMES or name.endswith(".localhost")


def resolve(host: str, port: int) -> list[str]:
    """Every address ``host`` resolves to (one lookup), in the resolver's order."""
    infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    return list(dict.fromkeys(str(sockaddr[0]) for *_, sockaddr in infos))


def checked_addresses(host: str, port: int, resolver=resolve, allow_private: bool = False) -> list[str]:
    """The addresses to connect to for ``host``, resolved once; :class:`RefusedTarget` when any of them
    (or the name itself: ``localhost.``) is inside, unless ``allow_private``."""
    literal = host_address(host)
    if literal is not None:
        addresses = [str(literal)]
    elif not allow_private and _local_name(host):
        raise RefusedTarget(f"{host} names the service's own host")
    else:
        addresses = resolver(host, port)
    if not allow_private:
        for address in addresses:
            if not _public(address):
                raise RefusedTarget(f"{host} resolves to the non-public address {address}")
    if not addresses:
        raise OSError(f"{host} resolves to no address")
    return addresses


def non_public_address(host: str, port: int | None, resolver=resolve) -> str | None:
    """Why ``host`` is inside the service's network (a loopback spelling, a local name, a name that
    resolves to a non-public address), or None. An unresolvable name is None: its delivery fails
    and is retried."""
    try:
        checked_addresses(host, port or 443, resolver)
    except RefusedTarget as refused:
        return str(refused)
    except (OSError, UnicodeError):
        return None
    return None


class PinnedBackend(httpcore.NetworkBackend):
    """Connects to the address that was checked: the host is resolved once here, every address it
    resolves to is checked, and the TCP connection goes to one of those addresses — no second lookup
    by the socket layer, so a name that answers public for the check and loopback a moment later (DNS
    rebinding) cannot slip through. The URL is unchanged, so the request keeps its Host header and TLS
    keeps the host name for SNI and certificate verification (httpcore takes both from the URL)."""

    def __init__(self, resolver=resolve, allow_private: bool = False, inner: httpcore.NetworkBackend | None = None):
        self.resolver, self.allow_private = resolver, allow_private
        self.inner = inner or httpcore.SyncBackend()

    def connect_tcp(self, host, port, timeout=None, local_address=None, socket_options=None):
        try:
            addresses = checked_addresses(host, port, self.resolver, self.allow_private)
        except (OSError, UnicodeError) as failed:
            raise httpcore.ConnectError(f"cannot resolve {host}: {failed}") from failed
        last: Exception | None = None
        for address in addresses:  # each one checked above
            try:
                return self.inner.connect_tcp(address, port, timeout, local_address, socket_options)
            except (httpcore.ConnectError, httpcore.ConnectTimeout) as failed:
                last = failed
        raise last  # type: ignore[misc]

    def connect_unix_socket(self, *args, **kwargs):
        raise httpcore.ConnectError("webhooks are sent over TCP only")

    def sleep(self, seconds: float) -> None:
        self.inner.sleep(seconds)


class PinnedTransport(httpx.HTTPTransport):
    """httpx's transport with a :class:`PinnedBackend` under its connection pool. No proxy from the
    environment (``trust_env`` off): through a proxy the check would judge the proxy, not the target."""

    def __init__(self, resolver=resolve, allow_private: bool = False, inner: httpcore.NetworkBackend | None = None,
                 verify: bool | ssl.SSLContext = True):
        super().__init__(verify=verify, trust_env=False)
        context = verify if isinstance(verify, ssl.SSLContext) else httpx.create_ssl_context(verify=verify,
                                                                                            trust_env=False)
        self._pool = httpcore.ConnectionPool(ssl_context=context, max_connections=16, max_keepalive_connections=4,
                                             network_backend=PinnedBackend(resolver, allow_private, inner))


SUBMIT_RESOLVE_SECONDS = 2.0  # the longest a submission waits for the callback host's name to resolve
_LOOKUPS = ThreadPoolExecutor(max_workers=4, thread_name_prefix="callback-dns")


def _bounded(resolver):
    """``resolver`` with a deadline: a name whose servers never answer cannot hold a submission for the
    resolver's own timeouts (tens of seconds). A late answer counts as unresolvable here; the delivery
    resolves and checks it again before it connects."""
    def lookup(host: str, port: int) -> list[str]:
        try:
            return _LOOKUPS.submit(resolver, host, port).result(timeout=SUBMIT_RESOLVE_SECONDS)
        except FutureTimeout:
            raise OSError(f"{host} did not resolve within {SUBMIT_RESOLVE_SECONDS} s") from None
    return lookup


def check_callback_url(url: str, owner: str, secrets: WebhookSecrets, allow_private: bool = False,
                       resolver=resolve) -> str:
    """The URL as stored; a 422 naming ``callback_url`` when it is unusable or cannot be signed, or
    (unless ``allow_private``) points inside the service's network: an address in any spelling
    (``2130706433``, ``0177.0.0.1``, ``0x7f.1``, ``127.1``, ``[::ffff:127.0.0.1]``, ``0.0.0.0``), a
    local name (``localhost.``), or a name that resolves to such an address now. The delivery checks
    again, on the address it connects to (a name may change its answer)."""
    parts = urlsplit(url)
    try:
        host, port = parts.hostname, parts.port
    except ValueError:
        host = port = None
    if parts.scheme not in ("http", "https") or not host:
        raise Unprocessable("callback_url must be an absolute http or https URL.",
                            errors=[field_problem(["query", "callback_url"], "not an absolute http(s) URL")])
    if secrets.secret_for(owner) is None:
        raise Unprocessable("callback_url needs a signing secret: set WEBHOOK_SECRETS (or API_KEYS) on the service.",
                            errors=[field_problem(["query", "callback_url"], "no webhook secret configured")])
    if not allow_private:
        inside = non_public_address(host, port or (443 if parts.scheme == "https" else 80), _bounded(resolver))
        if inside is not None:
            raise Unprocessable(
                "callback_url points at a non-public address; the service does not call its own network "
                "(WEBHOOK_PRIVATE_TARGETS=true allows it).",
                errors=[field_problem(["query", "callback_url"], f"{host} is not a public address ({inside})")])
    return url


class WebhookNotifier:
    """Sends due webhooks from a daemon thread and a small pool (see the module docstring)."""

    def __init__(self, service, secrets: WebhookSecrets, settings, transport: httpx.BaseTransport | None = None):
        self.service, self.secrets, self.settings = service, secrets, settings
        self._transport = transport
        self._http: httpx.Client | None = None
        self._http_lock = threading.Lock()
        self._pool = ThreadPoolExecutor(max_workers=4, thread_name_prefix="webhook")
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="webhook-notifier", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5)
        self._pool.shutdown(wait=True, cancel_futures=True)
        with self._http_lock:
            if self._http is not None:
                self._http.close()

    def _client(self) -> httpx.Client:
        """The HTTP client, made at the first delivery: most services send no webhook, and its TLS contexts (the CA
        bundle read twice) were a fifth of every app's start."""
        with self._http_lock:
            if self._http is None:
                # the pinned transport resolves each target once and connects to the address it checked
                transport = self._transport or PinnedTransport(allow_private=self.settings.webhook_private_targets)
                self._http = httpx.Client(timeout=self.settings.webhook_timeout_seconds, transport=transport,
                                          trust_env=False, headers={"User-Agent": "plantsolve-webhook"})
            return self._http

    def _loop(self) -> None:
        away = False  # the database was away at the last round: an outage is one line when it starts, one when it ends
        while not self._stop.wait(self.settings.webhook_poll_seconds):
            try:
                self.send_due()
            except Exception as error:  # the next round tries again
                if not is_infrastructure_failure(error):
                    log.exception("webhook round failed")
                    continue
                if not away:
                    log.warning("webhook rounds fail (%s: %s); trying every %g s", type(error).__name__,
                                (str(error).strip().splitlines() or [""])[0][:200], self.settings.webhook_poll_seconds)
                away = True
            else:
                if away:
                    log.info("webhook rounds work again")
                away = False

    def send_due(self) -> int:
        """Claim every due delivery and hand it to the pool; returns how many were claimed."""
        claimed = 0
        for job_id in self.service.due_callbacks():
            attempt = self.service.claim_callback(job_id, lease_seconds=LEASE_SECONDS)
            if attempt is not None:
                claimed += 1
                self._pool.submit(self.deliver, job_id, attempt)
        return claimed

    def deliver(self, job_id: uuid.UUID, attempt: int) -> bool:
        try:
            job = self.service.get(job_id, brief=True)
        except NotFound:
            return False
        if not job.callback_url:
            return False
        body = self.service.view(job).model_dump_json().encode()
        secret = self.secrets.secret_for(job.owner)
        headers = {"Content-Type": "application/json", "X-Plantsolve-Event": "job.finished",
                   "X-Plantsolve-Delivery": f"{job_id}/{attempt}"}
        if secret is not None:  # signed at each attempt: a retry carries the same id and a fresh timestamp
            headers.update(signed_headers(secret, message_id(job_id), body))
        error = None
        try:
            response = self._client().post(job.callback_url, content=body, headers=headers)
            if not 200 <= response.status_code < 300:
                error = f"HTTP {response.status_code}"
        except RefusedTarget as refused:  # checked on the address it was about to connect to: not retried
            self.service.record_callback(job_id, attempt, state="failed", error=f"refused: {refused}")
            log.warning("webhook of job %s refused: %s", job_id, refused)
            return False
        except httpx.HTTPError as failure:
            error = f"{type(failure).__name__}: {failure}"[:500]
        if error is None:
            self.service.record_callback(job_id, attempt, state="delivered")
            log.info("webhook delivered", extra={"job_id": str(job_id), "attempt": attempt})
            return True
        if attempt >= self.settings.webhook_max_attempts:
            self.service.record_callback(job_id, attempt, state="failed", error=error)
            log.warning("webhook of job %s given up after %d attempts: %s", job_id, attempt, error)
        else:
            delay = self.settings.webhook_retry_seconds * 2 ** (attempt - 1)
            self.service.record_callback(job_id, attempt, state="pending", error=error,
                                      next_at=datetime.now(timezone.utc) + timedelta(seconds=delay))
            log.info("webhook of job %s failed (%s); retry in %.1f s", job_id, error, delay)
        return False
