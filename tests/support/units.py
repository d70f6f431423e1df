"""Which numbers of a result schema carry no unit: the check behind 'every physical quantity has its unit'.

A result field that holds a number (or a list of them, at any depth) must state its unit in the OpenAPI
document as ``x-unit`` (``plantsolve.schemas.common.unit``); integers are counts and indices and need none.
A ``{name}`` in a unit names the result field that holds the unit and must exist.
"""

from __future__ import annotations

import re
from typing import Any

import pint

_PLACEHOLDER = re.compile(r"\{([A-Za-z_][A-Za-z0-9_.]*)\}")
_REGISTRY = pint.UnitRegistry()


def _resolve(schema: dict[str, Any], defs: dict[str, Any]) -> dict[str, Any]:
    while "$ref" in schema:
        schema = defs[schema["$ref"].rsplit("/", 1)[-1]]
    return schema


def _holds_number(schema: dict[str, Any], defs: dict[str, Any]) -> bool:
    schema = _resolve(schema, defs)
    if schema.get("type") == "number":
        return True
    if schema.get("type") == "array":
        items = schema.get("items") or {}
        prefix = schema.get("prefixItems") or []
        return any(_holds_number(s, defs) for s in [items, *prefix] if s)
    return any(_holds_number(s, defs) for s in schema.get("anyOf", []) + schema.get("oneOf", []))


def _sub_models(schema: dict[str, Any], defs: dict[str, Any], seen: set[str]) -> list[dict[str, Any]]:
    """The object schemas a property leads to (through refs, unions, arrays and maps)."""
    out: list[dict[str, Any]] = []
    stack = [schema]
    while stack:
        s = stack.pop()
        if "$ref" in s:
            name = s["$ref"].rsplit("/", 1)[-1]
            if name in seen:
                continue
            seen.add(name)
            s = defs[name]
        if s.get("type") == "object" and "properties" in s:
            out.append(s)
        stack.extend(s.get("anyOf", []) + s.get("oneOf", []) + s.get("allOf", []))
        if isinstance(s.get("items"), dict):
            stack.append(s["items"])
        stack.extend(s.get("prefixItems", []))
        if isinstance(s.get("additionalProperties"), dict):
            stack.append(s["additionalProperties"])
    return out


def numbers_without_unit(model: type) -> list[str]:
    """Paths (``Result.field.sub``) of the numeric fields of ``model``'s schema with no ``x-unit``."""
    root = model.model_json_schema(mode="serialization")
    defs = root.get("$defs", {})
    missing: list[str] = []
    seen: set[str] = set()
    todo = [(root.get("title", model.__name__), root)]
    while todo:
        path, obj = todo.pop()
        for name, prop in obj.get("properties", {}).items():
            where = f"{path}.{name}"
            if _holds_number(prop, defs) and "x-unit" not in prop and "x-unit" not in _resolve(prop, defs):
                missing.append(where)
            todo.extend((f"{where}", sub) for sub in _sub_models(prop, defs, seen))
    return sorted(set(missing))


def units_of(model: type) -> dict[str, str]:
    """Every ``x-unit`` stated in ``model``'s schema, by the property's title-path (for the parse check)."""
    root = model.model_json_schema(mode="serialization")
    found: dict[str, str] = {}

    def walk(node: Any, path: str) -> None:
        if isinstance(node, dict):
            if "x-unit" in node:
                found[path] = node["x-unit"]
            for key, value in node.items():
                walk(value, f"{path}/{key}")
        elif isinstance(node, list):
            for i, value in enumerate(node):
                walk(value, f"{path}/{i}")

    walk(root, "")
    return found


def unreadable_units(model: type) -> list[str]:
    """Units of ``model``'s schema that pint cannot read once each ``{name}`` is read as metres."""
    bad = []
    for path, symbol in units_of(model).items():
        try:
            _REGISTRY.parse_expression(_PLACEHOLDER.sub("m", symbol))
        except Exception:  # pint raises several types for a bad expression
            bad.append(f"{path}: {symbol!r}")
    return bad
