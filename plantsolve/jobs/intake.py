"""Intake: a submission read into the kind's input, and checked, once.

At submission :func:`read_json` or :func:`read_upload` turns the body (or the uploaded file and
the form's ``options``) into the kind's input value and :func:`check` runs the kind's checks
across fields: the only place they run. The extension of an upload is checked here and nowhere
else. A worker re-reads the stored input with :func:`read_stored` and does not check it again:
what was stored is what passed. The stored input comes from the blob store, which may be on another
machine: an upload is handed to the kind as a local file (the local back-end's own, else a temporary
copy that lives as long as the ``with`` block of :func:`read_stored`).

Uploads are read outside the API process: :func:`read_upload_bounded` runs
:func:`read_upload` and :func:`check` on the stored file in a child process forked from a forkserver
that has the kinds' readers imported, with its address space limited to ``UPLOAD_READ_MEMORY`` bytes beyond what
it starts with (RLIMIT_AS) and its CPU time to ``UPLOAD_READ_SECONDS`` (RLIMIT_CPU: a busy machine must not turn
a file that reads in 5 CPU seconds into a refusal; the API's wall-clock wait, ``UPLOAD_READ_WALL_FACTOR`` times
that, is the backstop for a reader that waits instead of computing). The child sends back only the outcome (accepted, or the 422's fields), so a zip
bomb or a parser that runs away costs the child, never the API process, and is a 422 naming ``file``.
The answer stays synchronous: a bad upload is a 422 at submission, as before. Before it, cheap checks
run in the API: the extension, and the line count of text uploads (:data:`MAX_TEXT_LINES`).

Every refusal is an :class:`~plantsolve.jobs.errors.Unprocessable` (422) or
:class:`~plantsolve.jobs.errors.UnsupportedMediaType` (415) naming the field.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import multiprocessing
import pickle
import resource
import signal
import threading
import time
import traceback
from contextlib import contextmanager
from multiprocessing import forkserver
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator

from pydantic import ValidationError

from plantsolve.jobs.backoff import FORKSERVER_RESTARTS, Backoff
from plantsolve.jobs.errors import (
    ReadersPaused,
    Unprocessable,
    UnsupportedMediaType,
    array_bounds,
    field_problem,
    from_input_rejected,
    from_validation_error,
    loads_bounded,
    prescan_json,
    summary,
)
from plantsolve.solvers.base import Deferred, InputRejected, SolverError, SolverSpec, StoredInput
from plantsolve.solvers.kinds import PACKAGES, load_kinds
from plantsolve.store.blobs import BlobMissing, BlobStore
from plantsolve.store.repository import JobRecord


def read_json(spec: SolverSpec, body: bytes) -> tuple[Any, Any]:
    """The body as parsed JSON (what is stored) and the kind's input value made from it."""
    prescan_json(body, array_bounds(spec.request_model), "The body")  # bounds first: nothing built past them
    raw = loads_bounded(body, [], "The body")
    try:
        # strict JSON: a number is a number (no `false` for 0, no "5" for 5), as the schema says
        request = spec.request_model.model_validate_json(body, strict=True)
    except ValidationError as error:
        integral = _with_integral_numbers_as_integers(raw, error)
        if integral is None:
            raise _another_kinds(spec, raw) or from_validation_error(error, model=spec.request_model) from None
        raw = integral
        try:
            request = spec.request_model.model_validate_json(json.dumps(raw), strict=True)
        except ValidationError as error:
            raise _another_kinds(spec, raw) or from_validation_error(error, model=spec.request_model) from None
    return raw, _input(spec, request)


def _another_kinds(spec: SolverSpec, document: Any) -> Unprocessable | None:
    """One 422 naming the kind a body was written for, when it is another kind's request or result: a list of
    'extra inputs' against the wrong schema would not say that the route is what is wrong."""
    if spec.kind not in PACKAGES or not isinstance(document, dict):  # (a plugin's kind: its fields are unknown)
        return None
    held = _held_kind(document, spec.kind)
    if held is None:
        return None
    error = field_problem([], f"the body holds {held}, not a {spec.kind} request", "wrong_kind")
    return Unprocessable(summary([error]), errors=[error])


