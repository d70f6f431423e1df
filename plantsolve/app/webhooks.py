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
"""

from __future__ import annotations

import base64
import binascii
import hashlib
import hmac
import ipaddress
import logging
import socket
import threading
import uuid
from concurrent.futures import ThreadPoolExecutor
from datetime import datetime, timedelta, timezone
from urllib.parse import urlsplit

import httpx
from standardwebhooks import Webhook

from plantsolve.app.auth import KeyRing
from plantsolve.jobs.errors import NotFound, Unprocessable, field_problem

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
            elif entry:
                self.default = secret_bytes(entry)
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


def _public(address: str) -> bool:
    ip = ipaddress.ip_address(address.split("%", 1)[0])
    if isinstance(ip, ipaddress.IPv6Address) and ip.ipv4_mapped is not None:
        ip = ip.ipv4_mapped
    return ip.is_global and not ip.is_multicast


def non_public_address(host: str, port: int | None) -> str | None:
    """The first address ``host`` stands for that is not a public unicast one (loopback, private,
    link-local, reserved), or None. A name is resolved, so a public-looking name that points
    inside is caught too."""
    try:
        return None if _public(host) else host
    except ValueError:
        pass  # a name, not an address literal
    try:
        infos = socket.getaddrinfo(host, port or 443, type=socket.SOCK_STREAM)
    except OSError:
        return None  # unresolvable: the delivery itself fails and is retried
    for *_, sockaddr in infos:
        if not _public(str(sockaddr[0])):
            return str(sockaddr[0])
    return None


def check_callback_url(url: str, owner: str, secrets: WebhookSecrets, allow_private: bool = False) -> str:
    """The URL as stored; a 422 naming ``callback_url`` when it is unusable or cannot be signed, or
    (unless ``allow_private``) names a non-public address literal."""
    parts = urlsplit(url)
    if parts.scheme not in ("http", "https") or not parts.hostname:
        raise Unprocessable("callback_url must be an absolute http or https URL.",
                            errors=[field_problem(["query", "callback_url"], "not an absolute http(s) URL")])
    if secrets.secret_for(owner) is None:
        raise Unprocessable("callback_url needs a signing secret: set WEBHOOK_SECRETS (or API_KEYS) on the service.",
                            errors=[field_problem(["query", "callback_url"], "no webhook secret configured")])
    if not allow_private:
        try:
            literal = not _public(parts.hostname)
        except ValueError:
            literal = False  # a name: checked when it is resolved for the delivery
        if literal:
            raise Unprocessable(
                "callback_url points at a non-public address; the service does not call its own network "
                "(WEBHOOK_PRIVATE_TARGETS=true allows it).",
                errors=[field_problem(["query", "callback_url"], f"{parts.hostname} is not a public address")])
    return url


class WebhookNotifier:
    """Sends due webhooks from a daemon thread and a small pool (see the module docstring)."""

    def __init__(self, service, secrets: WebhookSecrets, settings, transport: httpx.BaseTransport | None = None):
        self.service, self.secrets, self.settings = service, secrets, settings
        self._http = httpx.Client(timeout=settings.webhook_timeout_seconds, transport=transport,
                                  headers={"User-Agent": "plantsolve-webhook"})
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
        self._http.close()

    def _loop(self) -> None:
        while not self._stop.wait(self.settings.webhook_poll_seconds):
            try:
                self.send_due()
            except Exception:  # a database hiccup: the next round tries again
                log.exception("webhook round failed")

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
        target = urlsplit(job.callback_url)
        inside = None if self.settings.webhook_private_targets else non_public_address(target.hostname or "",
                                                                                         target.port)
        if inside is not None:
            self.service.record_callback(job_id, attempt, state="failed",
                                      error=f"refused: {target.hostname} resolves to the non-public address {inside}")
            log.warning("webhook of job %s refused: %s resolves to %s", job_id, target.hostname, inside)
            return False
        try:
            response = self._http.post(job.callback_url, content=body, headers=headers)
            if not 200 <= response.status_code < 300:
                error = f"HTTP {response.status_code}"
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
