"""Uploads: a JSON request (the same document as the JSON body)."""

from __future__ import annotations

from dataclasses import replace

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.base import InputRejected, StoredInput, decode_text, file_options, json_object, reject, validated
from plantsolve.solvers.other_kinds import refuse_other_kind

UPLOAD_EXTENSIONS = (".json",)


def parse_upload(source: StoredInput, options: dict | None) -> FlowmeterRequest:
    """A JSON request file; ``options`` (the upload form's options) override the file's options."""
    content = source.read()
    if not content.strip():
        raise reject("the file is empty")
    text = decode_text(content, "JSON file")
    body = json_object(text, refuse_cut=True)
    refuse_other_kind(body, "flowmeter")
    if options:
        body = {**body, "options": {**file_options(body), **options}}
    try:
        return validated(FlowmeterRequest, body)
    except InputRejected as exc:
        if not options:
            raise
        # the form's options are merged over the file's: their errors name the form field, not the file
        raise InputRejected([replace(e, loc=e.loc[1:]) if e.loc[1:2] == ("options",) else e
                             for e in exc.errors]) from None
