"""Uploads: an ``.ifc`` (STEP physical file) or ``.ifczip`` as the multipart ``file``, options as the
form's ``options`` JSON (``sharing``, ``tolerance``, ``allow_mirror``, ``allow_scale``, ``postpass``,
``entity_types``); or a ``.json`` request with the file base64-encoded. An uploaded model is not copied:
the request names it, and the solve opens the stored file (:mod:`.source`)."""

from __future__ import annotations

from plantsolve.schemas.dedup import DedupRequest
from plantsolve.solvers.base import StoredInput, json_object, reject
from plantsolve.solvers.dedup.ifcio import HEADER_BYTES, check_header
from plantsolve.solvers.dedup.source import ZIP_MAGIC, ends, is_blank
from plantsolve.solvers.other_kinds import refuse_other_kind
from plantsolve.solvers.step_file import TRAILER_BYTES
from plantsolve.solvers.upload_form import FormRules, read_form, request_of_file

UPLOAD_EXTENSIONS = (".ifc", ".ifczip", ".json")


FORM = FormRules(DedupRequest, units=None, no_units=(
    "a dedup request has no units: an IFC model states its own length unit (IfcUnitAssignment), and the result's "
    "lengths are in it"))


def parse_upload(source: StoredInput, options: dict | None) -> DedupRequest:
    """The request of an upload (intake checked its extension), with the upload form's ``options`` joined to it by
    the rules of :mod:`plantsolve.solvers.upload_form`; an IFC file is only looked at, not read."""
    if is_blank(source):
        raise reject("the file is empty")
    if source.extension == ".json":
        body = json_object(source.read(), refuse_cut=True)
        refuse_other_kind(body, "dedup")
        return request_of_file(body, options, FORM)
    head, tail = ends(source, HEADER_BYTES, TRAILER_BYTES)
    if source.extension == ".ifc":
        check_header(head, tail)
    elif head[:4] != ZIP_MAGIC:
        raise reject("not an .ifczip: a zip archive starts with 'PK'")
    return DedupRequest(filename=source.name[-255:], options=read_form(options, FORM).read)
