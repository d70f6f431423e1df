"""The job domain's errors, as classes: each names its status, title and problem type, and carries
the bad fields (``errors``, each with its JSON path and RFC 6901 pointer). The HTTP app renders them
as RFC 9457 problem documents (:mod:`plantsolve.app.problems`); the CLI prints them."""

from __future__ import annotations

import functools
import json
import re
import sys
from typing import Any, Iterable, Sequence

from pydantic import ValidationError
from sqlalchemy import exc as sqlalchemy_exc

from plantsolve.schemas.jobs import Problem
from plantsolve.solvers.base import DuplicateKey, InputRejected, loads_json

TYPE_BASE = "https://plantsolve.dev/problems/"


def pointer(loc: Sequence[str | int]) -> str:
    return "".join("/" + str(part).replace("~", "~0").replace("/", "~1") for part in loc)


def field_problem(loc: Sequence[str | int], msg: str, type_: str = "value_error") -> dict[str, Any]:
    return {"loc": list(loc), "pointer": pointer(loc), "msg": msg, "type": type_}


class ProblemError(Exception):
    status: int = 500
    title: str = "Internal error"
    slug: str = "internal"

    def __init__(
        self,
        detail: str | None = None,
        *,
        errors: list[dict[str, Any]] | None = None,
        extra: dict[str, Any] | None = None,
        headers: dict[str, str] | None = None,
    ):
        self.detail = detail
        self.errors = errors
        self.extra = extra
        self.headers = headers or {}
        super().__init__(detail or self.title)

    def to_problem(self, instance: str | None = None) -> Problem:
        return Problem(
            type=TYPE_BASE + self.slug,
            title=self.title,
            status=self.status,
            detail=self.detail,
            instance=instance,
            errors=self.errors,
            extra=self.extra,
        )


class NotFound(ProblemError):
    status, title, slug = 404, "Not found", "not-found"


class Conflict(ProblemError):
    status, title, slug = 409, "Conflict with the job's state", "conflict"


class UnsupportedMediaType(ProblemError):
    status, title, slug = 415, "Unsupported media type", "unsupported-media-type"


class Unprocessable(ProblemError):
    status, title, slug = 422, "Invalid input", "invalid-input"


# how long a client is asked to wait when the service's disk is short of space: freeing it takes an operator minutes
DISK_RETRY_AFTER_SECONDS = 60


class DiskSpaceLow(ProblemError):
    """The service's disk has less free space than ``MIN_FREE_DISK_BYTES`` (or is full): a submission is refused, as
    ``/readyz`` says ``disk``, rather than taken into a store that may not hold it; nothing was stored."""

    status, title, slug = 503, "Disk space low", "disk-space-low"

    def __init__(self, detail: str | None = None):
        super().__init__(detail or "The service's disk is short of free space, so no submission is taken now (nothing "
                         "was stored; the jobs already queued wait, none is lost). Submit again once space is freed.",
                         headers={"Retry-After": str(DISK_RETRY_AFTER_SECONDS)})


def from_validation_error(error: ValidationError, prefix: Sequence[str | int] = (), document: Any = None) -> Unprocessable:
    """422 naming each bad field; with the submitted ``document`` the locations are its JSON paths (the tags
    pydantic puts in them for a member of a union are left out)."""
    errors = [field_problem([*prefix, *json_path(document, e["loc"], e["type"])], e["msg"], e["type"])
              for e in error.errors(include_url=False)]
    return Unprocessable(summary(errors), errors=errors)


def json_path(document: Any, loc: Sequence[str | int], error_type: str = "") -> list[str | int]:
    """``loc`` as a path into ``document``: a string step that names no key of the value it stands on (a
    union member's tag such as ``list[...]``) is dropped, except a missing field's name, the last step of a
    ``missing`` error."""
    if document is None:
        return list(loc)
    path: list[str | int] = []
    node: Any = document
    for i, step in enumerate(loc):
        last = i == len(loc) - 1
        if isinstance(step, str) and not (isinstance(node, dict) and (step in node or (last and error_type == "missing"))):
            continue
        path.append(step)
        if isinstance(node, dict) and isinstance(step, str):
            node = node.get(step)
        elif isinstance(node, list) and isinstance(step, int) and -len(node) <= step < len(node):
            node = node[step]
        else:
            node = None
    return path


def from_input_rejected(error: InputRejected, prefix: Sequence[str | int] = ()) -> Unprocessable:
    errors = [field_problem([*prefix, *e.loc], e.msg, e.type) for e in error.errors]
    return Unprocessable(summary(errors), errors=errors)


def summary(errors: Iterable[dict[str, Any]]) -> str:
    parts = [f"{e['pointer'] or '(body)'}: {e['msg']}" for e in errors]
    text = "; ".join(parts[:5])
    return text + (f" (and {len(parts) - 5} more)" if len(parts) > 5 else "")


MAX_JSON_DEPTH = 200


