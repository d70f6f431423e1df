"""The job domain's errors, as classes: each names its status, title and problem type, and carries
the bad fields (``errors``, each with its JSON path and RFC 6901 pointer). The HTTP app renders them
as RFC 9457 problem documents (:mod:`plantsolve.app.problems`); the CLI prints them."""

from __future__ import annotations

import functools
import json
import math
import re
import sys
from typing import Any, Iterable, Sequence

from pydantic import BaseModel, ValidationError
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


class ReadersPaused(ProblemError):
    """The forkserver that reading processes fork from failed its starts again and again, and the next is paused
    (:class:`~plantsolve.jobs.intake.ForkserverStarts`): a submission read in such a process (an upload, a large JSON
    body) is refused before anything of it is stored, asked to come back when the pause ends. The same type as the
    API's other 503s (a service it needs is away)."""

    status, title, slug = 503, "Service unavailable", "unavailable"

    def __init__(self, failures: int, seconds_left: float):
        wait = max(1, math.ceil(seconds_left))
        super().__init__(f"Uploaded files and large JSON bodies are read in processes whose server failed {failures} "
                         f"start(s) in a row; the next start is tried in {wait} s, so nothing of this request was "
                         f"stored. Submit it again after Retry-After seconds.", headers={"Retry-After": str(wait)})


def from_validation_error(error: ValidationError, prefix: Sequence[str | int] = (),
                          model: type[BaseModel] | None = None) -> Unprocessable:
    """422 naming each bad field of ``model`` (the one validated) by its path as the user wrote it
    (:func:`user_path`)."""
    errors = [field_problem([*prefix, *user_path(e["loc"], model)], e["msg"], e["type"])
              for e in error.errors(include_url=False)]
    return Unprocessable(summary(errors), errors=errors)


def from_input_rejected(error: InputRejected, prefix: Sequence[str | int] = (),
                        model: type[BaseModel] | None = None) -> Unprocessable:
    """422 of a solver's refusal: its fields' paths as the user wrote them, where one went through ``model``'s
    validation (a reader's ``validated``) and so holds pydantic's tags."""
    errors = [field_problem([*prefix, *user_path(e.loc, model)], e.msg, e.type) for e in error.errors]
    return Unprocessable(summary(errors), errors=errors)


# the wrappers pydantic's validation passes through without a step of the location, and where their inner schema is
_WRAPPED = {"model": ("schema",), "definitions": ("schema",), "default": ("schema",), "nullable": ("schema",),
            "function-after": ("schema",), "function-before": ("schema",), "function-wrap": ("schema",),
            "model-field": ("schema",), "typed-dict-field": ("schema",), "dataclass-field": ("schema",),
            "dataclass": ("schema",), "lax-or-strict": ("lax_schema", "strict_schema"),
            "json-or-python": ("json_schema", "python_schema")}


def user_path(loc: Sequence[str | int], model: type[BaseModel] | None) -> list[str | int]:
    """``loc`` of an error of ``model``'s validation as the path the user wrote: the tags pydantic puts in a location
    for the member of a union (``points.list.0.0``, ``loops.0.function-after[...].1``) left out, every other step
    kept. A location may start with steps outside the model (``file``: a reader's prefix), which are kept, and a
    solver's own location (``file.line.7``), which names no field, passes unchanged.

    The model's validation schema says which steps are a union's: walked alongside ``loc``, a step at a union (or
    a discriminated union) is the member's tag, and the next step goes on in that member (in every member when the
    tag is pydantic's generated name); a step the walk does not know ends the walk and the rest is kept as is."""
    if model is None:
        return list(loc)
    schema, refs = _core(model)
    steps = list(loc)
    start = 0
    root = _open([schema], refs)
    while start < len(steps) and isinstance(steps[start], str) and not _takes(root, steps[start]):
        start += 1  # a reader's prefix ('file'): neither a field of the model nor the tag of its member
    if start == len(steps):
        return steps
    path, nodes = steps[:start], [schema]
    for i in range(start, len(steps)):
        step = steps[i]
        if not isinstance(step, (str, int)):
            return path + steps[i:]  # no step of a document: the rest as it is
        frontier = _open(nodes, refs)
        inner = [child for node in frontier for child in _child(node, step)]
        if inner:
            path.append(step)
            nodes = inner
            continue
        members = [member for node in frontier for member in _members(node, step)]
        if members:  # a union's tag: not in the user's document
            nodes = members
            continue
        return path + steps[i:]
    return path


