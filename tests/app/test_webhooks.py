"""The completion webhook: POSTed once the job has finished, with the job view, signed with the
tenant's secret per the Standard Webhooks spec (a captured delivery cannot be replayed), retried with
backoff, given up after WEBHOOK_MAX_ATTEMPTS; never in the runner's way."""

from __future__ import annotations

import base64
import hashlib
import hmac
import json
import socket
import threading
import time
from contextlib import contextmanager
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import httpcore
import httpx
import pytest
from fastapi.testclient import TestClient
from standardwebhooks import Webhook

from plantsolve.app.main import create_app
from plantsolve.app.webhooks import PinnedTransport, RefusedTarget, host_address
from plantsolve.client import (
    Client,
    WebhookReplayed,
    WebhookVerificationError,
    WebhookVerifier,
    webhook_secret,
)
from tests.conftest import service_settings, wait_for

ALICE = {"Authorization": "Bearer key-a"}


class Receiver:
    """A loopback HTTP server that records each POST and answers from a script of status codes."""

    def __init__(self, statuses=(200,), delay: float = 0.0):
        self.statuses, self.delay = list(statuses), delay
        self.requests: list[dict] = []
        receiver = self

        class Handler(BaseHTTPRequestHandler):
            def do_POST(self) -> None:
                body = self.rfile.read(int(self.headers["Content-Length"]))
                receiver.requests.append({"at": time.monotonic(), "body": body, "headers": dict(self.headers)})
                time.sleep(receiver.delay)
                status = receiver.statuses.pop(0) if len(receiver.statuses) > 1 else receiver.statuses[0]
                self.send_response(status)
                self.send_header("Content-Length", "0")
                self.end_headers()

            def log_message(self, *args) -> None:
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}/hook?token=t1"
        threading.Thread(target=self.server.serve_forever, daemon=True).start()

    def close(self) -> None:
        self.server.shutdown()
        self.server.server_close()


@contextmanager
def receiver(**kwargs):
    r = Receiver(**kwargs)
    try:
        yield r
    finally:
        r.close()


def _app(tmp_path, **overrides):
    values = dict(api_keys=["alice:key-a"], webhook_poll_seconds=0.05, webhook_retry_seconds=0.2,
                  webhook_private_targets=True)  # the receiver listens on 127.0.0.1
    values.update(overrides)
    return create_app(service_settings(tmp_path, **values))


def _callback_state(client, job_id, states=("delivered", "failed"), timeout=20.0, headers=ALICE) -> dict:
    deadline = time.monotonic() + timeout
    while True:
        callback = client.get(f"/v1/jobs/{job_id}", headers=headers).json()["callback"]
        if callback["state"] in states:
            return callback
        assert time.monotonic() < deadline, callback
        time.sleep(0.05)


def spec_signature(key: bytes, msg_id: str, timestamp: str, body: bytes) -> str:
    """The Standard Webhooks v1 signature, written here from the spec (not taken from the service)."""
    signed = f"{msg_id}.{timestamp}.".encode() + body
    return "v1," + base64.b64encode(hmac.new(key, signed, hashlib.sha256).digest()).decode()


def _delivered(tmp_path, **overrides) -> dict:
    """One real delivery of a finished job, as the receiver got it."""
    with receiver() as hook, TestClient(_app(tmp_path, **overrides)) as client:
        job = client.post("/v1/test-compute/jobs", params={"callback_url": hook.url}, json={"values": [3.0, 4.0]},
                          headers=ALICE).json()
        assert _callback_state(client, job["id"])["state"] == "delivered"
        (request,) = hook.requests
        return {"job": job, **request}


