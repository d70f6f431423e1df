"""Uploads: an ``.ifc`` (STEP physical file) or ``.ifczip`` as the multipart ``file``, options as the
form's ``options`` JSON (``sharing``, ``tolerance``, ``allow_mirror``, ``allow_scale``, ``postpass``,
``entity_types``); or a ``.json`` request with the file base64-encoded. An uploaded model is not copied:
the request names it, and the solve opens the stored file (:mod:`.source`)."""

from __future__ import annotations

from plantsolve.schemas.dedup import DedupOptions, DedupRequest
from plantsolve.solvers.base import StoredInput, file_options, json_object, reject, validated
from plantsolve.solvers.dedup.ifcio import HEADER_BYTES, check_header
from plantsolve.solvers.dedup.source import ZIP_MAGIC, ends, is_blank
from plantsolve.solvers.other_kinds import refuse_other_kind
from plantsolve.solvers.step_file import TRAILER_BYTES

UPLOAD_EXTENSIONS = (".ifc", ".ifczip", ".json")


def _options(options: dict | None) -> DedupOptions:
    if not options:
        return DedupOptions()
    options = dict(options.get("options", options)) if isinstance(options, dict) else options
    if not isinstance(options, dict):
        raise reject("options must be a JSON object", ("options",))
    return validated(DedupOptions, options, ("options",))


def parse_upload(source: StoredInput, options: dict | None) -> DedupRequest:
    """The request of an upload (intake checked its extension); an IFC file is only looked at, not read."""
    if is_blank(source):
        raise reject("the file is empty")
    if source.extension == ".json":
        body = json_object(source.read(), refuse_cut=True)
        refuse_other_kind(body, "dedup")
        if options:
            body = {**body, "options": {**file_options(body), **_options(options).model_dump(exclude_unset=True)}}
        return validated(DedupRequest, body, ("file",))
    head, tail = ends(source, HEADER_BYTES, TRAILER_BYTES)
    if source.extension == ".ifc":
        check_header(head, tail)
    elif head[:4] != ZIP_MAGIC:
        raise reject("not an .ifczip: a zip archive starts with 'PK'")
    return DedupRequest(filename=source.name[-255:], options=_options(options))
