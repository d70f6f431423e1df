"""Uploads: a JSON request (the same document as the JSON body)."""

from __future__ import annotations

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.base import StoredInput, decode_text, json_object, reject
from plantsolve.solvers.other_kinds import refuse_other_kind
from plantsolve.solvers.upload_form import FormRules, request_of_file

UPLOAD_EXTENSIONS = (".json",)
FORM = FormRules(FlowmeterRequest, units="file")


def parse_upload(source: StoredInput, options: dict | None) -> FlowmeterRequest:
    """A JSON request file with the upload form's ``options`` joined to it by the rules of
    :mod:`plantsolve.solvers.upload_form` (the form's ``units`` is that of a file that states none)."""
    content = source.read()
    if not content.strip():
        raise reject("the file is empty")
    text = decode_text(content, "JSON file")
    body = json_object(text, refuse_cut=True)
    refuse_other_kind(body, "flowmeter")
    return request_of_file(body, options, FORM)
