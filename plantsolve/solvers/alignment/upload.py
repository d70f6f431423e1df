"""Uploaded files: ``.pcf`` (ISOGEN) or ``.json`` (an AlignmentRequest body)."""

from __future__ import annotations

import codecs

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.solvers.alignment.pcf import options_from, parse_pcf
from plantsolve.solvers.alignment.sniff import (
    refuse_other_json,
    refuse_other_text,
)
from plantsolve.solvers.base import (
    FieldError,
    InputRejected,
    StoredInput,
    binary_stl,
    file_options,
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


_UNIT_RECORDS = ("UNITS-CO-ORDS", "UNITS-BORE")


def _refuse_units_option(text: str, options: dict | None) -> None:
    """A 422 naming ``options.units`` given with a PCF, and saying what decides a PCF's units: its UNITS-CO-ORDS and
    UNITS-BORE records (millimetres without them), which the option would contradict or repeat. It was refused as
    'Extra inputs are not permitted', which said neither. The form's other options are checked along with it."""
    if not isinstance(options, dict) or "units" not in options:
        return
    stated = [f"{' '.join(line.split()[:2])} (line {i + 1})" for i, line in enumerate(text.splitlines())
              if line[:1].strip() and line.split()[0].upper() in _UNIT_RECORDS][:4]
    errors = [FieldError(("options", "units"), (
        "a PCF states its own units: its UNITS-CO-ORDS record gives the coordinates' unit (millimetres without one) "
        "and UNITS-BORE the bores' (the coordinates' without one); an option does not override them: "
        + (f"this file states {', '.join(stated)}. " if stated else "this file states neither, so it is read in "
           "millimetres. ")
        + "Leave options.units out, or correct those records if the file's numbers are in another unit"),
        "extra_forbidden")]
    try:
        options_from({key: value for key, value in options.items() if key != "units"})
    except InputRejected as error:
        errors.extend(error.errors)
    raise InputRejected(errors)


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
        _refuse_units_option(text, options)
        return parse_pcf(text, options).model_copy(update={"source_encoding": encoding})
    body = json_object(text, refuse_cut=True)
    refuse_other_json(body)
    if "units" in body:
        body["units"] = _unit(body["units"], ("file", "units"))
    if options and not isinstance(options, dict):
        raise InputRejected([FieldError(("options",), "options must be an object")])
    form = dict(options or {})
    if form:
        if "units" in form:
            body["units"] = _form_unit(body.get("units"), form.pop("units"))
        inner = file_options(body)
        if form:
            body["options"] = {**inner, **form}
    try:
        return validated(AlignmentRequest, body, ())
    except InputRejected as error:  # a value the form gave is named as the form names it, the file's by the file
        raise InputRejected([FieldError(e.loc if e.loc[:1] == ("options",) and e.loc[1:2] and e.loc[1] in form
                                        else ("file", *e.loc), e.msg, e.type) for e in error.errors]) from None


def _unit(given, loc: tuple) -> object:
    """A request's unit by any of its spellings ('MM', 'millimetres'); what is no text is left to the schema."""
    if not isinstance(given, str):
        return given
    try:
        return request_unit(given)
    except ValueError as exc:
        raise InputRejected([FieldError(loc, str(exc))]) from None


def _form_unit(stated, given) -> object:
    """The form's ``units`` for a JSON file: the unit of a file that states none; the file's own when it states one,
    which the form may repeat but not contradict (which of the two the numbers are in is not known). It was laid
    into the request's options and refused as 'Extra inputs are not permitted', named inside the file."""
    unit = _unit(given, ("options", "units"))
    if stated is not None and unit != stated:
        raise InputRejected([FieldError(("options", "units"), (
            f"options.units {given!r} contradicts the file's units {stated!r}: say which is right (leave the option "
            "out to use the file's, or correct the file)"))])
    return unit
