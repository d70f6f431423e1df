"""Uploads: an ``.ifc`` (STEP physical file) or ``.ifczip`` as the multipart ``file``, options as the
form's ``options`` JSON (``sharing``, ``tolerance``, ``allow_mirror``, ``allow_scale``, ``postpass``,
``entity_types``); or a ``.json`` request with the file base64-encoded. The uploaded bytes are kept as
received (no base64 copy); the solver writes them to a temporary file for IfcOpenShell."""

from __future__ import annotations


from pydantic import ValidationError

from plantsolve.schemas.dedup import DedupOptions, DedupRequest
from plantsolve.solvers.base import FieldError, InputRejected, json_object, reject, upload_extension
from plantsolve.solvers.dedup.ifcio import check_header

UPLOAD_EXTENSIONS = (".ifc", ".ifczip", ".json")


def _options(options: dict | None) -> DedupOptions:
    if not options:
        return DedupOptions()
    options = dict(options.get("options", options)) if isinstance(options, dict) else options
    if not isinstance(options, dict):
        raise reject("options must be a JSON object", ("options",))
    try:
        return DedupOptions.model_validate(options)
    except ValidationError as e:
        raise InputRejected([FieldError(("options", *err["loc"]), err["msg"], err.get("type", "value_error"))
                             for err in e.errors()[:50]]) from None


def parse_upload(filename: str, content: bytes, options: dict | None) -> DedupRequest:
    ext = upload_extension(filename, UPLOAD_EXTENSIONS)
    if not content.strip():
        raise reject("the file is empty")
    if ext == ".json":
        body = json_object(content)
        if options:
            body = {**body, "options": {**(body.get("options") or {}), **_options(options).model_dump(exclude_unset=True)}}
        try:
            return DedupRequest.model_validate(body)
        except ValidationError as e:
            raise InputRejected([FieldError(("file", *err["loc"]), err["msg"], err.get("type", "value_error"))
                                 for err in e.errors()[:50]]) from None
    if ext == ".ifc":
        check_header(content)
    elif content[:4] != b"PK\x03\x04":
        raise reject("not an .ifczip: a zip archive starts with 'PK'")
    request = DedupRequest(filename=filename[-255:], options=_options(options))
    request._content = content
    return request