def loads_bounded(data: bytes | str, loc: Sequence[str | int], what: str) -> Any:
    """json.loads with a nesting limit: deeper documents (or unreadable ones) are a 422 naming ``loc``."""
    try:
        value = loads_json(data)
    except DuplicateKey as error:
        raise Unprocessable(f"{what} names a key twice: {error}",
                            errors=[field_problem(loc, str(error), "json_duplicate_key")]) from None
    except RecursionError:
        raise Unprocessable(f"{what} is nested too deeply to be read.",
                            errors=[field_problem(loc, f"JSON nested deeper than {MAX_JSON_DEPTH} levels",
                                                  "json_too_deep")]) from None
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise Unprocessable(f"{what} is not valid JSON: {error}",
                            errors=[field_problem(loc, f"invalid JSON: {error}", "json_invalid")]) from None
    except ValueError:  # an integer longer than Python converts from text (sys.get_int_max_str_digits)
        errors = [field_problem([*loc, *path], f"an integer of {digits} digits; a number may have at most "
                                f"{sys.get_int_max_str_digits()} (no quantity needs more)", "int_too_long")
                  for path, digits in _long_integers(data)]
        if not errors:
            raise
        raise Unprocessable(f"{what} holds a number too long to be read: {summary(errors)}", errors=errors) from None
    if _depth(value) > MAX_JSON_DEPTH:
        raise Unprocessable(f"{what} is nested too deeply to be read.",
                            errors=[field_problem(loc, f"JSON nested deeper than {MAX_JSON_DEPTH} levels",
                                                  "json_too_deep")])
    return value


class _LongInteger:
    """Stands for an integer whose digits Python refuses to convert (the place and length are what a 422 names)."""

    def __init__(self, digits: int):
        self.digits = digits


def _integer(text: str) -> int | _LongInteger:
    digits = len(text.lstrip("-"))
    limit = sys.get_int_max_str_digits()
    return _LongInteger(digits) if limit and digits > limit else int(text)


def _long_integers(data: bytes | str) -> list[tuple[list[str | int], int]]:
    """Where a JSON document holds integers too long to convert, and their lengths (the document read again, such
    integers left unconverted)."""
    try:
        document = json.loads(data, parse_int=_integer)
    except ValueError:
        return []
    found, stack = [], [(document, [])]
    while stack:
        item, path = stack.pop()
        if isinstance(item, _LongInteger):
            found.append((path, item.digits))
        elif isinstance(item, dict):
            stack.extend((v, [*path, k]) for k, v in item.items())
        elif isinstance(item, list):
            stack.extend((v, [*path, i]) for i, v in enumerate(item))
    return sorted(found, key=lambda place: [str(step) for step in place[0]])[:20]


