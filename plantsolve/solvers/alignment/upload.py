"""Uploaded files: ``.pcf`` (ISOGEN) or ``.json`` (an AlignmentRequest body)."""

from __future__ import annotations

import codecs

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.solvers.alignment.pcf import parse_pcf, read_document
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
)
from plantsolve.solvers.upload_form import FormRules, read_form, request_of_file

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


FORM = FormRules(AlignmentRequest, units="file")


def _refuse_units_option(text: str, options: dict | None) -> None:
    """A 422 naming ``options.units`` given with a PCF, and saying what decides a PCF's units: its UNITS-CO-ORDS and
    UNITS-BORE records (millimetres without them), which the option would contradict or repeat. It was refused as
    'Extra inputs are not permitted', which said neither. The form's other options are checked along with it."""
    if not isinstance(options, dict) or "units" not in options:
        return
    doc = read_document(text)  # the file's UNITS records, at the margin or indented in its header, not an item's
    stated = [f"{' '.join(doc.lines[i].split()[:2])} (line {i + 1})" for i in doc.unit_lines][:4]
    errors = [FieldError(("options", "units"), (
        "a PCF states its own units: its UNITS-CO-ORDS record gives the coordinates' unit (millimetres without one) "
        "and UNITS-BORE the bores' (the coordinates' without one); an option does not override them: "
        + (f"this file states {', '.join(stated)}. " if stated else "this file states neither, so it is read in "
           "millimetres. ")
        + "Leave options.units out, or correct those records if the file's numbers are in another unit"),
        "extra_forbidden")]
    try:
        read_form({key: value for key, value in options.items() if key != "units"}, FORM)
    except InputRejected as error:
        errors.extend(error.errors)
    raise InputRejected(errors)


def parse_upload(source: StoredInput, options: dict | None) -> AlignmentRequest:
    """The request of an uploaded PCF or JSON file (its extension checked by the intake), with the upload form's
    ``options`` joined to it by the rules of :mod:`plantsolve.solvers.upload_form` (a PCF takes no ``units``: it
    states its own)."""
    content = source.read()
    if binary_stl(content[:134]):  # every byte decodes as latin-1: said before it is
        raise reject("this is a binary STL mesh, not a PCF or an alignment JSON request (a mesh is a polyhedra "
                     "or tube input)")
    text, encoding = _decoded(content)
    if source.extension == ".pcf":
        refuse_other_text(text)
        _refuse_units_option(text, options)
        form = read_form(options, FORM)
        try:
            request = parse_pcf(text, form.read)
        except InputRejected as rejected:  # an option the PCF's reading refuses (a fixed component it lacks)
            raise InputRejected([form.named(e) or e for e in rejected.errors]) from None
        return request.model_copy(update={"source_encoding": encoding})
    body = json_object(text, refuse_cut=True)
    refuse_other_json(body)
    return request_of_file(body, options, FORM)
