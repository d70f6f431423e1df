"""Intake: a submission read into the kind's input, and checked, once.

At submission :func:`read_json` or :func:`read_upload` turns the body (or the uploaded file and
the form's ``options``) into the kind's input value and :func:`check` runs the kind's checks
across fields: the only place they run. The extension of an upload is checked here and nowhere
else. A worker re-reads the stored input with :func:`read_stored` and does not check it again:
what was stored is what passed. The stored input comes from the blob store, which may be on another
machine: an upload is handed to the kind as a local file (the local back-end's own, else a temporary
copy that lives as long as the ``with`` block of :func:`read_stored`).

Every refusal is an :class:`~plantsolve.jobs.errors.Unprocessable` (422) or
:class:`~plantsolve.jobs.errors.UnsupportedMediaType` (415) naming the field.
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import Any, Iterator

from pydantic import ValidationError

from plantsolve.jobs.errors import (
    Unprocessable,
    UnsupportedMediaType,
    field_problem,
    from_input_rejected,
    from_validation_error,
    loads_bounded,
)
from plantsolve.solvers.base import InputRejected, SolverError, SolverSpec, StoredInput
from plantsolve.store.blobs import BlobMissing, BlobStore
from plantsolve.store.models import Job


def read_json(spec: SolverSpec, body: bytes) -> tuple[Any, Any]:
    """The body as parsed JSON (what is stored) and the kind's input value made from it."""
    raw = loads_bounded(body, [], "The body")
    try:
        # strict JSON: a number is a number (no `false` for 0, no "5" for 5), as the schema says
        request = spec.request_model.model_validate_json(body, strict=True)
    except ValidationError as error:
        raise from_validation_error(error, document=raw) from None
    return raw, _input(spec, request)


def upload_extension(spec: SolverSpec, filename: str) -> str:
    """The upload's extension when the kind reads it; else a 415 listing the ones it does."""
    if spec.parse_upload is None or not spec.upload_extensions:
        raise UnsupportedMediaType(f"Solver kind {spec.kind!r} takes JSON bodies only.")
    extension = StoredInput(filename, content=b"").extension
    if extension not in spec.upload_extensions:
        raise UnsupportedMediaType(
            f"File type {extension or '(none)'!r} is not accepted by {spec.kind!r}; "
            f"accepted: {', '.join(spec.upload_extensions)}."
        )
    return extension


def upload_options(options_text: str | None) -> dict | None:
    """The multipart ``options`` field: a JSON object, or nothing."""
    if not options_text:
        return None
    options = loads_bounded(options_text, ["options"], "The 'options' form field")
    if not isinstance(options, dict):
        raise Unprocessable("The 'options' form field must be a JSON object.",
                            errors=[field_problem(["options"], "must be a JSON object", "dict_type")])
    return options


def read_upload(spec: SolverSpec, source: StoredInput, options: dict | None) -> Any:
    """The kind's input value read from an uploaded file (whose extension :func:`upload_extension` passed)."""
    if source.size == 0:
        raise Unprocessable("The uploaded file is empty.", errors=[field_problem(["file"], "empty file", "value_error")])
    try:
        request = spec.parse_upload(source, options)
    except InputRejected as error:
        raise from_input_rejected(error) from None
    except ValidationError as error:
        raise from_validation_error(error) from None
    except RecursionError:
        raise Unprocessable("The uploaded file is nested too deeply to be read.",
                            errors=[field_problem(["file"], "nested too deeply", "json_too_deep")]) from None
    return _input(spec, request, source)


def check(spec: SolverSpec, job_input: Any) -> None:
    """The kind's checks across fields; run once, at submission."""
    if spec.check_input is None:
        return
    try:
        spec.check_input(job_input)
    except InputRejected as error:
        raise from_input_rejected(error) from None


@contextmanager
def read_stored(spec: SolverSpec, job: Job, files: BlobStore) -> Iterator[Any]:
    """The kind's input value re-read from a job's stored input (in the worker; not checked again), for
    the duration of the ``with`` block (a temporary copy of an upload is removed after it)."""
    try:
        if job.input_kind == "json":
            yield spec.input_of(spec.request_model.model_validate(job.input))
        elif job.input_kind == "json_file":
            yield spec.input_of(spec.request_model.model_validate_json(files.get(job.input_file)))
        elif job.input_kind == "upload":
            if spec.parse_upload is None:
                raise SolverError("input", f"solver kind {spec.kind!r} accepts no file uploads")
            with files.local_file(job.input_file, job.input_filename or "") as path:
                source = StoredInput.from_path(path, job.input_filename)
                yield spec.input_of(spec.parse_upload(source, job.input_options), source)
        else:
            raise SolverError("input", f"unknown input kind {job.input_kind!r}")
    except BlobMissing:
        raise SolverError("input", "The submitted input is missing from the blob store (deleted, or a BLOB_STORE "
                          "other than the one it was submitted to).") from None


def _input(spec: SolverSpec, request: Any, source: StoredInput | None = None) -> Any:
    try:
        return spec.input_of(request, source)
    except InputRejected as error:
        raise from_input_rejected(error) from None
    except ValidationError as error:
        raise from_validation_error(error) from None
