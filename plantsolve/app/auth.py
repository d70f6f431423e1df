"""Optional API keys: with ``API_KEYS`` set, every /v1 call needs ``Authorization: Bearer <key>``."""

from __future__ import annotations

import hmac

from fastapi import Request

from plantsolve.app.problems import Unauthorized


def require_api_key(request: Request) -> None:
    keys: list[str] = request.app.state.settings.api_keys
    if not keys:
        return
    header = request.headers.get("authorization", "")
    scheme, _, token = header.partition(" ")
    if scheme.lower() != "bearer" or not token:
        raise Unauthorized("Send 'Authorization: Bearer <key>'.")
    if not any(hmac.compare_digest(token.strip().encode(), key.encode()) for key in keys):
        raise Unauthorized("The API key is not valid.")