@functools.lru_cache(maxsize=64)
def _core(model: type[BaseModel]) -> tuple[dict, dict[str, dict]]:
    """A model's core (validation) schema and its definitions by reference."""
    schema = model.__pydantic_core_schema__
    refs: dict[str, dict] = {}
    stack: list[Any] = [schema]
    while stack:
        node = stack.pop()
        if isinstance(node, dict):
            if isinstance(node.get("ref"), str) and "type" in node:
                refs[node["ref"]] = node
            stack.extend(value for key, value in node.items() if key not in ("metadata", "serialization"))
        elif isinstance(node, (list, tuple)):
            stack.extend(node)
    return schema, refs


def _open(nodes: list[dict], refs: dict[str, dict]) -> list[dict]:
    """The nodes that take a step of a location: wrappers (a reference, a validator function, a default ...) opened."""
    found, stack, seen = [], list(nodes), set()
    while stack:
        node = stack.pop()
        if not isinstance(node, dict) or id(node) in seen:
            continue
        seen.add(id(node))
        kind = node.get("type")
        if kind == "definition-ref":
            stack.append(refs.get(node.get("schema_ref"), {}))
        elif kind == "model" and node.get("root_model"):
            stack.append(node.get("schema"))
        elif kind in _WRAPPED:
            stack.extend(node.get(key) for key in _WRAPPED[kind])
        elif kind == "chain":
            stack.extend(node.get("steps", ()))
        else:
            found.append(node)
    return found


def _takes(nodes: list[dict], step: str | int) -> bool:
    return any(_child(node, step) or _members(node, step) for node in nodes)


def _child(node: dict, step: str | int) -> list[dict]:
    """Where ``step`` leads from ``node`` as a step of the user's document (a field, an item, a key), if it does."""
    kind = node.get("type")
    if kind in ("model-fields", "typed-dict") and isinstance(step, str):
        for name, field in node.get("fields", {}).items():
            if step == name or step == field.get("validation_alias"):
                return [field]
    elif kind == "dataclass-args" and isinstance(step, str):
        return [field for field in node.get("fields", ()) if field.get("name") == step]
    elif kind in ("list", "set", "frozenset", "generator") and isinstance(step, int):
        return [node.get("items_schema") or {"type": "any"}]
    elif kind == "tuple" and isinstance(step, int) and step >= 0:
        items = node.get("items_schema") or [{"type": "any"}]
        return [items[min(step, len(items) - 1)]]
    elif kind == "dict":
        return [node.get("values_schema") or {"type": "any"}]
    return []


def _members(node: dict, step: str | int) -> list[dict]:
    """The members of a union ``node`` that ``step`` tags: a discriminated union's tag, a member's own label, or
    (a name pydantic made up, ``list[...]``, ``function-after[...]``) every unlabelled member."""
    kind = node.get("type")
    if kind == "tagged-union":
        choices = node.get("choices", {})
        return [choices[step]] if step in choices else [choices[str(step)]] if str(step) in choices else []
    if kind != "union":
        return []
    labelled = [choice[0] for choice in node.get("choices", ()) if isinstance(choice, tuple) and choice[1] == step]
    if labelled or not isinstance(step, str):
        return labelled
    return [choice for choice in node.get("choices", ()) if not isinstance(choice, tuple) and _named(choice, step)]


def _named(choice: dict, step: str) -> bool:
    """Whether ``step`` is the name pydantic gives the unlabelled union member ``choice``: its type, with what it
    holds in brackets (``list[float]``, ``function-after[check(), ...]``), or a model's class name."""
    kind = str(choice.get("type"))
    cls = choice.get("cls")
    return step == kind or step.startswith(kind + "[") or (isinstance(cls, type) and step == cls.__name__) \
        or kind == "definition-ref" and step == str(choice.get("schema_ref", "")).split(":")[0].rsplit(".", 1)[-1]


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
