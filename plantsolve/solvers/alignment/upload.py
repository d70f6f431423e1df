"""Uploaded files: ``.pcf`` (ISOGEN) or ``.json`` (an AlignmentRequest body)."""

from __future__ import annotations

import json

from pydantic import ValidationError

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.solvers.alignment.pcf import parse_pcf
from plantsolve.solvers.base import FieldError, InputRejected

UPLOAD_EXTENSIONS = (".pcf", ".json")


def parse_upload(filename: str, content: bytes, options: dict | None) -> AlignmentRequest:
    name = (filename or "").lower()
    ext = next((e for e in UPLOAD_EXTENSIONS if name.endswith(e)), None)
    if ext is None:
        raise InputRejected([FieldError(("file",), f"unsupported file type {filename!r}; expected one of {UPLOAD_EXTENSIONS}")])
    encoding = "utf-8-sig" if content.startswith(b"\xef\xbb\xbf") else "utf-8"
    for enc in (encoding, "cp1252", "latin-1"):  # latin-1 decodes every byte
        try:
            text = content.decode(enc)
            break
        except UnicodeDecodeError:
            continue
    encoding = enc
    try:
        if ext == ".json":
            body = json.loads(text)
            if not isinstance(body, dict):
                raise InputRejected([FieldError(("file",), "JSON upload must be an object (an alignment request)")])
            if options:
                if not isinstance(options, dict):
                    raise InputRejected([FieldError(("options",), "options must be an object")])
                inner = body.get("options") or {}
                if not isinstance(inner, dict):
                    raise InputRejected([FieldError(("file", "options"), "options must be an object")])
                body["options"] = {**inner, **options}
            return AlignmentRequest.model_validate(body)
        return parse_pcf(text, options).model_copy(update={"source_encoding": encoding})
    except json.JSONDecodeError as exc:
        raise InputRejected([FieldError(("file",), f"invalid JSON: {exc}")]) from exc
    except ValidationError as exc:
        errs = [FieldError(("file",) + tuple(e["loc"]), e["msg"]) for e in exc.errors()]
        raise InputRejected(errs) from exc
