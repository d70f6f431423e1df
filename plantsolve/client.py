"""A Python client of the plantsolve HTTP API, sync (:class:`Client`) and async (:class:`AsyncClient`), on httpx.

    from plantsolve.client import Client

    with Client("http://127.0.0.1:8000", api_key=None) as client:
        job = client.submit("perfmap", file="n3_fan_map.csv", options={"model": "auto"})
        job = client.wait(job, progress=lambda j: print(f"{j.fraction:4.0%} {j.message}"))
        result = client.result(job)             # the kind's result document (raises if the job failed)
        if job.verdict:                         # succeeded, but the result does not pass (a failed inspection)
            print(job.verdict["code"], job.verdict["message"])
        client.download_artifacts(job, "out")   # every plot and file, SHA-256 checked

``wait`` follows the job's Server-Sent Events (``GET /v1/jobs/{id}/events``) and falls back to polling
``GET /v1/jobs/{id}`` when the stream is unavailable (an older server, a proxy that buffers). Every
error answer becomes an exception of the :class:`ApiError` family carrying the RFC 9457 problem
document (``error.problem``; ``error.errors`` lists each bad field of a 422).

The module imports nothing else of plantsolve: it can be copied next to a script that only has httpx.
"""

from __future__ import annotations

import asyncio
import base64
import hashlib
import hmac
import inspect
import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, AsyncIterator, Awaitable, Callable, Iterator, Mapping, Union

import httpx

FINISHED = ("succeeded", "failed", "cancelled")
# the report warnings that are a verdict against a result, not a caveat on it (the service's
# plantsolve/schemas/common.py VERDICT_CODES, stated in each report as ``verdict``; copied for reports stored
# before that field, because this module imports nothing of plantsolve)
VERDICT_CODES = frozenset({"inspection_failed", "inspection_not_determined", "inspection_not_comparable",
                           "volume_not_determined", "totals_not_determined", "rigidity_not_determined",
                           "one_piece_not_determined", "submodels_missing", "not_converged", "verification_failed",
                           "tolerance_not_reached"})
RECONNECT_SECONDS = 1.0  # pause before opening a cut event stream again
FileArgument = Union[str, Path, bytes, tuple[str, bytes]]


# ---- errors ----------------------------------------------------------------------------------


class ApiError(Exception):
    """An error answer of the API; ``problem`` is its problem document (``application/problem+json``)."""

    status = 0

    def __init__(self, problem: dict[str, Any], status: int | None = None):
        self.problem = problem
        if status is not None:
            self.status = status
        self.title = str(problem.get("title", ""))
        self.detail = problem.get("detail")
        self.errors: list[dict[str, Any]] = list(problem.get("errors") or [])
        self.extra: dict[str, Any] = dict(problem.get("extra") or {})
        super().__init__(f"{self.status} {self.title}" + (f": {self.detail}" if self.detail else ""))


class Unauthorized(ApiError):
    status = 401


class NotFound(ApiError):
    status = 404


class Conflict(ApiError):
    """The job's state does not allow this (a result before the job succeeded, a cancel after it ended)."""

    status = 409


class PayloadTooLarge(ApiError):
    status = 413


class UnsupportedMediaType(ApiError):
    status = 415


class InvalidInput(ApiError):
    """422: ``errors`` names each bad field (``loc``: its JSON path)."""

    status = 422


class ServerError(ApiError):
    status = 500


class JobFailed(Exception):
    """``wait(..., raise_on_failure=True)`` on a job that failed or was cancelled; ``job.report`` says why."""

    def __init__(self, job: "Job"):
        self.job = job
        super().__init__(f"job {job.id} {job.status}: {job.summary}")


class IntegrityError(Exception):
    """A downloaded artifact does not have the SHA-256 the job view announced."""


_ERRORS = {cls.status: cls for cls in (Unauthorized, NotFound, Conflict, PayloadTooLarge, UnsupportedMediaType,
                                        InvalidInput)}


def _raise_for_problem(response: httpx.Response) -> None:
    if response.status_code < 400:
        return
    try:
        problem = response.json()
        if not isinstance(problem, dict):
            raise ValueError
    except ValueError:
        problem = {"title": response.reason_phrase, "status": response.status_code, "detail": response.text[:500]}
    cls = _ERRORS.get(response.status_code, ServerError if response.status_code >= 500 else ApiError)
    raise cls(problem, status=response.status_code)


