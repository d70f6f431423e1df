"""Checks at submission: a file is there, it is base64 (JSON), it looks like an IFC file, the sharing mode suits
its schema (read from the header without parsing the model), and a tolerance is no distance no copy could be off
by in the unit the file defines (its text scanned, the model not parsed)."""

from __future__ import annotations

import functools
import itertools
import re
from collections import Counter

import ifcopenshell
from ifcopenshell import ifcopenshell_wrapper

from plantsolve.solvers.base import reject
from plantsolve.solvers.dedup.ifcio import DEFINITION
from plantsolve.solvers.dedup.placements import world_coordinate_problem, world_refusal
from plantsolve.solvers.dedup.source import IfcSource
from plantsolve.solvers.dedup.tolerance import refuse_at_intake, stated_length_unit
from plantsolve.solvers.ifc_schema import counts_elsewhere, first_misfit
from plantsolve.solvers.other_kinds import file_holds
from plantsolve.solvers.step_file import (
    blank_strings_and_comments,
    carried_from,
    instance_text,
    left_open,
    line_ends,
)

_SCHEMA = re.compile(rb"FILE_SCHEMA\s*\(\s*\(\s*'([A-Za-z0-9_]+)", re.IGNORECASE)


def header_schema(text: bytes) -> str | None:
    found = _SCHEMA.search(text[:65536])
    return found.group(1).decode().upper() if found else None


def _schema_definition(schema: str):
    try:
        return ifcopenshell_wrapper.schema_by_name(schema)
    except RuntimeError:  # IfcOpenShell knows IFC4X3 by its latest addendum's name
        return ifcopenshell_wrapper.schema_by_name("IFC4X3_ADD2") if schema.startswith("IFC4X3") else None


def _is_product(declaration) -> bool:
    while declaration is not None:
        if declaration.name() == "IfcProduct":
            return True
        declaration = declaration.supertype() if hasattr(declaration, "supertype") else None  # a type: no entity
    return False


def refuse_unknown_entity_types(names: list[str], schema: str) -> None:
    """A 422 naming ``options.entity_types[i]`` when it is no entity of the file's schema (a typing slip,
    ``IfcWal``; an IFC4 name in an IFC2X3 file), or no product: nothing would be selected, and the run would
    share nothing without a word on why."""
    definition = _schema_definition(schema)
    if definition is None:
        return
    for i, name in enumerate(names):
        try:
            declaration = definition.declaration_by_name(name)
        except RuntimeError:
            raise reject(f"{name!r} is no entity of the file's schema {schema}: no product would be selected",
                         ("options", "entity_types", i)) from None
        if not _is_product(declaration):
            raise reject(f"{declaration.name()} is no product (IfcProduct subtype) in {schema}: only products "
                         "share geometry; name product entities such as IfcWall or IfcFlowSegment",
                         ("options", "entity_types", i))


CHUNK = 1 << 20
CARRIED = 4096  # of a chunk without a ';', the end kept for the next: the start of a definition cut there
# IfcProduct.Representation is an IfcProductRepresentation: IfcProductDefinitionShape (IFC2X3 may write the
# supertype itself); without one, no product has geometry
SHAPES = {b"IFCPRODUCTDEFINITIONSHAPE", b"IFCPRODUCTREPRESENTATION"}


@functools.lru_cache(maxsize=8)  # a schema's table, the same every call: walked once per process (3 ms)
def _entities(schema: str) -> dict[bytes, tuple[str, bool]]:
    """The schema's entities by their name as STEP writes it (capitals): (their name, whether a product)."""
    return {d.name().upper().encode(): (d.name(), _is_product(d))
            for d in _schema_definition(schema).declarations() if isinstance(d, ifcopenshell_wrapper.entity)}


@functools.lru_cache(maxsize=8)
def _products(schema: str) -> frozenset[bytes]:
    return frozenset(name for name, (_, is_product) in _entities(schema).items() if is_product)


def _held(counts: Counter, entities: dict[bytes, tuple[str, bool]]) -> str:
    return ", ".join(f"{n:,} {entities.get(name, (name.decode(errors='replace'),))[0]}"
                     for name, n in counts.most_common(3))