def _with_integral_numbers_as_integers(document: Any, error: ValidationError) -> Any | None:
    """The document with each number written with a zero fraction (``3.0``) where an integer is expected made an
    integer, when that is all the validation refused; else None.

    JSON Schema, and so the OpenAPI document, counts ``3.0`` as an integer; pydantic's strict mode does not. Only the
    refused places change, so ``3.5`` (not an integer) and ``true`` (not a number) are still refused, and so is a
    number past 2**53, which a float does not hold exactly."""
    errors = error.errors(include_url=False, include_context=False)
    places = []
    for item in errors:
        value = item.get("input")
        if item["type"] != "int_type" or type(value) is not float or not value.is_integer() or abs(value) > 2 ** 53:
            return None
        places.append(item["loc"])
    for loc in places:
        node, path = document, list(loc)
        while len(path) > 1:
            key = path.pop(0)
            if isinstance(node, dict) and key in node or isinstance(node, list) and isinstance(key, int) \
                    and 0 <= key < len(node):
                node = node[key]
            # else: a union's branch tag in the location, not a step in the document
        key = path[0]
        if not (isinstance(node, (dict, list)) and (key in node if isinstance(node, dict) else
                                                     isinstance(key, int) and 0 <= key < len(node))):
            return None
        if type(node[key]) is float and node[key].is_integer():
            node[key] = int(node[key])
    return document


def upload_extension(spec: SolverSpec, filename: str) -> str:
    """The upload's extension when the kind reads it; else a 415 listing the ones it does."""
    if spec.parse_upload is None or not spec.upload_extensions:
        raise UnsupportedMediaType(f"Solver kind {spec.kind!r} takes JSON bodies only.")
    extension = StoredInput(filename, content=b"").extension
    if extension not in spec.upload_extensions:
        raise UnsupportedMediaType(
            f"File type {extension or '(none)'!r} is not accepted by {spec.kind!r}; "
            f"accepted: {', '.join(spec.upload_extensions)}." + (f" {hint}" if (hint := spec.upload_hint(extension)) else "")
        )
    return extension


def upload_options(options_text: str | None) -> dict | None:
    """The multipart ``options`` field: a JSON object, or nothing."""
    if not options_text:
        return None
    prescan_json(options_text, {}, "The 'options' form field")
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
        raise from_input_rejected(error, model=spec.request_model) from None
    except ValidationError as error:
        raise from_validation_error(error, model=spec.request_model) from None
    except RecursionError:
        raise Unprocessable("The uploaded file is nested too deeply to be read.",
                            errors=[field_problem(["file"], "nested too deeply", "json_too_deep")]) from None
    return _input(spec, request, source)


# Growth of a reading process's address space beyond its start (RLIMIT_AS), and its time: what one upload
# may cost to read. The API process itself holds only the uploaded bytes.
UPLOAD_READ_MEMORY = 768 * 1024 * 1024
UPLOAD_READ_SECONDS = 8.0
UPLOAD_READ_WALL_FACTOR = 4.0
# Text uploads (point clouds, tables) are read line by line in Python at about 1 KB and 9 us a line: beyond
# this many lines a reader could not finish within the budget above, so they are refused before it runs.
MAX_TEXT_LINES = 1_000_000
TEXT_EXTENSIONS = (".xyz", ".csv", ".txt", ".pts", ".asc", ".tsv")

log = logging.getLogger("plantsolve.api")
# it imports every kind's schemas: a body refused is its first use, so a process that runs one kind imports that one's
_held_kind = Deferred("plantsolve.solvers.other_kinds:held_kind")
_forkserver = multiprocessing.get_context("forkserver")
# A process with one thread (the CLI while it submits) may fork its reading processes from itself, with what it has
# imported: no forkserver, no second interpreter importing the kind's readers again (about 1.3 CPU s of a small
# upload's run). A process with threads (the service) must not fork them: a lock held by another thread at the fork
# stays held in the child.
READER_STARTS = ("forkserver", "fork")


# What the forkserver imports when it starts, in order. It is one per process (multiprocessing's): the upload readers
# fork from it and so do the embedded service's job processes (plantsolve.workers.processes), so each adds its modules
# and neither replaces the other's (the readers' list, set after the job processes' one, had left the warm parent
# without a single solver: each job process imported its kind's solver itself).
_preloaded: dict[str, None] = {}


def preload_in_forkserver(modules: Iterable[str], *, first: bool = False) -> None:
    """Add ``modules`` to what the forkserver imports at its next start: after those already listed, or before them
    when ``first`` (a module that must run before the others import theirs, whoever asked first)."""
    added = dict.fromkeys(modules)
    merged = {**added, **_preloaded} if first else {**_preloaded, **added}
    _preloaded.clear()
    _preloaded.update(merged)
    _forkserver.set_forkserver_preload(list(_preloaded))