# ---- the job view ------------------------------------------------------------------------------


@dataclass(frozen=True)
class Job:
    """A job as ``GET /v1/jobs/{id}`` shows it; ``view`` keeps the whole document."""

    id: str
    kind: str
    status: str
    fraction: float
    message: str
    summary: str
    report: dict[str, Any] | None
    artifacts: list[dict[str, Any]] = field(default_factory=list)
    view: dict[str, Any] = field(default_factory=dict, repr=False)

    @classmethod
    def from_view(cls, view: Mapping[str, Any]) -> "Job":
        progress = view.get("progress") or {}
        return cls(id=str(view["id"]), kind=view["kind"], status=view["status"],
                   fraction=float(progress.get("fraction", 0.0)), message=str(progress.get("message", "")),
                   summary=str(view.get("summary", "")), report=view.get("report"),
                   artifacts=list(view.get("artifacts") or []), view=dict(view))

    @property
    def finished(self) -> bool:
        return self.status in FINISHED

    @property
    def warnings(self) -> list[dict[str, Any]]:
        return list((self.report or {}).get("warnings") or [])

    @property
    def verdict(self) -> dict[str, Any] | None:
        """The first warning of a succeeded job's report that says its result does not pass (``code``,
        ``message``: a failed or undetermined inspection, a fit not converged, ...), else ``None``. ``status``
        says the job ran to its end; this says whether its answer is a pass."""
        if self.status != "succeeded":
            return None
        if "verdict" in (self.report or {}):  # the service's own statement (label, code, message)
            return self.report["verdict"]
        return next((w for w in self.warnings if w.get("code") in VERDICT_CODES), None)


JobRef = Union[Job, str]


def _job_id(job: JobRef) -> str:
    return job.id if isinstance(job, Job) else str(job)


# ---- requests shared by both clients --------------------------------------------------------------


def _headers(api_key: str | None) -> dict[str, str]:
    headers = {"Accept": "application/json, application/problem+json"}
    if api_key:
        headers["Authorization"] = f"Bearer {api_key}"
    return headers


def _submit_arguments(request: Mapping[str, Any] | None, file: FileArgument | None, options: Mapping[str, Any] | None,
                      idempotency_key: str | None, callback_url: str | None) -> dict[str, Any]:
    if (request is None) == (file is None):
        raise ValueError("give either a JSON request or a file")
    headers = {"Idempotency-Key": idempotency_key} if idempotency_key else {}
    params = {"callback_url": callback_url} if callback_url else {}
    if request is not None:
        if options:
            raise ValueError("options go inside a JSON request ('options' field); the argument is for uploads")
        return {"json": dict(request), "headers": headers, "params": params}
    if isinstance(file, (str, Path)):
        path = Path(file)
        name, content = path.name, path.read_bytes()
    elif isinstance(file, bytes):
        name, content = "upload", file
    else:
        name, content = file
    data = {"options": json.dumps(dict(options))} if options else {}
    return {"files": {"file": (name, content, "application/octet-stream")}, "data": data, "headers": headers,
            "params": params}


def _list_params(kind: str | None, status: str | None, limit: int, cursor: str | None) -> dict[str, Any]:
    params: dict[str, Any] = {"limit": limit}
    if kind:
        params["kind"] = kind
    if status:
        params["status"] = status
    if cursor:
        params["cursor"] = cursor
    return params


class WebhookVerificationError(ValueError):
    """A webhook delivery that does not verify: headers missing, timestamp out of tolerance, no
    matching signature."""


class WebhookReplayed(WebhookVerificationError):
    """A delivery whose ``webhook-id`` this verifier has accepted before (a replay, or a retry of a
    delivery the receiver already took: answer 2xx without acting on it again)."""


def webhook_secret(api_key: str) -> str:
    """The webhook secret (``whsec_<base64>``, as Standard Webhooks writes secrets) that the service
    derives from an API key when WEBHOOK_SECRETS names none for its tenant."""
    key = hmac.new(api_key.encode(), b"plantsolve-webhook", hashlib.sha256).digest()
    return "whsec_" + base64.b64encode(key).decode()