def refuse_without_products(source: IfcSource, schema: str) -> None:
    """A 422 for a model with nothing to share: no instance at all (a header and an empty DATA section), no product,
    or no product shape. The instances' entity names are scanned in chunks (the model not parsed) until a product
    and a shape were both seen, in a usual export near the start; the solve refused these files only after the
    job had been accepted. What is scanned is also held against the header's schema (:func:`refuse_other_schema`)."""
    entities = _entities(schema)
    products = _products(schema)
    counts: Counter = Counter()
    product = shape = False
    carry = b""
    lines_before = 0
    open_since = None  # the line of a string or comment the carried text starts inside
    first = True
    with source.stream() as stream:
        while chunk := stream.read(CHUNK):
            whole = carry + chunk
            # strings and comments blanked first: a ';' or '#3=B' in one is none of the file's (one left open at the
            # chunk's end is blanked to it, and the cut comes before it)
            blanked = blank_strings_and_comments(whole)
            cut = blanked.rfind(b";")  # an instance definition is seen whole: the text up to its last ';'
            if cut < 0:  # inside one long instance (a point list): what is passed over still has its lines
                kept, opener, opened = carried_from(whole, max(0, len(whole) - CARRIED))
                if opened is not None and open_since is None:
                    open_since = lines_before + line_ends(whole, 0, opened) + 1
                lines_before += line_ends(whole, 0, kept)
                carry, text, blanked = opener + whole[kept:], b"", b""
            else:
                carry, text, blanked = whole[cut + 1:], whole[:cut + 1], blanked[:cut + 1]
                open_since = None
            names = Counter(m.group(2).upper() for m in DEFINITION.finditer(blanked))
            refuse_other_schema(blanked, [first_definition(blanked, name) for name in names
                                          if name and name not in counts], lines_before, schema)
            if first:  # the contexts and their world coordinate systems come first in an export
                refuse_unplaceable_world(text, schema, blanked)
                first = False
            lines_before += line_ends(blanked)
            counts.update(names)
            product = product or not products.isdisjoint(names)
            shape = shape or not SHAPES.isdisjoint(names)
            if product and shape:
                return
    if (opened := left_open(carry)) is not None:  # the instances after it were read as a string's or comment's text
        what = "a string ('...')" if carry[opened:opened + 1] == b"'" else "a comment (/* ... */)"
        line = open_since if opened == 0 and open_since is not None else lines_before + line_ends(carry, 0, opened) + 1
        raise reject(f"line {line}: {what} opened here is not closed before "
                     "the end of the file (or a quote before it is missing): the instances after it cannot be read; "
                     "export the model again")
    if not counts:
        raise reject("the file holds no model: its DATA section has no instance (a STEP header alone); export the "
                     "model with its products")
    if not product:
        raise reject(f"the model has no product (no IfcProduct such as IfcWall or IfcBuildingElementProxy), so no "
                     f"geometry to share; it holds {_held(counts, entities)}")
    raise reject("no product of the model has geometry (no IfcProductDefinitionShape: every product's Representation "
                 f"is empty), so there is nothing to share; it holds {_held(counts, entities)}")


def first_definition(text: bytes, name: bytes) -> re.Match | None:
    """A definition of an instance of entity ``name`` (as STEP writes it, capitals) in ``text`` (its strings and
    comments blanked), which holds one: the
    first written '#n=NAME(', found by a plain search (a case-blind pattern search took a second over a 60 MB model)
    and matched from the line start or ';' before its '#' (several instances may share a line), else the first the
    pattern finds."""
    at = text.find(b"=" + name + b"(")
    if at >= 0:
        number = text.rfind(b"#", 0, at)
        semicolon, newline = text.rfind(b";", 0, number), text.rfind(b"\n", 0, number)
        found = DEFINITION.match(text, semicolon if semicolon > newline else newline + 1)
        if found is not None and found.group(2).upper() == name:
            return found
    return re.search(rb"(?:^|;)[ \t\r]*#(\d+)[ \t]*=[ \t]*(" + re.escape(name) + rb")(?![A-Za-z0-9_])", text,
                     re.IGNORECASE | re.MULTILINE)


def refuse_other_schema(text: bytes, firsts: list[re.Match | None], lines_before: int, schema: str) -> None:
    """A 422 for a model of another schema than its header's FILE_SCHEMA, seen in the text intake scans: an entity
    the schema does not have, or an entity's first instance written with another number of attributes than it has
    there (an IFC2X3 model labelled IFC4: its IfcColumn has 8, IFC4's 9). The solve's parse refused these only after
    the job had been accepted. ``text``: its strings and comments blanked, ``firsts``: definitions of entities not seen in an earlier chunk, ``lines_before``:
    the lines of the file before ``text``."""
    misfit = first_misfit(text, firsts, schema, unknown=True)
    if misfit is None:
        return
    at = lines_before + line_ends(text, 0, misfit.start) + 1
    fits = misfit.fits
    if misfit.entity is None:
        raise reject(f"line {at}: #{misfit.number}={misfit.name} is no entity of the header's "
                     f"FILE_SCHEMA {schema}" + (f" (it is one of {' and '.join(fits)})" if fits else "") +
                     ": the file is of another schema than its header says, and nothing of it can be optimized "
                     "as that schema; write the schema the exporter wrote the model in")
    written = misfit.written
    raise reject(f"line {at}: #{misfit.number}={misfit.name} is written with {written} "
                 f"attribute{'' if written == 1 else 's'}, and "
                 f"{misfit.entity} has {misfit.expected} in the header's FILE_SCHEMA {schema} "
                 f"({counts_elsewhere(misfit.elsewhere)}). "
                 + (f"The content looks like {' or '.join(fits)}: is the header's FILE_SCHEMA wrong? "
                    if fits else "The file is of another schema than its header says, or broken; ")
                 + "nothing of it is optimized, as the optimized model would be written in a schema its content "
                 "is not")


_CONTEXT = re.compile(rb"(?:^|;)[ \t\r]*#(\d+)[ \t]*=[ \t]*IFCGEOMETRICREPRESENTATIONCONTEXT[ \t]*\(",
                      re.IGNORECASE | re.MULTILINE)