class ForkserverStarts:
    """The forkserver's failed starts in a row, and when the next may be tried. It is one per process, and whoever needs
    it first starts it: the job processes' dispatcher (it is their warm parent) or an upload's reading process. One
    that dies at every start (the out-of-memory killer, a library that crashes at import) costs each start the imports
    of every kind: the dispatcher tried again every second, and each upload started one of its own, for as long as
    the cause lasted. Now the starts after failures in a row wait as ``backoff`` says (the first failure is tried
    again at once); a failure more than ``apart`` seconds after the one before counts as a first.

    One death is seen by every caller that used that forkserver (the uploads waiting on it, the dispatcher): each
    takes :meth:`current` before its start and passes it to :meth:`failed`, which counts a start's failure once."""

    def __init__(self, backoff: Backoff = FORKSERVER_RESTARTS, apart: float = 60.0):
        self.backoff, self.apart = backoff, apart
        self.failures = 0
        self._start = 0  # the forkserver start callers use now: one more after each failure counted
        self._last = float("-inf")  # the last failure (monotonic)
        self._due = float("-inf")  # when the next start may be tried (monotonic)
        self._lock = threading.Lock()

    def current(self) -> int:
        """The forkserver start a caller is about to use (or wait on): what it passes to :meth:`failed`."""
        return self._start

    def failed(self, start: int) -> float:
        """Forkserver start ``start`` (:meth:`current`) failed, or the forkserver died: returns the pause before the
        next start. Its failure counts once, however many callers saw it."""
        with self._lock:
            now = time.monotonic()
            if start != self._start:  # another caller counted it already
                return max(0.0, self._due - now)
            self._start += 1
            self.failures = self.failures + 1 if now - self._last < self.apart else 1
            self._last = now
            pause = self.backoff.pause(self.failures)
            self._due = now + pause
            return pause

    def pause_left(self) -> float:
        """Seconds until the next start may be tried (0: now)."""
        return max(0.0, self._due - time.monotonic())

    def refuse_while_paused(self) -> None:
        """Raise :class:`~plantsolve.jobs.errors.ReadersPaused` (a 503 asking to come back when the pause ends) while
        a start may not be tried."""
        left = self.pause_left()
        if left > 0:
            raise ReadersPaused(self.failures, left)


FORKSERVER_STARTS = ForkserverStarts()


def start_readers(kinds: Iterable[SolverSpec]) -> None:
    """Start the readers' forkserver in the background, so the first upload does not wait: it imports this module
    and these kinds' readers and checks once (seconds), and each reading process forks from it with them imported.
    The service names every kind; the CLI the one kind it reads an upload of, or none for a JSON request (then no
    forkserver starts here: a reading process, should one be asked for, starts it and imports what it runs)."""
    modules = [module for spec in kinds for module in spec.modules(SolverSpec.READERS)]
    if not modules:
        return
    preload_in_forkserver(["plantsolve.jobs.intake", *modules])
    threading.Thread(target=forkserver.ensure_running, name="upload-readers", daemon=True).start()


def check_text_lines(source: StoredInput) -> None:
    """A text upload of more than :data:`MAX_TEXT_LINES` lines is a 422 before any reader runs (counted at C speed)."""
    if source.extension not in TEXT_EXTENSIONS:
        return
    lines = source.read().count(b"\n")
    if lines > MAX_TEXT_LINES:
        raise Unprocessable(
            f"The uploaded text file has {lines} lines; a text upload may have at most {MAX_TEXT_LINES}. "
            f"Send large point clouds in a binary format (.npy, .ply, .las, .e57).",
            errors=[field_problem(["file"], f"{lines} lines, more than the {MAX_TEXT_LINES} a text upload may have",
                                  "too_long")])


def read_upload_bounded(spec: SolverSpec, source: StoredInput, options: dict | None, plugins: Iterable[str] = (), *,
                        memory_bytes: int = UPLOAD_READ_MEMORY, seconds: float = UPLOAD_READ_SECONDS,
                        start: str = "forkserver") -> None:
    """:func:`read_upload` and :func:`check` of a stored upload, run in a bounded child process: returns when the
    upload passes, raises the 422 otherwise (also when reading it needs more memory or time than allowed).
    ``start``: how the child starts (:data:`READER_STARTS`); ``"fork"`` only from a process with one thread.
    The spec travels by reference (its kind and the ``plugins`` of the kind map it is in), else pickled; a spec
    made of local functions (a test's) can do neither, and is read here, in this process."""
    if source.path is None:
        raise ValueError("a bounded read needs the upload stored on disk")
    check_text_lines(source)
    _bounded(spec, "upload", source, options, plugins, memory_bytes=memory_bytes, seconds=seconds, start=start)