def test_a_finished_job_is_posted_signed_per_standard_webhooks(tmp_path):
    before = int(time.time())
    delivery = _delivered(tmp_path)
    job, body, headers = delivery["job"], delivery["body"], delivery["headers"]
    assert job["callback"]["state"] == "pending" and job["callback"]["attempts"] == 0
    view = json.loads(body)
    assert view["id"] == job["id"] and view["status"] == "succeeded" and view["artifacts"]
    assert headers["Content-Type"] == "application/json"
    assert headers["X-Plantsolve-Event"] == "job.finished"
    assert "X-Plantsolve-Signature" not in headers  # the body-only, replayable signature is gone
    msg_id, stamp = headers["webhook-id"], headers["webhook-timestamp"]
    assert msg_id == "msg_" + job["id"].replace("-", "")
    assert before <= int(stamp) <= time.time() + 1
    # the receiver derives the key from its own API key and checks the signature as the spec says
    key = hmac.new(b"key-a", b"plantsolve-webhook", hashlib.sha256).digest()
    assert headers["webhook-signature"] == spec_signature(key, msg_id, stamp, body)
    assert webhook_secret("key-a") == "whsec_" + base64.b64encode(key).decode()
    # the reference implementation agrees, and so does the client's verifier
    assert Webhook(webhook_secret("key-a")).verify(body, headers)["id"] == job["id"]
    assert WebhookVerifier(webhook_secret("key-a")).verify(body, headers)["id"] == job["id"]
    with pytest.raises(WebhookVerificationError, match="no webhook-signature matches"):
        WebhookVerifier(webhook_secret("key-b")).verify(body, headers)


def test_a_tampered_or_replayed_delivery_is_refused(tmp_path):
    delivery = _delivered(tmp_path)
    body, headers, secret = delivery["body"], delivery["headers"], webhook_secret("key-a")
    sent = int(headers["webhook-timestamp"])
    verifier = WebhookVerifier(secret, tolerance_seconds=300)
    # a changed body: the signature no longer matches
    tampered = body.replace(b'"succeeded"', b'"failed"')
    assert tampered != body
    with pytest.raises(WebhookVerificationError, match="no webhook-signature matches"):
        verifier.verify(tampered, headers)
    # a moved timestamp: it is part of what is signed
    with pytest.raises(WebhookVerificationError, match="no webhook-signature matches"):
        verifier.verify(body, {**headers, "webhook-timestamp": str(sent + 1)})
    assert verifier.verify(body, headers)["status"] == "succeeded"
    # the same delivery sent again: its id was taken
    with pytest.raises(WebhookReplayed):
        verifier.verify(body, headers)
    # captured and replayed later, to a receiver that does not remember the id: too old
    with pytest.raises(WebhookVerificationError, match="beyond the 300 s tolerance"):
        WebhookVerifier(secret).verify(body, headers, now=sent + 301)
    assert WebhookVerifier(secret).verify(body, headers, now=sent + 299)["status"] == "succeeded"
    # a receiver whose handling failed lets the sender's retry through
    verifier.forget(headers["webhook-id"])
    assert verifier.verify(body, headers)["status"] == "succeeded"
    # no signature headers at all
    with pytest.raises(WebhookVerificationError, match="missing"):
        verifier.verify(body, {"Content-Type": "application/json"})


def test_failed_deliveries_are_retried_with_growing_delays(tmp_path):
    with receiver(statuses=(503, 500, 200)) as hook, TestClient(_app(tmp_path)) as client:
        job = client.post("/v1/test-fail/jobs", params={"callback_url": hook.url}, json={}, headers=ALICE).json()
        callback = _callback_state(client, job["id"])
        assert callback["state"] == "delivered" and callback["attempts"] == 3
        times = [r["at"] for r in hook.requests]
        assert len(times) == 3
        first_gap, second_gap = times[1] - times[0], times[2] - times[1]
        assert first_gap >= 0.2 and second_gap >= 0.4  # 0.2 s, then doubled
        assert json.loads(hook.requests[-1]["body"])["status"] == "failed"  # failed jobs are reported too
        # one message, three attempts: the same webhook-id (for de-duplication), each attempt signed anew
        assert len({r["headers"]["webhook-id"] for r in hook.requests}) == 1
        for request in hook.requests:
            assert WebhookVerifier(webhook_secret("key-a")).verify(request["body"], request["headers"])