def _webhook_key(secret: str | bytes) -> bytes:
    if isinstance(secret, bytes):
        return secret
    if secret.startswith("whsec_"):
        return base64.b64decode(secret[len("whsec_"):], validate=True)
    return secret.encode()  # a WEBHOOK_SECRETS value without the prefix is used as its UTF-8 bytes


class WebhookVerifier:
    """Checks completion webhooks as the Standard Webhooks specification says, for a receiver:

        verifier = WebhookVerifier(webhook_secret(api_key))      # or the WEBHOOK_SECRETS value
        view = verifier.verify(request_body, request_headers)    # the job view, or an exception

    ``webhook-signature`` must hold a ``v1,<base64 HMAC-SHA256 of "{id}.{timestamp}.{body}">`` made
    with the secret; ``webhook-timestamp`` must lie within ``tolerance_seconds`` of now; and a
    ``webhook-id`` accepted before is refused (:class:`WebhookReplayed`). Ids are remembered for the
    tolerance window only: an older delivery is refused by its timestamp anyway. The memory is this
    object's: a receiver with several processes keeps the ids in a shared store instead. A receiver
    that accepted a delivery and then failed to act on it calls :meth:`forget` so the retry passes."""

    def __init__(self, secret: str | bytes, tolerance_seconds: float = 300.0):
        self.key = _webhook_key(secret)
        if not self.key:
            raise ValueError("the webhook secret is empty")
        self.tolerance = tolerance_seconds
        self._seen: dict[str, float] = {}  # webhook-id -> its timestamp

    def verify(self, body: bytes, headers: Mapping[str, str], now: float | None = None) -> Any:
        """The JSON body when the delivery verifies; else :class:`WebhookVerificationError`."""
        lower = {k.lower(): v for k, v in headers.items()}
        msg_id, stamp, signatures = (lower.get(h) for h in ("webhook-id", "webhook-timestamp", "webhook-signature"))
        if not (msg_id and stamp and signatures):
            raise WebhookVerificationError("missing webhook-id, webhook-timestamp or webhook-signature")
        try:
            sent = int(stamp)
        except ValueError:
            raise WebhookVerificationError(f"webhook-timestamp {stamp!r} is not Unix seconds") from None
        now = time.time() if now is None else now
        if abs(now - sent) > self.tolerance:
            raise WebhookVerificationError(
                f"webhook-timestamp is {now - sent:+.0f} s from now, beyond the {self.tolerance:.0f} s tolerance")
        expected = hmac.new(self.key, f"{msg_id}.{stamp}.".encode() + body, hashlib.sha256).digest()
        for candidate in signatures.split():  # space-separated; several while a secret is rotated
            version, _, value = candidate.partition(",")
            try:
                given = base64.b64decode(value, validate=True)
            except ValueError:
                continue
            if version == "v1" and hmac.compare_digest(expected, given):
                break
        else:
            raise WebhookVerificationError("no webhook-signature matches the body with this secret")
        self._seen = {k: t for k, t in self._seen.items() if abs(now - t) <= self.tolerance}
        if msg_id in self._seen:
            raise WebhookReplayed(f"webhook-id {msg_id} was accepted before")
        self._seen[msg_id] = sent
        return json.loads(body)

    def forget(self, msg_id: str) -> None:
        """Accept ``msg_id`` once more (its handling failed, the sender's retry is wanted)."""
        self._seen.pop(msg_id, None)


def _check_sha256(content: bytes, artifact: Mapping[str, Any]) -> None:
    expected = artifact.get("sha256")
    if expected and hashlib.sha256(content).hexdigest() != expected:
        raise IntegrityError(f"artifact {artifact.get('name')!r}: SHA-256 differs from the job view's")


class EventParser:
    """Server-Sent Events, line by line: ``feed(line)`` returns ``(event, data)`` when an event is complete."""

    def __init__(self) -> None:
        self.event, self.data = "message", []

    def feed(self, line: str) -> tuple[str, str] | None:
        if not line:
            complete = (self.event, "\n".join(self.data)) if self.data else None
            self.event, self.data = "message", []
            return complete
        if line.startswith(":"):
            return None  # a comment: the keep-alive
        name, _, value = line.partition(":")
        value = value[1:] if value.startswith(" ") else value
        if name == "event":
            self.event = value
        elif name == "data":
            self.data.append(value)
        return None