def read_json_bounded(spec: SolverSpec, source: StoredInput, plugins: Iterable[str] = (), *,
                      memory_bytes: int = UPLOAD_READ_MEMORY, seconds: float = UPLOAD_READ_SECONDS,
                      start: str = "forkserver") -> str:
    """:func:`read_json` and :func:`check` of a large JSON body stored on disk, in a bounded child process as an
    upload is read (a field file's text of two million rows is 2 CPU s and 400 MB to validate and check): the
    SHA-256 of the kind and the body's canonical form (:func:`canonical_json`, what idempotency compares), or the
    422 naming the body's field (or the body, when reading it needs more memory or time than allowed)."""
    if source.path is None:
        raise ValueError("a bounded read needs the body stored on disk")
    prescan_json(source.read(), array_bounds(spec.request_model), "The body")  # as read_json: the bounds first
    return _bounded(spec, "json", source, None, plugins, memory_bytes=memory_bytes, seconds=seconds, start=start)


def canonical_json(value: Any) -> bytes:
    return json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=False).encode()


def body_hash(kind: str, raw: Any) -> str:
    """The SHA-256 by which two JSON submissions are the same request: the kind and the body's canonical form."""
    return hashlib.sha256(kind.encode() + b"\n" + canonical_json(raw)).hexdigest()


# what a bounded read reads, and how its refusals name it: (JSON path, a noun for the message)
_READ_AS = {"upload": (["file"], "The uploaded file", "this file", "an upload"),
            "json": ([], "The body", "this body", "a JSON body")}


def _bounded(spec: SolverSpec, what: str, source: StoredInput, options: dict | None, plugins: Iterable[str], *,
             memory_bytes: int, seconds: float, start: str) -> Any:
    plugins = tuple(plugins)
    try:
        pickled = pickle.dumps((spec.kind, plugins) if load_kinds(plugins).get(spec.kind) is spec else spec)
    except (pickle.PicklingError, AttributeError, TypeError):
        return _read(spec, what, source, options)
    if start not in READER_STARTS:
        raise ValueError(f"no reader start {start!r}; known: {', '.join(READER_STARTS)}")
    if start == "fork":
        if threading.active_count() > 1:
            raise RuntimeError("reading processes are forked only from a process with one thread")
        spec.preload(SolverSpec.READERS)  # here, so the child imports nothing under its memory limit
    if start == "forkserver":
        FORKSERVER_STARTS.refuse_while_paused()
        forkserver_start = FORKSERVER_STARTS.current()
    context = multiprocessing.get_context(start)
    receiver, sender = context.Pipe(duplex=False)
    process = context.Process(
        target=_read_in_child, daemon=True, name=f"read-{spec.kind}",
        args=(sender, pickled, what, str(source.path), source.name, options, memory_bytes, seconds))
    try:
        process.start()
    except Exception:
        receiver.close()
        if start == "forkserver":
            FORKSERVER_STARTS.failed(forkserver_start)
        raise
    finally:
        sender.close()
    died = False
    try:
        outcome = receiver.recv() if receiver.poll(seconds * UPLOAD_READ_WALL_FACTOR + 2) else ("time",)
    except EOFError:  # it died without a word: its CPU limit, the kernel (out of memory) or a crash in native code
        outcome, died = ("memory",), True
    finally:
        receiver.close()
        if process.is_alive():
            process.kill()
        process.join(timeout=5)
    if died and process.exitcode == -signal.SIGXCPU:  # the soft CPU limit (the default action ends the process)
        outcome = ("time",)
    if outcome[0] == "ok":
        return outcome[1]
    if outcome[0] == "invalid":
        raise Unprocessable(outcome[1], errors=outcome[2])
    loc, subject, this, one = _READ_AS[what]
    if outcome[0] == "memory":
        msg = f"reading {this} needs more than the {memory_bytes // 2**20} MiB {one} may take to read"
        raise Unprocessable(f"{subject} could not be read: {msg}.", errors=[field_problem(loc, msg, "too_large")])
    if outcome[0] == "time":
        msg = f"reading {this} takes longer than the {seconds:g} CPU seconds {one} may take to read"
        raise Unprocessable(f"{subject} could not be read: {msg}.", errors=[field_problem(loc, msg, "too_slow")])
    log.warning("reading %s for %s failed in the reader:\n%s", f"an uploaded {source.extension} file"
                if what == "upload" else "a JSON body", spec.kind, outcome[1])
    msg = f"the file could not be read as a {source.extension or 'file'} file for {spec.kind} (it is malformed)" \
        if what == "upload" else f"the body could not be read as a {spec.kind} request"
    raise Unprocessable(f"{subject} could not be read: {msg}.", errors=[field_problem(loc, msg, "value_error")])


