"""HTTP settings: API keys, body limits, schema migration at start-up.

:class:`AppSettings` extends the job settings (the API process also takes jobs in, runs the
sweeper and, on the embedded default, the pool); see :mod:`plantsolve.store.settings` for the layering.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Annotated

from pydantic import Field, field_validator
from pydantic_settings import NoDecode

from plantsolve.jobs.settings import JobSettings, split_commas


class AppSettings(JobSettings):
    api_keys: Annotated[list[str], NoDecode] = Field(
        default_factory=list,
        description="Comma-separated API keys, each 'name:key' or a bare key; each key is a tenant that sees only "
        "its own jobs. When set, every /v1 call needs 'Authorization: Bearer <key>'.",
    )
    admin_keys: Annotated[list[str], NoDecode] = Field(
        default_factory=list, description="Comma-separated keys that see every tenant's jobs."
    )
    protect_docs: bool = Field(default=True, description="With keys set, /docs, /redoc and /openapi.json need a key too.")
    cors_origins: Annotated[list[str], NoDecode] = Field(
        default_factory=list, description="Comma-separated origins allowed to call the API from a browser (CORS off when empty)."
    )
    forwarded_allow_ips: Annotated[list[str], NoDecode] = Field(
        default_factory=list,
        description="Comma-separated addresses (or networks, or '*') of reverse proxies whose X-Forwarded-For and "
        "X-Forwarded-Proto are believed: the client address (the login limit's key) and the scheme come from "
        "those headers only when the connection comes from one of them. Empty: the headers are ignored, "
        "loopback included.",
    )
    login_secret: str | None = Field(
        default=None, min_length=16,
        description="Key signing the login form's CSRF token (every API process must share it). Unset: derived "
        "from API_KEYS and ADMIN_KEYS, which every process shares already.",
    )
    max_body_bytes: int = Field(default=200 * 1024 * 1024, description="Largest accepted request body (413 above).")
    body_idle_seconds: float = Field(
        default=30.0, gt=0, le=3600,
        description="Longest wait for the next bytes of a request body that has begun (408 after it): a client that "
                    "stops half way, or sends less than it declared, holds no connection longer.")
    max_upload_bytes: int = Field(default=64 * 1024 * 1024, description="Largest accepted uploaded file (413 above).")
    auto_migrate: bool = Field(default=True, description="Upgrade the database schema when the API starts.")
    events_poll_seconds: float = Field(
        default=0.5, gt=0, le=60,
        description="How often an open event stream (/events) reads the jobs' status and progress from the database.",
    )
    events_ping_seconds: float = Field(
        default=15.0, gt=0, le=3600, description="Period of the keep-alive comment on an open event stream."
    )
    events_outage_seconds: float = Field(
        default=30.0, gt=0, le=3600,
        description="Longest an open event stream pauses while the database is away: then it sends an 'error' event "
        "(a 503 problem) with a retry hint and ends.")

    webhook_secrets: Annotated[list[str], NoDecode] = Field(
        default_factory=list,
        description="Comma-separated 'tenant:secret' (or one bare secret for every tenant) signing the completion "
        "webhooks per Standard Webhooks: 'whsec_<base64>' (the decoded bytes are the key; text without the prefix "
        "is used as its UTF-8 bytes); a tenant without one gets the secret derived from its API key "
        "(plantsolve.client.webhook_secret(key)).",
    )
    webhook_private_targets: bool = Field(
        default=False, description="Allow webhooks to loopback, private, link-local and other non-public addresses "
        "(a receiver on the same host or network). Off: such a callback_url is refused at submission (any spelling of "
        "an inside address, or a name that resolves to one) and a delivery connects only to the address it checked, "
        "so a tenant cannot make the service call its internal network.")
    webhook_max_attempts: int = Field(default=6, ge=1, le=50, description="Deliveries tried before a webhook is given up.")
    webhook_retry_seconds: float = Field(
        default=2.0, gt=0, le=3600, description="First retry delay of a webhook; doubled after each failed delivery."
    )
    webhook_timeout_seconds: float = Field(default=10.0, gt=0, le=300, description="Timeout of one webhook delivery.")
    webhook_poll_seconds: float = Field(
        default=1.0, gt=0, le=60, description="How often the API process looks for finished jobs with a webhook to send."
    )

    @field_validator("api_keys", "admin_keys", "cors_origins", "webhook_secrets", "forwarded_allow_ips", mode="before")
    @classmethod
    def _split_keys(cls, value: object) -> object:
        return split_commas(value)


@lru_cache
def get_settings() -> AppSettings:
    return AppSettings()
