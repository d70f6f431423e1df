"""Uploaded files: ``.pcf`` (ISOGEN) or ``.json`` (an AlignmentRequest body)."""

from __future__ import annotations

import codecs

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.solvers.alignment.pcf import parse_pcf
from plantsolve.solvers.alignment.sniff import (
    refuse_other_json,
    refuse_other_text,
)
from plantsolve.solvers.base import (
    FieldError,
    InputRejected,
    StoredInput,
    binary_stl,
    json_object,
    reject,
    utf16_without_mark,
    validated,
)
from plantsolve.solvers.length_units import request_unit

UPLOAD_EXTENSIONS = (".pcf", ".json")


def _decoded(content: bytes) -> tuple[str, str]:
    """The text and the encoding it was read with (the aligned PCF is written back in it)."""
    if content[:2] in (codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE):  # Windows "Unicode" text: read as such, not
        try:  # as cp1252 bytes in which no keyword is found
            return content.decode("utf-16"), "utf-16"
        except UnicodeDecodeError:
            pass
    if b"\x00" in content[:4096] and (text := utf16_without_mark(content)) is not None:
        return text, "utf-16-le" if content[1:2] == b"\x00" else "utf-16-be"
    encoding = "utf-8-sig" if content.startswith(b"\xef\xbb\xbf") else "utf-8"
    for enc in (encoding, "cp1252"):
        try:
            return content.decode(enc), enc
        except UnicodeDecodeError:
            continue
    return content.decode("latin-1"), "latin-1"  # latin-1 decodes every byte


def parse_upload(source: StoredInput, options: dict | None) -> AlignmentRequest:
    """The request of an uploaded PCF or JSON file (its extension checked by the intake); ``options``
    (the upload form's) override options given inside a JSON file."""
    content = source.read()
    if binary_stl(content[:134]):  # every byte decodes as latin-1: said before it is
        raise reject("this is a binary STL mesh, not a PCF or an alignment JSON request (a mesh is a polyhedra "
                     "or tube input)")
    text, encoding = _decoded(content)
    if source.extension == ".pcf":
        refuse_other_text(text)
        return parse_pcf(text, options).model_copy(update={"source_encoding": encoding})
    body = json_object(text, refuse_cut=True)
    refuse_other_json(body)
    if isinstance(body.get("units"), str):  # 'MM', 'millimetres': the unit by any of its spellings
        try:
            body["units"] = request_unit(body["units"])
        except ValueError as exc:
            raise InputRejected([FieldError(("file", "units"), str(exc))]) from None
    if options:
        if not isinstance(options, dict):
            raise InputRejected([FieldError(("options",), "options must be an object")])
        inner = body.get("options") or {}
        if not isinstance(inner, dict):
            raise InputRejected([FieldError(("file", "options"), "options must be an object")])
        body["options"] = {**inner, **options}
    return validated(AlignmentRequest, body)
