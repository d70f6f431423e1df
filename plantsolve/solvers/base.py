"""The contract between a solver package and whoever runs it.

Every solver package exports ``SPEC``, a :class:`SolverSpec` that declares its kind, its
request and result schemas, its solve function, upload parser, input checker, artifact
writer, synchronous result operations and limits. The kind map
(:mod:`plantsolve.solvers.kinds`) lists the packages' specs; nothing is found by naming
convention. A spec names its functions as ``"module:attribute"`` (a :class:`Deferred`), so that
listing the kinds imports no numerics: each function's module is imported when it is first called.

A solver receives a :class:`Progress` callback. It calls ``progress(fraction, message)``
between iterations; the callback raises :class:`Cancelled` when the job has been
cancelled (or its time is up), so a solver needs no extra code to honour cancellation
beyond calling it regularly.

Errors a solver may raise:
- :class:`InputRejected` — the input is invalid in a way only the solver can see
  (e.g. a pipe whose ports are not collinear). The service answers 422 naming the field.
- :class:`SolverError` — the solver could not produce any result. A solver that merely
  did not converge must *not* raise: it returns its best result with a report instead.
"""

from __future__ import annotations

import importlib
import json
import math
import re
import struct
import tempfile
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import partial
from importlib import resources
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Mapping, Protocol, Sequence

from pydantic import BaseModel, ValidationError


class Progress(Protocol):
    def __call__(self, fraction: float, message: str = "") -> None:
        """Report progress in [0, 1]; raises :class:`Cancelled` if the run must stop."""


def no_progress(fraction: float, message: str = "") -> None:
    """A :class:`Progress` that ignores reports and never cancels (library and test use)."""


class Cancelled(Exception):
    """Raised by the progress callback when the job was cancelled or timed out."""


@dataclass
class FieldError:
    """One bad field: ``loc`` is the JSON path (e.g. ``("connections", 3, "to")``)."""

    loc: tuple[str | int, ...]
    msg: str
    type: str = "value_error"


class InputRejected(ValueError):
    """The input is invalid; carries one :class:`FieldError` per bad field."""

    def __init__(self, errors: Sequence[FieldError] | FieldError, title: str | None = None):
        """``InputRejected(FieldError(("file",), "no END-POINT"))`` or a list of them."""
        self.errors = [errors] if isinstance(errors, FieldError) else list(errors)
        self.title = title or "; ".join(
            f"{'/'.join(str(p) for p in e.loc) or '(body)'}: {e.msg}" for e in self.errors
        )
        super().__init__(self.title)


class SolverError(Exception):
    """The solver produced no usable result.

    ``stage`` names the stage that failed, ``message`` is a human sentence, ``details`` is
    JSON-serialisable and machine readable.
    """

    def __init__(self, stage: str, message: str, details: dict[str, Any] | None = None):
        self.stage = stage
        self.message = message
        self.details = details or {}
        super().__init__(f"{stage}: {message}")


@dataclass
class Artifact:
    """A file produced from a result: a plot, a mesh, an exported model."""

    name: str  # file name, e.g. "tube.stl"; unique per job
    media_type: str  # e.g. "model/stl", "image/png"
    data: bytes = field(repr=False)


@dataclass(frozen=True)
class StoredInput:
    """A submitted file as the service keeps it: the ``name`` it was sent under, where it lies
    (``path``, None when it only lives in memory) and its bytes on demand (:meth:`read`).

    The job domain hands the stored upload by path, so a reader that wants a file on disk (dedup's
    IfcOpenShell) opens it directly; library use and tests make one from bytes."""

    name: str
    path: Path | None = None
    content: bytes | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if (self.path is None) == (self.content is None):
            raise ValueError("a StoredInput has a path or bytes, exactly one of them")

    @classmethod
    def from_bytes(cls, name: str, content: bytes) -> "StoredInput":
        return cls(name=name, content=bytes(content))

    @classmethod
    def from_path(cls, path: str | Path, name: str | None = None) -> "StoredInput":
        path = Path(path)
        return cls(name=name or path.name, path=path)

    @property
    def extension(self) -> str:
        """Lower case, with its dot; ``""`` for a name without one."""
        return "." + self.name.rsplit(".", 1)[-1].lower() if "." in self.name else ""

    @property
    def size(self) -> int:
        return len(self.content) if self.content is not None else self.path.stat().st_size

    def read(self) -> bytes:
        return self.content if self.content is not None else self.path.read_bytes()

    @contextmanager
    def as_file(self) -> Iterator[Path]:
        """A path on disk holding the bytes: the stored file itself, or a temporary copy of in-memory bytes."""
        if self.path is not None:
            yield self.path
            return
        with tempfile.TemporaryDirectory(prefix="plantsolve-input-") as folder:
            path = Path(folder) / (re.sub(r"[^A-Za-z0-9._-]+", "_", self.name)[-120:] or "input")
            path.write_bytes(self.content)
            yield path