_REFERENCE = re.compile(rb"#(\d+)")
WORLD_DEPTH = 3  # context -> its WorldCoordinateSystem -> its Location, Axis, RefDirection
# a model has a context or two (3D 'Model', 2D 'Plan'): a text of thousands is judged by its first few, each parsed
# as a model of its own
MAX_CONTEXTS = 4


def _index(text: bytes) -> dict[int, int]:
    """Where ``text`` (its strings and comments blanked) defines each instance: its number -> the offset of its '#'
    (the first of two definitions)."""
    index: dict[int, int] = {}
    for match in DEFINITION.finditer(text):
        index.setdefault(int(match.group(1)), match.start(1) - 1)
    return index


def _definitions(text: bytes, blanked: bytes, index: dict[int, int], number: int, depth: int,
                 found: dict[int, bytes]) -> bool:
    """``found`` filled with the definitions of instance ``number`` and of those it refers to, ``depth`` levels down;
    False when one of them is not in ``text`` (further on in the file: the solve looks at it)."""
    if number in found:
        return True
    instance = instance_text(text, index[number], blanked) if number in index else None
    if instance is None:
        return False
    found[number] = instance
    references = _REFERENCE.findall(blanked[index[number]:index[number] + len(instance)].split(b"=", 1)[1])
    return depth == 0 or all(_definitions(text, blanked, index, int(ref), depth - 1, found) for ref in references)


def refuse_unplaceable_world(text: bytes, schema: str, blanked: bytes | None = None) -> None:
    """A 422 for a representation context whose WorldCoordinateSystem no product can be placed in (a writer's 1e308, a
    zero or parallel axis, a location beyond the context's Precision), read from the file's first chunk: the context
    and the instances it refers to as a model of their own, judged as the solve judges the whole model's (which it
    refused only after the job had been accepted). The text's definitions are indexed once, and its first
    MAX_CONTEXTS contexts judged; they are looked for in ``blanked``, the text with its strings and comments
    blanked (made here when not given), and read from ``text``."""
    blanked = blank_strings_and_comments(text) if blanked is None else blanked
    contexts = [int(found.group(1)) for found in itertools.islice(_CONTEXT.finditer(blanked), MAX_CONTEXTS)]
    if not contexts:
        return
    index = _index(blanked)
    for context in contexts:
        found: dict[int, bytes] = {}
        if not _definitions(text, blanked, index, context, WORLD_DEPTH, found):
            continue
        data = b"\n".join(found[k] for k in sorted(found)).decode("latin-1")
        try:
            world = ifcopenshell.file.from_string(
                "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION((''),'2;1');\nFILE_NAME('','',(''),(''),'','','');\n"
                f"FILE_SCHEMA(('{schema}'));\nENDSEC;\nDATA;\n{data}\nENDSEC;\nEND-ISO-10303-21;\n")
            problem = world_coordinate_problem(world, text=text)
        except Exception:  # noqa: BLE001 - what the parser cannot read alone, the solve reads in the whole model
            continue
        if problem:
            raise reject(world_refusal(problem))


def check_input(source: IfcSource) -> None:
    schema = header_schema(source.header())
    if schema is None:
        raise reject("no FILE_SCHEMA in the STEP header")
    if not schema.startswith("IFC"):
        raise reject(f"not an IFC model: it holds {file_holds(source.header())} (FILE_SCHEMA {schema!r}); dedup reads "
                     "IFC2X3, IFC4 and IFC4X3 models")
    if schema.startswith("IFC4X3") and schema not in ifcopenshell_wrapper.schema_names():
        # IfcOpenShell parses IFC 4.3 by its final release's name only: 'IFC4X3' (a release candidate's label, some
        # exporters') failed in the parse as "No schema loaded", after a check that had listed IFC4X3 as accepted
        raise reject(f"FILE_SCHEMA {schema!r}: IFC 4.3 is read as its final release, 'IFC4X3_ADD2' (IfcOpenShell reads "
                     "no other 4.3 label); a model of IFC 4.3's entities can say FILE_SCHEMA(('IFC4X3_ADD2')) in its "
                     "header")
    if not (schema in ("IFC2X3", "IFC4") or schema.startswith("IFC4X3")):
        raise reject(f"unsupported IFC schema {schema!r}; accepted: IFC2X3, IFC4, IFC4X3_ADD2")
    refuse_without_products(source, schema)
    if source.options.tolerance is not None:
        with source.stream() as stream:
            unit = stated_length_unit(stream)
        if unit is not None:
            refuse_at_intake(source.options.tolerance, unit)
    if source.options.entity_types:
        refuse_unknown_entity_types(source.options.entity_types, schema)
    if source.options.sharing == "product_shape" and schema == "IFC2X3":
        raise reject("'product_shape' needs IFC4 or later: in IFC2X3 an IfcProductDefinitionShape belongs to "
                     "exactly one product (ShapeOfProduct [1:1]); use 'mapped_item' or 'auto'", ("options", "sharing"))