class _StreamUnavailable(Exception):
    """The event stream cannot be used (not offered, not an event stream, cut): poll instead."""


def _stream_timeout(remaining: float | None) -> httpx.Timeout:
    # the server sends a comment at least every ~15 s: a silent minute means the stream is dead
    read = 60.0 if remaining is None else max(0.5, min(60.0, remaining))
    return httpx.Timeout(30.0, read=read)


Progress = Callable[[Job], Any]


# ---- the synchronous client ----------------------------------------------------------------------


class Client:
    """Talks to one plantsolve service. ``http`` may be any ``httpx.Client`` (tests pass the app's own)."""

    def __init__(self, base_url: str = "http://127.0.0.1:8000", *, api_key: str | None = None, timeout: float = 60.0,
                 http: httpx.Client | None = None):
        self._own = http is None
        self.http = http or httpx.Client(base_url=base_url, timeout=timeout)
        self.headers = _headers(api_key)

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        if self._own:
            self.http.close()

    def _request(self, method: str, url: str, **kwargs: Any) -> httpx.Response:
        headers = {**self.headers, **kwargs.pop("headers", {})}
        response = self.http.request(method, url, headers=headers, **kwargs)
        _raise_for_problem(response)
        return response

    def submit(self, kind: str, request: Mapping[str, Any] | None = None, *, file: FileArgument | None = None,
               options: Mapping[str, Any] | None = None, idempotency_key: str | None = None,
               callback_url: str | None = None) -> Job:
        """``POST /v1/<kind>/jobs``: a JSON request, or a file (a path, bytes or ``(name, bytes)``) with ``options``;
        ``callback_url``: the completion webhook."""
        arguments = _submit_arguments(request, file, options, idempotency_key, callback_url)
        return Job.from_view(self._request("POST", f"/v1/{kind}/jobs", **arguments).json())

    def job(self, job: JobRef) -> Job:
        return Job.from_view(self._request("GET", f"/v1/jobs/{_job_id(job)}").json())

    def jobs(self, *, kind: str | None = None, status: str | None = None, page_size: int = 50) -> Iterator[Job]:
        """Every job (newest first), page after page."""
        cursor = None
        while True:
            page = self._request("GET", "/v1/jobs", params=_list_params(kind, status, page_size, cursor)).json()
            yield from (Job.from_view(item) for item in page["items"])
            cursor = page.get("next_cursor")
            if not cursor:
                return

    def cancel(self, job: JobRef) -> Job:
        return Job.from_view(self._request("POST", f"/v1/jobs/{_job_id(job)}/cancel").json())

    def result(self, job: JobRef) -> dict[str, Any]:
        """The result document; :class:`Conflict` (with ``extra['report']`` for a failed job) when there is none."""
        return self._request("GET", f"/v1/jobs/{_job_id(job)}/result").json()

    def input(self, job: JobRef) -> Any:
        return self._request("GET", f"/v1/jobs/{_job_id(job)}/input").json()

    def artifact(self, job: JobRef, name: str) -> bytes:
        return self._request("GET", f"/v1/jobs/{_job_id(job)}/artifacts/{name}").content

    def download_artifacts(self, job: JobRef, directory: str | Path) -> list[Path]:
        """Every artifact of a succeeded job into ``directory``, each checked against its SHA-256."""
        job = job if isinstance(job, Job) and job.finished else self.job(job)
        folder = Path(directory)
        folder.mkdir(parents=True, exist_ok=True)
        written = []
        for artifact in job.artifacts:
            content = self._request("GET", artifact["url"]).content
            _check_sha256(content, artifact)
            target = folder / Path(artifact["name"]).name
            target.write_bytes(content)
            written.append(target)
        return written

    def wait(self, job: JobRef, *, progress: Progress | None = None, timeout: float | None = None,
             events: bool = True, poll_seconds: float = 1.0, raise_on_failure: bool = False) -> Job:
        """Block until the job has finished and return it; ``progress(job)`` is called at each change.
        :class:`TimeoutError` after ``timeout`` seconds; :class:`JobFailed` for a failed or cancelled job
        with ``raise_on_failure``."""
        job_id = _job_id(job)
        deadline = None if timeout is None else time.monotonic() + timeout
        final = None
        if events:
            try:
                final = self._follow_events(job_id, progress, deadline)
            except _StreamUnavailable:
                final = None
        if final is None:
            final = self._poll(job_id, progress, deadline, poll_seconds)
        if raise_on_failure and final.status != "succeeded":
            raise JobFailed(final)
        return final

    def _follow_events(self, job_id: str, progress: Progress | None, deadline: float | None) -> Job | None:
        last: Job | None = None
        while True:
            remaining = None if deadline is None else deadline - time.monotonic()
            if remaining is not None and remaining <= 0:
                raise TimeoutError(f"job {job_id} did not finish in time")
            try:
                with self.http.stream("GET", f"/v1/jobs/{job_id}/events", timeout=_stream_timeout(remaining),
                                      headers={**self.headers, "Accept": "text/event-stream"}) as response:
                    if response.status_code != 200 or not response.headers.get("content-type", "").startswith(
                            "text/event-stream"):
                        # an older server, a proxy, or an unknown job: polling tells which, with its error
                        raise _StreamUnavailable
                    parser = EventParser()
                    for line in response.iter_lines():
                        event = parser.feed(line)
                        if event is None:
                            if deadline is not None and time.monotonic() > deadline:
                                raise TimeoutError(f"job {job_id} did not finish in time")
                            continue
                        name, data = event
                        if name == "job":
                            last = Job.from_view(json.loads(data))
                            if progress is not None:
                                progress(last)
                        elif name == "end":
                            return last if last is not None and last.finished else self.job(job_id)
            except httpx.TransportError as error:
                if last is None:  # never got going: the stream is not usable here
                    raise _StreamUnavailable from error
            # cut in the middle (a proxy, a restart): open it again; the first event is the current state
            time.sleep(RECONNECT_SECONDS)

    def _poll(self, job_id: str, progress: Progress | None, deadline: float | None, poll_seconds: float) -> Job:
        seen = None
        while True:
            job = self.job(job_id)
            state = (job.status, job.fraction, job.message)
            if state != seen and progress is not None:
                progress(job)
            seen = state
            if job.finished:
                return job
            if deadline is not None and time.monotonic() + poll_seconds > deadline:
                raise TimeoutError(f"job {job_id} did not finish in time")
            time.sleep(poll_seconds)


