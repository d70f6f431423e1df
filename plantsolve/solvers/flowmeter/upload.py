"""Uploads: a JSON request (the same document as the JSON body)."""

from __future__ import annotations


from pydantic import ValidationError

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.base import FieldError, InputRejected, json_object, reject, upload_extension

UPLOAD_EXTENSIONS = (".json",)


def parse_upload(filename: str, content: bytes, options: dict | None) -> FlowmeterRequest:
    """A JSON request file; ``options`` (the upload form's options) override the file's options."""
    upload_extension(filename, UPLOAD_EXTENSIONS)
    if not content.strip():
        raise reject("the file is empty")
    try:
        text = content.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise reject(f"invalid JSON: {e}") from None
    body = json_object(text)
    if options:
        body = {**body, "options": {**(body.get("options") or {}), **options}}
    try:
        return FlowmeterRequest.model_validate(body)
    except ValidationError as e:
        raise InputRejected([
            FieldError(tuple(err["loc"]) if options and tuple(err["loc"])[:1] == ("options",) else ("file", *err["loc"]),
                       err["msg"], err.get("type", "value_error"))
            for err in e.errors()]) from None