@dataclass(frozen=True)
class Solved:
    """What a kind's solve returns: the ``result`` (the kind's result model) and the payloads that
    only the solve could make and its artifacts need (dedup's optimized model), keyed by name.
    The artifact writer takes both, so no artifact is ever made by solving again."""

    result: BaseModel
    files: Mapping[str, bytes] = field(default_factory=dict, repr=False)


def validated(model: type[BaseModel], data: Any, loc_prefix: tuple[str | int, ...] = ("file",), *,
              max_errors: int = 50, strict: bool | None = None) -> Any:
    """``model`` validated from ``data`` (a dict read from a file or a form field); a pydantic
    ``ValidationError`` becomes :class:`InputRejected` with each field's path behind ``loc_prefix``."""
    try:
        return model.model_validate(data, strict=strict)
    except ValidationError as error:
        raise InputRejected([
            FieldError((*loc_prefix, *e["loc"]), e["msg"], e.get("type", "value_error"))
            for e in error.errors(include_url=False)[:max_errors]
        ]) from None


def reject(msg: str, loc: tuple[str | int, ...] = ("file",), type: str = "value_error") -> InputRejected:
    """One bad field as an exception to raise: ``raise reject("no END-POINT", ("file", "line", 7))``."""
    return InputRejected(FieldError(loc, msg, type))


def upload_extension(filename: str, accepted: Sequence[str]) -> str:
    """The uploaded file's extension (lower case, with its dot) when the kind reads it; else a 422 on ``file``."""
    ext = "." + filename.rsplit(".", 1)[-1].lower() if "." in filename else ""
    if ext not in accepted:
        raise reject(f"unsupported file type {ext or '(none)'!r}; accepted: {', '.join(accepted)}")
    return ext


class DuplicateKey(ValueError):
    """A JSON object naming one key twice: which value was meant is unknown (json.loads keeps the last)."""

    def __init__(self, key: str):
        super().__init__(f"the key {key!r} appears twice in one object; which value is meant is not known")
        self.key = key


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict:
    out = dict(pairs)
    if len(out) < len(pairs):
        seen: set[str] = set()
        for key, _ in pairs:
            if key in seen:
                raise DuplicateKey(key)
            seen.add(key)
    return out


def loads_json(text: str | bytes) -> Any:
    """json.loads refusing an object that names a key twice (:class:`DuplicateKey`): ``{"units": "mm", …,
    "units": "m"}`` would otherwise be read in metres without a word."""
    return json.loads(text, object_pairs_hook=_unique_keys)


_TOKEN_START = re.compile(r"-?(\d+\.?\d*([eE][-+]?\d*)?)?|t(r(ue?)?)?|f(a(l(se?)?)?)?|n(u(ll?)?)?")
"""What may stand at the end of a JSON text cut inside its last value: the start of a number or literal."""


def _refuse_cut(error: json.JSONDecodeError) -> None:
    """A 422 on ``file`` saying that a JSON upload ends before its document is complete (a request is one
    object: nothing of a cut one is usable), with the line and column where it stops; other JSON errors
    return."""
    # a string still open runs to the end of the text too (a raw line break inside one is another error), and a text
    # cut inside its last token (after a minus sign, inside `tru`) stops the parser just before that token
    if error.pos >= len(error.doc.rstrip()) or error.msg.startswith("Unterminated string") \
            or _TOKEN_START.fullmatch(error.doc[error.pos:].strip()):
        raise reject(f"the JSON ends before its document is complete (at line {error.lineno}, column {error.colno}: "
                     f"{error.msg}); the file was cut? Nothing of a cut request is used") from None