def _depth(value: Any) -> int:
    """Nesting depth of a parsed JSON value, without recursion."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        item, level = stack.pop()
        if isinstance(item, dict):
            deepest = max(deepest, level)
            stack.extend((v, level + 1) for v in item.values() if isinstance(v, (dict, list)))
        elif isinstance(item, list):
            deepest = max(deepest, level)
            stack.extend((v, level + 1) for v in item if isinstance(v, (dict, list)))
    return deepest


INFRASTRUCTURE = (OSError, ConnectionError, TimeoutError, EOFError)
DATABASE_AWAY = (sqlalchemy_exc.OperationalError, sqlalchemy_exc.InterfaceError, sqlalchemy_exc.DisconnectionError,
                 sqlalchemy_exc.TimeoutError)


def is_infrastructure_failure(error: BaseException) -> bool:
    """A failure of the machine or its services (network, disk, database, broker) that another attempt
    (or request) may not meet; anything else a solver raises (numerical breakdown, a bug) repeats on the
    same input. The API answers these with 503 and ``Retry-After``, the runner retries them."""
    if isinstance(error, INFRASTRUCTURE):
        return True
    if isinstance(error, sqlalchemy_exc.SQLAlchemyError):  # not a constraint or a statement the code got wrong
        return isinstance(error, DATABASE_AWAY) or bool(getattr(error, "connection_invalidated", False))
    module = type(error).__module__ or ""
    return module.startswith(("psycopg", "redis", "kombu", "celery", "billiard", "amqp"))



# ---- bounded intake of JSON: counted before it is parsed ------------------------------------------------

# Most JSON values (numbers, strings, literals, arrays, objects) one body may hold. Validation in the API
# process costs about 2.6 us and 170 bytes per value (measured: an alignment body of 10^6 connections, 7x10^6
# values, took 18.5 s and 1.2 GB); this budget keeps one submission under 3 s and 200 MB of validation, and
# the pre-scan that enforces it under 2 s. Large numeric data travels as files (uploads are read in a
# bounded process) or as base64 NPY strings, one value each.
MAX_JSON_VALUES = 1_000_000

_STRING = re.compile(rb'"[^"\\]*(?:\\.[^"\\]*)*"')
_TOKEN = re.compile(rb'"[^"\\]*(?:\\.[^"\\]*)*"|[\[\]{},]')
_COMMA, _OPEN_ARRAY, _CLOSE_ARRAY, _OPEN_OBJECT, _CLOSE_OBJECT, _QUOTE = b",[]{}\""


@functools.lru_cache(maxsize=64)
def array_bounds(model: type) -> dict[tuple[str, ...], int]:
    """The declared ``maxItems`` of every array of a pydantic model's JSON schema, by its path (object keys as
    the JSON spells them, ``*`` for any item of an array). Where alternatives (a union) disagree the larger
    bound holds; an array one alternative leaves unbounded is left out."""
    schema = model.model_json_schema(by_alias=True, mode="validation")
    definitions = schema.get("$defs", {})
    found: dict[tuple[str, ...], list[int | None]] = {}

    def walk(node: Any, path: tuple[str, ...], seen: frozenset[str]) -> None:
        if not isinstance(node, dict) or len(path) > 64:
            return
        ref = node.get("$ref")
        if isinstance(ref, str) and ref.startswith("#/$defs/"):
            name = ref[len("#/$defs/"):]
            if name not in seen:  # a recursive model: its deeper levels are bounded by the total budget
                walk(definitions.get(name, {}), path, seen | {name})
        for key in ("anyOf", "oneOf", "allOf"):
            for member in node.get(key, ()):
                walk(member, path, seen)
        if node.get("type") == "array" or "items" in node or "prefixItems" in node:
            bound = node.get("maxItems")
            if bound is None and "prefixItems" in node and node.get("items") is False:
                bound = len(node["prefixItems"])
            found.setdefault(path, []).append(bound)
            walk(node.get("items"), path + ("*",), seen)
            for member in node.get("prefixItems", ()):
                walk(member, path + ("*",), seen)
        for key, member in (node.get("properties") or {}).items():
            walk(member, path + (key,), seen)

    walk(schema, (), frozenset())
    return {path: max(bounds) for path, bounds in found.items() if bounds and None not in bounds}


def prescan_json(data: bytes | str, bounds: dict[tuple[str, ...], int], what: str,
                 max_values: int = MAX_JSON_VALUES) -> None:
    """Bounds of a JSON document checked before it is parsed, so that its cost is that of the bound, never of the
    document. A tokenizer (a regular expression over the bytes; nothing is built) counts each array's items
    against its declared bound (``bounds``, from :func:`array_bounds`) and the document's values against
    ``max_values``, and stops at the first that passes: an array past its bound is ``too_long`` (what pydantic
    would say after validating every item), a document past the budget ``json_too_large`` naming the outermost
    array being read. Malformed JSON is left to the parser that follows."""
    if isinstance(data, str):
        data = data.encode("utf-8", "surrogatepass")
    if 1 + data.count(b",") + data.count(b"[") + data.count(b"{") <= max_values:
        return  # an upper bound of the values, at C speed: within the budget validation is bounded and states
        # the declared bounds itself
    # a frame per open container: [is_array, generic path, commas so far, bound, current key, expecting a key]
    frames: list[list[Any]] = []
    top: list[Any] | None = None
    values = 1  # each comma outside a string starts one more value, each container holds at least one
    for match in _TOKEN.finditer(data):
        token = match.group()
        first = token[0]
        if first == _QUOTE:
            if top is not None and top[5]:
                top[4] = token[1:-1].decode("utf-8", "replace")
                top[5] = False
            continue
        if first == _COMMA:
            values += 1
            if top is not None:
                if top[0]:
                    top[2] += 1
                    if top[3] is not None and top[2] >= top[3]:
                        loc = _location(frames)[:-1]
                        raise Unprocessable(
                            f"{what}: {pointer(loc) or '(body)'} has more than {top[3]} items, the most it may have.",
                            errors=[field_problem(loc, f"List should have at most {top[3]} items (counted before "
                                                       f"validation: it has more)", "too_long")])
                else:
                    top[5] = True
        elif first == _CLOSE_ARRAY or first == _CLOSE_OBJECT:
            if frames:
                frames.pop()
                top = frames[-1] if frames else None
        else:
            values += 1
            path: tuple[str, ...] = () if top is None else top[1] + (("*",) if top[0] else (top[4],))
            is_array = first == _OPEN_ARRAY
            top = [is_array, path, 0, bounds.get(path) if is_array else None, None, not is_array]
            frames.append(top)
        if values > max_values:
            loc = _location(frames)
            outer = next((i for i, frame in enumerate(frames) if frame[0]), None)
            loc = loc[:outer] if outer is not None else loc[:1]
            raise Unprocessable(
                f"{what} holds more than {max_values} JSON values, the most one submission may hold "
                f"(the largest part: {pointer(loc) or '(body)'}); send large data as a file.",
                errors=[field_problem(loc, f"the document holds more than {max_values} values (numbers, strings, "
                                           f"lists, objects); counted before validation", "json_too_large")])


def _location(frames: list[list[Any]]) -> list[str | int]:
    """The JSON path of the value being read: each array's index so far, each object's current key."""
    return [frame[2] if frame[0] else frame[4] for frame in frames]
