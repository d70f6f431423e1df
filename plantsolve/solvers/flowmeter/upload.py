"""Uploads: a JSON request (the same document as the JSON body)."""

from __future__ import annotations

import json

from pydantic import ValidationError

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.base import FieldError, InputRejected, reject

UPLOAD_EXTENSIONS = (".json",)


def parse_upload(filename: str, content: bytes, options: dict | None) -> FlowmeterRequest:
    """A JSON request file; ``options`` (the upload form's options) override the file's options."""
    ext = "." + filename.rsplit(".", 1)[-1].lower() if "." in filename else ""
    if ext not in UPLOAD_EXTENSIONS:
        raise reject(f"unsupported file type {ext or '(none)'!r}; accepted: {', '.join(UPLOAD_EXTENSIONS)}")
    if not content.strip():
        raise reject("the file is empty")
    try:
        body = json.loads(content.decode("utf-8-sig"))
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise reject(f"invalid JSON: {e}") from None
    if not isinstance(body, dict):
        raise reject("the JSON file must hold a request object")
    if options:
        body = {**body, "options": {**(body.get("options") or {}), **options}}
    try:
        return FlowmeterRequest.model_validate(body)
    except ValidationError as e:
        raise InputRejected([
            FieldError(tuple(err["loc"]) if options and tuple(err["loc"])[:1] == ("options",) else ("file", *err["loc"]),
                       err["msg"], err.get("type", "value_error"))
            for err in e.errors()]) from None