def json_object(text: str | bytes, not_an_object: str = "the JSON file must hold a request object",
                list_as: str | None = None, refuse_cut: bool = False) -> dict:
    """An uploaded JSON file that must hold one object; a 422 on ``file`` saying why it does not (``not_an_object``
    names what the format's object is). With ``list_as`` a bare list is the request's field of that name (a
    point or position list saved on its own). With ``refuse_cut`` a document that ends before it is complete is
    said to be cut (:func:`_refuse_cut`) rather than invalid. Bytes are read as :func:`decode_text` reads text (a
    Windows editor's UTF-16 or Windows-1252)."""
    if isinstance(text, bytes):
        text = decode_text(text, "JSON file")
    if not text.replace("\ufeff", "").strip():
        # json reports an empty text as ending early, which read as a cut file (a byte-order mark is no content)
        raise reject("the JSON file is empty (it holds only blank lines or whitespace): upload the file holding "
                     "the request")
    try:
        body = loads_json(text)
    except json.JSONDecodeError as e:
        if refuse_cut:
            _refuse_cut(e)
        raise reject(f"invalid JSON: {e}") from None
    except (UnicodeDecodeError, DuplicateKey) as e:
        raise reject(f"invalid JSON: {e}") from None
    if list_as is not None and isinstance(body, list):
        body = {list_as: body}
    if not isinstance(body, dict):
        raise reject(not_an_object)
    return body


def binary_stl(head: bytes) -> bool:
    """A binary STL's start: an 80-byte header, a triangle count, then a first triangle of finite floats whose normal
    is a unit vector or zero (exporters write either) and whose attribute word is zero."""
    if len(head) < 134 or int.from_bytes(head[80:84], "little") == 0:
        return False
    numbers = struct.unpack("<12f", head[84:132])
    if not all(math.isfinite(v) for v in numbers) or head[132:134] != b"\0\0":
        return False
    length = math.sqrt(sum(v * v for v in numbers[:3]))
    return length < 1e-6 or abs(length - 1.0) < 1e-3


def decode_text(content: bytes, what: str = "text file") -> str:
    """The text of an uploaded file as exporters write it: UTF-8 (with or without a byte-order mark),
    UTF-16 with its mark, or Windows-1252 (what Excel and older Windows tools write). Binary content
    is refused naming the file."""
    if content[:4] == b"PK\x03\x04":
        raise reject(f"this is a zip archive (an Excel .xlsx workbook?), not a {what}")
    if content[:2] in (b"\xff\xfe", b"\xfe\xff"):
        try:
            return content.decode("utf-16")
        except UnicodeDecodeError:
            raise reject("the file starts with a UTF-16 mark but is not UTF-16 text") from None
    if b"\x00" in content:
        if (text := utf16_without_mark(content)) is not None:
            return text
        holds = ", a binary STL mesh" if binary_stl(content[:134]) else ""
        raise reject(f"this is a binary file (it contains NUL bytes, the first at byte offset {content.index(0)}{holds}), "
                     f"not a {what}")
    try:
        return content.decode("utf-8-sig")
    except UnicodeDecodeError:
        return content.decode("cp1252", errors="replace")