# ---- the asynchronous client ---------------------------------------------------------------------


class AsyncClient:
    """:class:`Client` for asyncio; ``progress`` may be a plain function or a coroutine function."""

    def __init__(self, base_url: str = "http://127.0.0.1:8000", *, api_key: str | None = None, timeout: float = 60.0,
                 http: httpx.AsyncClient | None = None):
        self._own = http is None
        self.http = http or httpx.AsyncClient(base_url=base_url, timeout=timeout)
        self.headers = _headers(api_key)

    async def __aenter__(self) -> "AsyncClient":
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.aclose()

    async def aclose(self) -> None:
        if self._own:
            await self.http.aclose()

    async def _request(self, method: str, url: str, **kwargs: Any) -> httpx.Response:
        headers = {**self.headers, **kwargs.pop("headers", {})}
        response = await self.http.request(method, url, headers=headers, **kwargs)
        _raise_for_problem(response)
        return response

    async def submit(self, kind: str, request: Mapping[str, Any] | None = None, *, file: FileArgument | None = None,
                     options: Mapping[str, Any] | None = None, idempotency_key: str | None = None,
                     callback_url: str | None = None) -> Job:
        arguments = _submit_arguments(request, file, options, idempotency_key, callback_url)
        return Job.from_view((await self._request("POST", f"/v1/{kind}/jobs", **arguments)).json())

    async def job(self, job: JobRef) -> Job:
        return Job.from_view((await self._request("GET", f"/v1/jobs/{_job_id(job)}")).json())

    async def jobs(self, *, kind: str | None = None, status: str | None = None, page_size: int = 50) -> AsyncIterator[Job]:
        cursor = None
        while True:
            page = (await self._request("GET", "/v1/jobs", params=_list_params(kind, status, page_size, cursor))).json()
            for item in page["items"]:
                yield Job.from_view(item)
            cursor = page.get("next_cursor")
            if not cursor:
                return

    async def cancel(self, job: JobRef) -> Job:
        return Job.from_view((await self._request("POST", f"/v1/jobs/{_job_id(job)}/cancel")).json())

    async def result(self, job: JobRef) -> dict[str, Any]:
        return (await self._request("GET", f"/v1/jobs/{_job_id(job)}/result")).json()

    async def input(self, job: JobRef) -> Any:
        return (await self._request("GET", f"/v1/jobs/{_job_id(job)}/input")).json()

    async def artifact(self, job: JobRef, name: str) -> bytes:
        return (await self._request("GET", f"/v1/jobs/{_job_id(job)}/artifacts/{name}")).content

    async def download_artifacts(self, job: JobRef, directory: str | Path) -> list[Path]:
        job = job if isinstance(job, Job) and job.finished else await self.job(job)
        folder = Path(directory)
        folder.mkdir(parents=True, exist_ok=True)
        written = []
        for artifact in job.artifacts:
            content = (await self._request("GET", artifact["url"])).content
            _check_sha256(content, artifact)
            target = folder / Path(artifact["name"]).name
            target.write_bytes(content)
            written.append(target)
        return written

    async def wait(self, job: JobRef, *, progress: Callable[[Job], Any] | None = None, timeout: float | None = None,
                   events: bool = True, poll_seconds: float = 1.0, raise_on_failure: bool = False) -> Job:
        job_id = _job_id(job)

        async def report(current: Job) -> None:
            if progress is not None:
                outcome = progress(current)
                if inspect.isawaitable(outcome):
                    await outcome

        async def follow() -> Job:
            if events:
                try:
                    final = await self._follow_events(job_id, report)
                    if final is not None:
                        return final
                except _StreamUnavailable:
                    pass
            return await self._poll(job_id, report, poll_seconds)

        try:
            final = await asyncio.wait_for(follow(), timeout)
        except asyncio.TimeoutError:
            raise TimeoutError(f"job {job_id} did not finish in time") from None
        if raise_on_failure and final.status != "succeeded":
            raise JobFailed(final)
        return final

    async def _follow_events(self, job_id: str, report: Callable[[Job], Awaitable[None]]) -> Job | None:
        last: Job | None = None
        while True:
            try:
                async with self.http.stream("GET", f"/v1/jobs/{job_id}/events", timeout=_stream_timeout(None),
                                            headers={**self.headers, "Accept": "text/event-stream"}) as response:
                    if response.status_code != 200 or not response.headers.get("content-type", "").startswith(
                            "text/event-stream"):
                        # an older server, a proxy, or an unknown job: polling tells which, with its error
                        raise _StreamUnavailable
                    parser = EventParser()
                    async for line in response.aiter_lines():
                        event = parser.feed(line)
                        if event is None:
                            continue
                        name, data = event
                        if name == "job":
                            last = Job.from_view(json.loads(data))
                            await report(last)
                        elif name == "end":
                            return last if last is not None and last.finished else await self.job(job_id)
            except httpx.TransportError as error:
                if last is None:
                    raise _StreamUnavailable from error
            await asyncio.sleep(RECONNECT_SECONDS)

    async def _poll(self, job_id: str, report: Callable[[Job], Awaitable[None]], poll_seconds: float) -> Job:
        seen = None
        while True:
            job = await self.job(job_id)
            state = (job.status, job.fraction, job.message)
            if state != seen:
                await report(job)
            seen = state
            if job.finished:
                return job
            await asyncio.sleep(poll_seconds)


__all__ = [
    "Client", "AsyncClient", "Job", "EventParser", "ApiError", "Unauthorized", "NotFound", "Conflict",
    "PayloadTooLarge", "UnsupportedMediaType", "InvalidInput", "ServerError", "JobFailed", "IntegrityError",
    "WebhookVerifier", "WebhookVerificationError", "WebhookReplayed", "webhook_secret",
]