def test_the_client_asks_for_a_webhook(tmp_path):
    with receiver() as hook, TestClient(_app(tmp_path)) as http:
        client = Client(api_key="key-a", http=http)
        job = client.submit("test-compute", {"values": [1.0]}, callback_url=hook.url)
        assert job.view["callback"]["state"] == "pending"
        assert _callback_state(http, job.id)["state"] == "delivered"


def test_a_receiver_that_keeps_failing_is_given_up(tmp_path):
    with receiver(statuses=(500,)) as hook, TestClient(_app(tmp_path, webhook_max_attempts=2)) as client:
        job = client.post("/v1/test-compute/jobs", params={"callback_url": hook.url}, json={"values": [1.0]},
                          headers=ALICE).json()
        callback = _callback_state(client, job["id"])
        assert callback == {"url": hook.url, "state": "failed", "attempts": 2, "error": "HTTP 500"}
        time.sleep(0.5)
        assert len(hook.requests) == 2


SPEC_SECRET = "whsec_MfKQ9r8GKYqrTwjUPD8ILPZIo2LaLaSw"  # the spec's example secret: base64 of 24 bytes


def test_webhook_secrets_setting_and_bad_urls(tmp_path):
    with receiver() as hook, TestClient(_app(tmp_path, api_keys=[], webhook_secrets=[SPEC_SECRET])) as client:
        job = client.post("/v1/test-compute/jobs", params={"callback_url": hook.url}, json={"values": [1.0]}).json()
        assert _callback_state(client, job["id"], headers={})["state"] == "delivered"
        body, headers = hook.requests[0]["body"], hook.requests[0]["headers"]
        key = base64.b64decode(SPEC_SECRET.removeprefix("whsec_"))  # the key is the decoded bytes
        assert headers["webhook-signature"] == spec_signature(key, headers["webhook-id"],
                                                              headers["webhook-timestamp"], body)
        assert Webhook(SPEC_SECRET).verify(body, headers)["id"] == job["id"]
        for bad in ("ftp://host/x", "not a url", "/relative"):
            refused = client.post("/v1/test-compute/jobs", params={"callback_url": bad}, json={"values": [1.0]})
            assert refused.status_code == 422 and refused.json()["errors"][0]["loc"] == ["query", "callback_url"]
    with TestClient(create_app(service_settings(tmp_path / "plain"))) as client:  # no keys, no secrets: unsignable
        refused = client.post("/v1/test-compute/jobs", params={"callback_url": "http://127.0.0.1:9/x"},
                              json={"values": [1.0]})
        assert refused.status_code == 422 and "WEBHOOK_SECRETS" in refused.json()["detail"]
        assert client.get("/v1/jobs").json()["items"] == []


def test_a_slow_receiver_does_not_hold_up_the_jobs(tmp_path):
    with receiver(delay=3.0) as hook, TestClient(_app(tmp_path, embedded_workers=1)) as client:
        first = client.post("/v1/test-compute/jobs", params={"callback_url": hook.url}, json={"values": [1.0]},
                            headers=ALICE).json()
        wait_for(client, first["id"], headers=ALICE)
        deadline = time.monotonic() + 10
        while not hook.requests:  # the delivery has started and hangs in the receiver
            assert time.monotonic() < deadline
            time.sleep(0.02)
        started = time.monotonic()
        second = client.post("/v1/test-compute/jobs", json={"values": [2.0]}, headers=ALICE).json()
        assert wait_for(client, second["id"], headers=ALICE)["status"] == "succeeded"
        assert time.monotonic() - started < 2.5  # the only job slot was free while the webhook waited
        assert client.get(f"/v1/jobs/{first['id']}", headers=ALICE).json()["callback"]["state"] == "pending"
        assert _callback_state(client, first["id"])["state"] == "delivered"