def utf16_without_mark(content: bytes) -> str | None:
    """The text of UTF-16 written without its byte-order mark (some Windows tools), else None: text of ASCII
    characters has a NUL as every second byte (the high byte of each character) and none in the other half,
    which binary data does not."""
    if len(content) < 2 or len(content) % 2:
        return None
    for order, nul_at in (("utf-16-le", 1), ("utf-16-be", 0)):
        if content[1 - nul_at::2].count(0) == 0 and content[nul_at::2].count(0) >= 0.9 * (len(content) // 2):
            try:
                return content.decode(order)
            except UnicodeDecodeError:
                return None
    return None


_REFERENCE = re.compile(r"^[A-Za-z_][\w.]*:[A-Za-z_][\w.]*$")


class Deferred:
    """A function named ``"package.module:attribute"`` (``"plantsolve.solvers.tube.scan:TubeScan.load"``), imported
    when it is first called or asked for (:attr:`target`) and kept by this object from then on: a spec's functions
    cost nothing until a process uses them, and each process imports only the modules it runs."""

    __slots__ = ("reference", "_target")

    def __init__(self, reference: str) -> None:
        if not _REFERENCE.match(reference):
            raise ValueError(f"{reference!r} is not a 'package.module:attribute' reference")
        self.reference = reference
        self._target: Callable[..., Any] | None = None

    @property
    def module(self) -> str:
        return self.reference.partition(":")[0]

    @property
    def target(self) -> Callable[..., Any]:
        """The function itself (its module imported on the first ask; importing is thread-safe and idempotent)."""
        if self._target is None:
            module, _, attribute = self.reference.partition(":")
            value: Any = importlib.import_module(module)
            for name in attribute.split("."):
                value = getattr(value, name)
            if not callable(value):
                raise TypeError(f"{self.reference} is not callable")
            self._target = value
        return self._target

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return self.target(*args, **kwargs)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Deferred) and other.reference == self.reference

    def __hash__(self) -> int:
        return hash(self.reference)

    def __repr__(self) -> str:
        return f"Deferred({self.reference!r})"

    def __reduce__(self) -> tuple:
        return Deferred, (self.reference,)  # a pickled spec travels by name; the other process imports it itself


def _deferred(value: Any) -> Any:
    """A ``"module:attribute"`` string as a :class:`Deferred`; a function (or None) as it is."""
    return Deferred(value) if isinstance(value, str) else value


def stored_example(package: str, name: str = "example.json") -> Callable[[], dict[str, Any]]:
    """A kind's ``example`` read from a JSON file in its package: the output of its ``synthetic.example()``, written
    out (a test holds the two equal), so that documenting the kinds (OpenAPI, dashboard) imports no generator."""
    return partial(_read_json_resource, package, name)


def _read_json_resource(package: str, name: str) -> dict[str, Any]:
    return json.loads(resources.files(package).joinpath(name).read_text(encoding="utf-8"))


class ResultNotUsable(Exception):
    """A finished result cannot answer a :class:`ResultOperation` (the service answers 409)."""


@dataclass(frozen=True)
class ResultOperation:
    """A synchronous question answered from a finished job's result, served as
    ``POST /v1/<kind>/jobs/{id}/<name>`` (perfmap's inverse query is one).

    ``answer(result, request)`` takes the stored result (as ``result_model`` of the spec) and
    the validated ``request_model``; it raises :class:`InputRejected` (422) for a bad request
    and :class:`ResultNotUsable` (409) when this result cannot answer at all. ``answer`` and
    ``example`` may be ``"module:attribute"`` references (:class:`Deferred`).
    """

    name: str
    request_model: type[BaseModel]
    response_model: type[BaseModel]
    answer: Callable[[Any, Any], BaseModel] | str
    summary: str = ""
    description: str = ""
    example: Callable[[], dict[str, Any]] | str | None = None  # a valid request body, shown in the API documentation

    def __post_init__(self) -> None:
        for name in ("answer", "example"):
            object.__setattr__(self, name, _deferred(getattr(self, name)))


_KIND = re.compile(r"^[a-z][a-z0-9_-]{0,39}$")