def _read(spec: SolverSpec, what: str, source: StoredInput, options: dict | None) -> Any:
    """What a bounded read does, in whichever process runs it: an upload read and checked (None), or a JSON body
    read and checked (its :func:`body_hash`)."""
    if what == "upload":
        check(spec, read_upload(spec, source, options))
        return None
    raw, job_input = read_json(spec, source.read())
    check(spec, job_input)
    return body_hash(spec.kind, raw)


def _read_in_child(sender, pickled: bytes, what: str, path: str, name: str, options: dict | None,
                   memory_bytes: int, seconds: float) -> None:
    """In the reading process: limits first, then the reader; only the outcome goes back."""
    try:
        resource.setrlimit(resource.RLIMIT_AS, (_address_space() + memory_bytes,) * 2)
        cpu = math.ceil(seconds)
        resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 1))
        spec = pickle.loads(pickled)
        if isinstance(spec, tuple):
            kind, plugins = spec
            spec = load_kinds(plugins)[kind]
        outcome: tuple = ("ok", _read(spec, what, StoredInput.from_path(Path(path), name), options))
    except Unprocessable as error:
        outcome = ("invalid", error.detail, error.errors)
    except MemoryError:
        outcome = ("memory",)
    except BaseException:  # a reader's bug on odd input: the API logs it and answers 422 naming the file
        outcome = ("failed", traceback.format_exc(limit=20))
    try:
        sender.send(outcome)
    finally:
        sender.close()


def _address_space() -> int:
    """This process's virtual memory size in bytes (VmSize): the base its limit is counted from."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmSize:"):
            return int(line.split()[1]) * 1024
    return 0


def check(spec: SolverSpec, job_input: Any) -> None:
    """The kind's checks across fields; run once, at submission."""
    if spec.check_input is None:
        return
    try:
        spec.check_input(job_input)
    except InputRejected as error:
        raise from_input_rejected(error, model=spec.request_model) from None


@contextmanager
def read_stored(spec: SolverSpec, job: JobRecord, files: BlobStore,
                on_request: Callable[[Any], None] | None = None) -> Iterator[Any]:
    """The kind's input value re-read from a job's stored input (in the worker; not checked again), for
    the duration of the ``with`` block (a temporary copy of an upload is removed after it). ``on_request`` is
    given the request as soon as it is read, before the kind's ``load`` (which may fail too)."""
    seen = on_request or (lambda request: None)

    def input_of(request: Any, source: StoredInput | None = None) -> Any:
        seen(request)
        return spec.input_of(request, source)

    try:
        if job.input_kind == "json":
            yield input_of(spec.request_model.model_validate(job.input))
        elif job.input_kind == "json_file":
            yield input_of(spec.request_model.model_validate_json(files.get(job.input_file)))
        elif job.input_kind == "upload":
            if spec.parse_upload is None:
                raise SolverError("input", f"solver kind {spec.kind!r} accepts no file uploads")
            with files.local_file(job.input_file, job.input_filename or "") as path:
                source = StoredInput.from_path(path, job.input_filename)
                yield input_of(spec.parse_upload(source, job.input_options), source)
        else:
            raise SolverError("input", f"unknown input kind {job.input_kind!r}")
    except BlobMissing:
        raise SolverError("input", "The submitted input is missing from the blob store (deleted, or a BLOB_STORE "
                          "other than the one it was submitted to).") from None


def _input(spec: SolverSpec, request: Any, source: StoredInput | None = None) -> Any:
    try:
        return spec.input_of(request, source)
    except InputRejected as error:
        raise from_input_rejected(error, model=spec.request_model) from None
    except ValidationError as error:
        raise from_validation_error(error, model=spec.request_model) from None
