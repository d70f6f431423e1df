"""An IFC file's instances held against the schema its header's FILE_SCHEMA names (dedup refuses a file of another
schema at intake, polyhedra warns that its quantities may be read from other attributes).

IfcOpenShell reads every instance by the header's schema: an entity that schema lacks is dropped, and an instance
written with another number of attributes is padded or cut without a word. The first instance of each entity is
looked at, its attribute values counted from its text (the model is not parsed), and the schemas whose count it has
are named: an IFC2X3 model labelled IFC4 writes its IfcColumn with 8 values, IFC4's has 9.
"""

from __future__ import annotations

import functools
import re
from collections.abc import Iterable
from dataclasses import dataclass

from plantsolve.solvers.step_file import instance_text, written_attributes

SCHEMAS = ("IFC2X3", "IFC4", "IFC4X3_ADD2")  # the schemas IfcOpenShell reads and the IFC kinds accept


@functools.lru_cache(maxsize=4096)  # a few hundred entities a schema, asked for again per chunk and per file
def declared(schema: str, entity: str) -> tuple[str, int] | None:
    """``entity``'s name as ``schema`` spells it and how many attributes it has there; None when the schema has no
    such entity (or names a type by it)."""
    import ifcopenshell  # noqa: PLC0415  (third-party, only needed for IFC)

    try:
        declaration = ifcopenshell.schema_by_name(schema).declaration_by_name(entity)
        return declaration.name(), declaration.attribute_count()
    except (RuntimeError, IndexError, AttributeError):  # no such entity there; a type declaration has no attributes
        return None


def attribute_count(schema: str, entity: str) -> int | None:
    """How many attributes ``entity`` has in ``schema``, None when the schema has no such entity."""
    found = declared(schema, entity)
    return None if found is None else found[1]


def counts_elsewhere(counts: dict[str, int | None]) -> str:
    """'9 in IFC4, none in IFC2X3': an entity's attribute count in each schema of ``counts``."""
    return ", ".join(f"{count} in {schema}" if count is not None else f"none in {schema}"
                     for schema, count in counts.items())


@dataclass(frozen=True)
class Misfit:
    """The first instance of an entity that the header's schema does not read as written."""

    start: int  # where its '#' is in the text scanned
    number: str  # its instance number
    name: str  # its entity as written, in capitals
    entity: str | None  # as the header's schema spells it; None: the schema has no such entity
    written: int | None  # the attribute values it writes (None: the schema has no such entity)
    expected: int | None  # the header's schema's count
    elsewhere: dict[str, int | None]  # the entity's count in each other schema of SCHEMAS (None: no such entity)

    @property
    def fits(self) -> list[str]:
        """The other schemas the instance is of: those having its entity (when the header's has not), or having it
        with as many attributes as it writes."""
        return [schema for schema, count in self.elsewhere.items()
                if count is not None and (self.entity is None or count == self.written)]


def first_misfit(text: str | bytes, definitions: Iterable[re.Match | None], schema: str, *, unknown: bool,
                 limit: int | None = None) -> Misfit | None:
    """The first of ``definitions`` (matches in ``text``, its strings and comments blanked by
    ``blank_strings_and_comments``: group 1 the instance number, group 2 its entity; the first of each entity looked
    at) whose entity ``schema`` does not have (when ``unknown``; else passed over) or whose
    instance writes another number of attribute values than the entity has there. An instance not closed in
    ``text`` is passed over (the parse counts it); ``limit``: at most so many entities of the schema looked at."""
    seen: set[str] = set()
    for match in definitions:
        if match is None:
            continue
        name = match.group(2)
        name = (name.decode("ascii") if isinstance(name, bytes) else name).upper()
        if not name or name in seen:  # a complex instance names its parts inside its brackets
            continue
        if limit is not None and len(seen) >= limit:
            break
        number = match.group(1)
        number = number.decode("ascii") if isinstance(number, bytes) else number
        others = [other for other in SCHEMAS if other != schema]
        found = declared(schema, name)
        if found is None:
            if unknown:
                return Misfit(match.start(1) - 1, number, name, None, None, None,
                              {other: attribute_count(other, name) for other in others})
            continue
        seen.add(name)
        instance = instance_text(text, match.start(1) - 1, blanked=text)
        if instance is None:
            continue
        written = written_attributes(instance.decode("latin-1") if isinstance(instance, bytes) else instance)
        entity, expected = found
        if written is not None and written != expected:
            return Misfit(match.start(1) - 1, number, name, entity, written, expected,
                          {other: attribute_count(other, entity) for other in others})
    return None