@dataclass(frozen=True)
class SolverSpec:
    """Everything the service needs to know about one solver kind.

    - ``parse_upload(source, options) -> request``: a :class:`StoredInput` of a file the kind
      accepts (``upload_extensions``, lower case, with the dot) and the form's options, read
      into the kind's request model.
    - ``load(request, source) -> input``: the kind's input value (decoded arrays, a model
      handle) made once from the request and, for an upload, its stored file; ``None``: the
      request itself is the input. Everything below takes this input.
    - ``check_input(input)``: the checks across fields that the schema cannot state (raises
      :class:`InputRejected`). The job domain runs them once, at submission; a solver does
      not run them again.
    - ``solve(input, progress) -> Solved``: the pure computation.
    - ``render_artifacts(input, solved) -> [Artifact]``: plots, meshes, exported files.
    - ``example() -> dict``: a small valid request body (JSON) that solves in seconds; the
      OpenAPI document shows it and the contract test runs every kind through it.
    - ``reader_notes(request) -> [(code, message, details, level)]``: for a kind whose request keeps its
      source file's text rather than what the reader found in it (alignment's PCF), the reader's notes said again
      from that text (a request without that text has none); those of level ``"warning"`` are reader's warnings, which every report of the job carries, a failed
      one too (``plantsolve.jobs.reader_notes``). A kind whose reader writes its notes into the request
      (``Diagnostic`` fields, a ``source`` mapping) needs neither.
    - limits: ``soft_time_limit`` (the solver is asked to stop), ``time_limit`` (it is
      stopped), ``max_attempts`` (``None``: the service's ``MAX_ATTEMPTS``).
    - ``upload_hints``: pairs of file types (lower case, with the dot) and a sentence the 415 of those
      types ends with, saying where such a file goes instead (a file the request holds as text, say).

    The functions may be given as ``"module:attribute"`` strings: they become :class:`Deferred`
    functions, imported on first use, so that the kind map (names, schemas, upload extensions, limits)
    is read without importing any solver. :meth:`preload` imports them all ahead of use.
    """

    kind: str
    request_model: type[BaseModel]
    result_model: type[BaseModel]
    solve: Callable[[Any, Progress], Solved] | str
    version: str
    load: Callable[[Any, StoredInput | None], Any] | str | None = None
    check_input: Callable[[Any], None] | str | None = None
    parse_upload: Callable[[StoredInput, dict | None], BaseModel] | str | None = None
    render_artifacts: Callable[[Any, Solved], list[Artifact]] | str | None = None
    upload_extensions: tuple[str, ...] = ()
    upload_hints: tuple[tuple[tuple[str, ...], str], ...] = ()
    soft_time_limit: float = 600.0
    time_limit: float = 660.0
    max_attempts: int | None = None
    description: str = ""
    operations: tuple[ResultOperation, ...] = ()
    example: Callable[[], dict[str, Any]] | str | None = None
    reader_notes: Callable[[Any], Iterable[tuple[str, str, dict, str]]] | str | None = None

    FUNCTIONS = ("solve", "load", "check_input", "parse_upload", "render_artifacts", "example", "reader_notes")
    # what reading an upload and checking it runs (the upload readers' processes import these ahead)
    READERS = ("parse_upload", "load", "check_input")

    def __post_init__(self) -> None:
        for name in self.FUNCTIONS:
            object.__setattr__(self, name, _deferred(getattr(self, name)))
        if not _KIND.match(self.kind):
            raise ValueError(f"solver kind {self.kind!r} is not a lower-case name usable in a URL")
        if not 0 < self.soft_time_limit <= self.time_limit:
            raise ValueError(f"{self.kind}: need 0 < soft_time_limit <= time_limit")
        if self.parse_upload is not None and not self.upload_extensions:
            raise ValueError(f"{self.kind}: parse_upload needs upload_extensions")
        if any(not e.startswith(".") or e != e.lower() for e in self.upload_extensions):
            raise ValueError(f"{self.kind}: upload extensions are lower case and start with a dot")
        names = [op.name for op in self.operations]
        if len(set(names)) != len(names):
            raise ValueError(f"{self.kind}: operation names repeat: {names}")

    def upload_hint(self, extension: str) -> str:
        """What the 415 of a file of type ``extension`` adds (empty: nothing)."""
        return next((hint for types, hint in self.upload_hints if extension in types), "")

    def input_of(self, request: BaseModel, source: StoredInput | None = None) -> Any:
        """The kind's input value for a request (and its stored file, for an upload)."""
        return request if self.load is None else self.load(request, source)

    def deferred(self, roles: Sequence[str] | None = None) -> list[Deferred]:
        """The spec's :class:`Deferred` functions in ``roles`` (default: all of them, its operations' too)."""
        functions = [getattr(self, role) for role in (self.FUNCTIONS if roles is None else roles)]
        if roles is None:
            functions += [f for op in self.operations for f in (op.answer, op.example)]
        return [f for f in functions if isinstance(f, Deferred)]

    def modules(self, roles: Sequence[str] | None = None) -> list[str]:
        """The modules that define the spec's functions in ``roles`` (what a process preloads by name)."""
        return list(dict.fromkeys(f.module for f in self.deferred(roles)))

    def preload(self, roles: Sequence[str] | None = None) -> None:
        """Import the functions in ``roles`` now (a job process before its first job), not at their first use."""
        for function in self.deferred(roles):
            function.target