def test_callbacks_into_the_services_own_network_are_refused_by_default(tmp_path):
    """A tenant must not make the service call addresses only it can reach (cloud metadata, admin ports):
    an address literal or a local name is refused at submission."""
    with receiver() as hook, TestClient(_app(tmp_path, webhook_private_targets=False)) as client:
        for inside in ("http://127.0.0.1:9/x", "http://10.1.2.3/x", "http://169.254.169.254/latest",
                       "http://[::1]:8000/x", "http://[::ffff:192.168.0.1]/x", "http://0.0.0.0/x"):
            refused = client.post("/v1/test-compute/jobs", params={"callback_url": inside}, json={"values": [1.0]},
                                  headers=ALICE)
            assert refused.status_code == 422, inside
            assert refused.json()["errors"][0]["loc"] == ["query", "callback_url"]
            assert "not a public address" in refused.json()["errors"][0]["msg"]
        by_name = hook.url.replace("127.0.0.1", "localhost")
        refused = client.post("/v1/test-compute/jobs", params={"callback_url": by_name}, json={"values": [1.0]},
                              headers=ALICE)
        assert refused.status_code == 422 and refused.json()["errors"][0]["loc"] == ["query", "callback_url"]
        assert hook.requests == []


def test_the_example_receiver_takes_a_delivery_once_and_refuses_forgeries(tmp_path):
    """examples/client/webhook_receiver.py, fed a real delivery, its replay and a forgery."""
    import importlib.util

    import httpx

    spec = importlib.util.spec_from_file_location("webhook_receiver", "examples/client/webhook_receiver.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    delivery = _delivered(tmp_path)
    taken: list[dict] = []
    server = example.make_server("127.0.0.1", 0, webhook_secret("key-a"), taken.append)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        url = f"http://127.0.0.1:{server.server_address[1]}/hook"
        headers = {k: v for k, v in delivery["headers"].items() if k.lower() != "content-length"}
        assert httpx.post(url, content=delivery["body"], headers=headers).status_code == 204
        assert httpx.post(url, content=delivery["body"], headers=headers).status_code == 200  # replayed
        forged = delivery["body"].replace(b'"succeeded"', b'"cancelled"')
        assert httpx.post(url, content=forged, headers=headers).status_code == 401
        assert [view["id"] for view in taken] == [delivery["job"]["id"]]
    finally:
        server.shutdown()
        server.server_close()


# ---- the target is checked where it is connected (DNS rebinding) and in every spelling -------------------

PUBLIC = "93.184.216.34"  # a global unicast address (never connected to here)


class Rebinding:
    """A resolver for one name that answers a public address the first time and loopback after:
    a DNS rebinding attacker with a zero TTL."""

    def __init__(self, name: str, first: str = PUBLIC, later: str = "127.0.0.1"):
        self.name, self.first, self.later, self.lookups = name, first, later, 0

    def answer(self) -> str:
        self.lookups += 1
        return self.first if self.lookups == 1 else self.later

    def getaddrinfo(self, real):
        def fake(host, port, *args, **kwargs):
            if host != self.name:
                return real(host, port, *args, **kwargs)
            return [(socket.AF_INET, socket.SOCK_STREAM, 6, "", (self.answer(), int(port or 80)))]
        return fake


class RecordingBackend(httpcore.NetworkBackend):
    """Stands for the network: records where each connection goes and what is sent on it, answers 204."""

    def __init__(self):
        self.connected: list[tuple[str, int]] = []
        self.sent = bytearray()
        self.tls_names: list[str | None] = []
        backend = self

        class Stream(httpcore.NetworkStream):
            def __init__(self):
                self.answer = b"HTTP/1.1 204 No Content\r\nContent-Length: 0\r\n\r\n"

            def read(self, max_bytes, timeout=None):
                chunk, self.answer = self.answer[:max_bytes], self.answer[max_bytes:]
                return chunk

            def write(self, buffer, timeout=None):
                backend.sent += buffer

            def close(self):
                pass

            def start_tls(self, ssl_context, server_hostname=None, timeout=None):
                backend.tls_names.append(server_hostname)
                return self

            def get_extra_info(self, info):
                return None

        self.stream = Stream

    def connect_tcp(self, host, port, timeout=None, local_address=None, socket_options=None):
        self.connected.append((host, port))
        return self.stream()

    def sleep(self, seconds):
        pass


@pytest.mark.parametrize("scheme", ["http", "https"])
def test_the_transport_connects_to_the_address_it_checked_with_the_original_host(scheme):
    """Resolved once: the public answer is checked and connected to; the later loopback answer is never asked
    for. The request keeps the name in its Host header and TLS gets the name for SNI and verification."""
    rebinding, network = Rebinding("hooks.example"), RecordingBackend()
    transport = PinnedTransport(resolver=lambda host, port: [rebinding.answer()], inner=network)
    with httpx.Client(transport=transport) as client:
        assert client.post(f"{scheme}://hooks.example/hook", content=b"{}").status_code == 204
    port = 443 if scheme == "https" else 80
    assert network.connected == [(PUBLIC, port)] and rebinding.lookups == 1
    assert b"\r\nHost: hooks.example\r\n" in bytes(network.sent)
    assert network.tls_names == (["hooks.example"] if scheme == "https" else [])


def test_the_transport_refuses_a_name_that_resolves_inside():
    network = RecordingBackend()
    for answers in (["127.0.0.1"], [PUBLIC, "10.0.0.7"], ["::ffff:169.254.169.254"]):
        transport = PinnedTransport(resolver=lambda host, port, answers=answers: answers, inner=network)
        with httpx.Client(transport=transport) as client, pytest.raises(RefusedTarget):
            client.post("http://hooks.example/hook", content=b"{}")
    assert network.connected == []
    allowed = PinnedTransport(resolver=lambda host, port: ["127.0.0.1"], allow_private=True, inner=network)
    with httpx.Client(transport=allowed) as client:  # WEBHOOK_PRIVATE_TARGETS=true: connected, still pinned
        assert client.post("http://hooks.example/hook").status_code == 204
    assert network.connected == [("127.0.0.1", 80)]


def test_a_rebinding_name_never_reaches_the_services_own_network(tmp_path, monkeypatch):
    """The name answers public when it is checked and loopback afterwards: the delivery goes to the checked
    address or is refused, never to the loopback receiver."""
    with receiver() as hook:
        port = hook.server.server_address[1]
        rebinding = Rebinding("rebind.example")
        monkeypatch.setattr(socket, "getaddrinfo", rebinding.getaddrinfo(socket.getaddrinfo))
        with TestClient(_app(tmp_path, webhook_private_targets=False, webhook_timeout_seconds=1.0,
                             webhook_max_attempts=1)) as client:
            job = client.post("/v1/test-compute/jobs", params={"callback_url": f"http://rebind.example:{port}/hook"},
                              json={"values": [1.0]}, headers=ALICE)
            assert job.status_code == 202, job.text
            state = _callback_state(client, job.json()["id"])
        assert hook.requests == []
        assert state["state"] == "failed" and "127.0.0.1" in state["error"], state


LOOPBACK_SPELLINGS = [
    "http://2130706433/x", "http://0177.0.0.1/x", "http://0x7f.1/x", "http://127.1/x", "http://0x7f000001/x",
    "http://017700000001/x", "http://127.0.0.1./x", "http://[::1]/x", "http://[::ffff:127.0.0.1]/x",
    "http://[::ffff:7f00:1]/x", "http://[64:ff9b::7f00:1]/x", "http://[2002:7f00:1::]/x", "http://localhost./x",
    "http://LOCALHOST:8000/x", "http://api.localhost/x", "http://0.0.0.0/x", "http://0/x", "http://[::]/x",
    "https://0xa9.0xfe.0xa9.0xfe/latest", "http://inside.example/x",
]


def test_every_loopback_spelling_is_refused_at_submission(tmp_path, monkeypatch):
    real = socket.getaddrinfo

    def resolver(host, port, *args, **kwargs):  # a name that resolves inside at submission
        if host == "inside.example":
            return [(socket.AF_INET, socket.SOCK_STREAM, 6, "", ("10.20.30.40", port))]
        if host == "public.example":
            return [(socket.AF_INET, socket.SOCK_STREAM, 6, "", (PUBLIC, port))]
        return real(host, port, *args, **kwargs)

    monkeypatch.setattr(socket, "getaddrinfo", resolver)
    with TestClient(_app(tmp_path, webhook_private_targets=False)) as client:
        for url in LOOPBACK_SPELLINGS:
            refused = client.post("/v1/test-compute/jobs", params={"callback_url": url}, json={"values": [1.0]},
                                  headers=ALICE)
            assert refused.status_code == 422, url
            assert refused.json()["errors"][0]["loc"] == ["query", "callback_url"], url
        for url in ("http://public.example/x", f"http://{PUBLIC}/x", "http://0x5d.0xb8.0xd8.0x22/x"):
            accepted = client.post("/v1/test-compute/jobs", params={"callback_url": url}, json={"values": [1.0]},
                                   headers=ALICE)
            assert accepted.status_code == 202, (url, accepted.text)
        assert len(client.get("/v1/jobs", headers=ALICE).json()["items"]) == 3


@pytest.mark.parametrize("host, address", [
    ("2130706433", "127.0.0.1"), ("0177.0.0.1", "127.0.0.1"), ("0x7f.1", "127.0.0.1"), ("127.1", "127.0.0.1"),
    ("10.1", "10.0.0.1"), ("192.168.257", "192.168.1.1"), ("0x5d.0xb8.0xd8.0x22", PUBLIC), ("1.2.3.4.", "1.2.3.4"),
    ("[::ffff:127.0.0.1]", "::ffff:7f00:1"), ("example.com", None), ("1.2.3.4.5", None), ("256.1.1.1", None),
    ("0x", "0.0.0.0"), ("08.1.1.1", None), ("1e3", None),
])
def test_host_addresses_are_read_as_a_resolver_reads_them(host, address):
    found = host_address(host)
    assert (str(found) if found is not None else None) == address


def test_a_name_that_never_resolves_does_not_hold_a_submission(tmp_path, monkeypatch):
    real = socket.getaddrinfo
    answer = threading.Event()  # the name's servers answer only when the test ends

    def stalled(host, port, *args, **kwargs):
        if host == "slow.example":
            answer.wait(120)
        return real(host, port, *args, **kwargs)

    monkeypatch.setattr(socket, "getaddrinfo", stalled)
    try:
        with TestClient(_app(tmp_path, webhook_private_targets=False)) as client:
            started = time.monotonic()
            accepted = client.post("/v1/test-compute/jobs", params={"callback_url": "http://slow.example/x"},
                                   json={"values": [1.0]}, headers=ALICE)
            # answered after the submission's own bound (2 s), far from the resolver's 120 s stall, however busy
            # the machine; the delivery checks the name again
            assert accepted.status_code == 202 and time.monotonic() - started < 60
    finally:
        answer.set()


def test_a_plain_text_secret_is_said_to_need_its_whsec_form_for_a_standard_webhooks_receiver(caplog):
    """The same text given to the service and to the standardwebhooks library: the service signs with its UTF-8
    bytes, the library decodes it as base64, and every delivery is refused. The service says so at start-up and
    which form the receiver needs; with that form the library verifies the delivery."""
    import logging

    from plantsolve.app.auth import KeyRing
    from plantsolve.app.webhooks import WebhookSecrets, signed_headers

    caplog.set_level(logging.WARNING, logger="plantsolve")
    plain = "rig7-hook-secret"
    secrets = WebhookSecrets([f"acme:{plain}", "whsec_" + base64.b64encode(b"k" * 32).decode()], KeyRing([], []))
    body = b'{"id": "x"}'
    headers = signed_headers(secrets.secret_for("acme"), "msg_1", body)
    with pytest.raises(Exception, match="No matching signature found"):
        Webhook(plain).verify(body, headers)
    assert Webhook("whsec_" + base64.b64encode(plain.encode()).decode()).verify(body, headers) == {"id": "x"}
    (message,) = {r.getMessage() for r in caplog.records if "WEBHOOK_SECRETS" in r.getMessage()}
    assert "tenant 'acme'" in message and "whsec_" in message  # the whsec_ secret is not warned about
    assert plain not in caplog.text  # the secret itself is never logged
