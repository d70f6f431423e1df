"""Reading and writing models with IfcOpenShell. Bad input (not a STEP file, truncated, unknown schema)
is refused with a 422 naming the file. The optimized model is written to and read back from memory:
``to_string`` gives the same bytes as ``write``, without a temporary file."""

from __future__ import annotations

import itertools
import re
from collections import Counter

import ifcopenshell

from plantsolve.solvers.base import reject, utf16_without_mark
from plantsolve.solvers.ifc_schema import SCHEMAS, attribute_count, counts_elsewhere
from plantsolve.solvers.other_kinds import file_holds
from plantsolve.solvers.step_file import (
    blank_strings_and_comments,
    line_ends,
    where_cut,
    written_attributes,
)

# an instance's definition: '#12=' after a line's start or the ';' ending the one before, looked for in the text with
# its strings and comments blanked (a ';#3=B' in a string is no definition)
DEFINITION = re.compile(rb"(?:^|;)[ \t\r]*#(\d+)[ \t]*=[ \t]*([A-Za-z0-9_]*)", re.MULTILINE)
MAX_NAMED = 5
HEADER_BYTES = 4096  # the STEP header is looked for this far in
MAX_INSTANCE_NUMBER = 2**31 - 1  # IfcOpenShell's by_id takes a C int
# IfcOpenShell's parser on an instance written with more or fewer attributes than its entity has in the header's
# schema (it pads or drops them without failing): "Expected 9 attribute values, found 8 for instance #955"
ATTRIBUTE_COUNT = "VAL016"
_COUNTS = re.compile(r"Expected (\d+) attribute values, found (\d+) for instance #(\d+)")


def check_header(head: bytes, tail: bytes) -> None:
    """A whole STEP physical file, judged by its first ``HEADER_BYTES`` and its last ``TRAILER_BYTES``."""
    head = head[:HEADER_BYTES].lstrip(b"\xef\xbb\xbf \r\n\t")
    if not head:
        raise reject("the IFC model is empty (no STEP text; an .ifczip holding an empty .ifc?)")
    if head[:2] in (b"\xff\xfe", b"\xfe\xff") or utf16_without_mark(head[:8]) is not None:
        raise reject("the file is UTF-16 text (two bytes a character, as Windows 'Unicode' saves it): a STEP physical "
                     "file is 8-bit text; save it as UTF-8 or ANSI and send it again")
    if not head.startswith(b"ISO-10303-21;"):
        holds = file_holds(head)
        raise reject(f"not an IFC file{f': it holds {holds}' if holds else ''} (a STEP physical file starts with "
                     "'ISO-10303-21;')")
    if b"FILE_SCHEMA" not in head.upper():
        raise reject("not an IFC file: no FILE_SCHEMA in the header")
    cut = where_cut(tail)
    if cut is not None:
        raise reject(f"truncated STEP file: it does not end with 'END-ISO-10303-21;' — {cut}; the "
                     "file was cut in transfer or export, and nothing of a cut model is optimized (send the whole file)")


def parser_log() -> ifcopenshell.logger:
    """A logger that keeps one parse's messages in memory (the parse's own, not the process's log)."""
    log = ifcopenshell.logger()
    log.output_format(ifcopenshell.logger.FMT_INMEMORY)
    return log


def open_path(path: str, log: ifcopenshell.logger | None = None) -> ifcopenshell.file:
    """The model at ``path``; ``log``: a :func:`parser_log` that receives the parser's messages."""
    try:
        model = ifcopenshell.open(path, logger=log)
    except Exception as e:  # the parser raises several kinds for a broken file
        message = str(e) or type(e).__name__
        if "schema" in message.lower():
            raise reject(f"unknown or unsupported IFC schema: {message}") from None
        raise reject(f"unreadable IFC file: {message}") from None
    check_model(model)
    return model


def check_model(model: ifcopenshell.file, instances: int | None = None) -> None:
    """Refuses a model this solver cannot optimize; ``instances``: how many the file holds, when ``model`` is
    only part of it."""
    largest = model.get_max_id()
    # the optimization numbers what it adds after the largest instance: at most a few per instance there is;
    # the instances are counted only when the largest number alone leaves doubt (there are at most that many)
    if 3 * largest + 1000 > MAX_INSTANCE_NUMBER and \
            largest + 2 * (instances or len(model.entity_names())) + 1000 > MAX_INSTANCE_NUMBER:
        raise reject(f"instance #{largest}: IfcOpenShell addresses instance numbers up to #{MAX_INSTANCE_NUMBER:,}, "
                     "and the optimized model numbers what it adds after the largest; renumber the file's instances "
                     "from #1, as any IFC export or STEP tool does")
    if model.schema not in ("IFC2X3", "IFC4") and not model.schema.startswith("IFC4X3"):
        raise reject(f"unsupported IFC schema {model.schema!r}; accepted: IFC2X3, IFC4, IFC4X3_ADD2")
    if not model.by_type("IfcProject"):
        counts = Counter(entity.is_a() for entity in itertools.islice(model, 100_000))
        held = ", ".join(f"{n:,} {name}" for name, n in counts.most_common(3)) or "no instances"
        raise reject(f"not an IFC model: the file has no IfcProject (every model has one, with its units and "
                     f"representation contexts); it holds {held}")


def model_text(model: ifcopenshell.file) -> bytes:
    """The model as STEP text (IfcOpenShell writes ASCII: other characters are escaped)."""
    return model.to_string().encode()


def read_back(text: bytes) -> ifcopenshell.file:
    """A model from STEP text we wrote (the proof reads the optimized file as a user would)."""
    return ifcopenshell.file.from_string(text.decode())


def instance_line(text: bytes, number: int) -> int | None:
    """The line of a STEP text on which instance ``#number`` is defined (lines ended by LF, CR or CR LF), None when it
    is not."""
    blanked = blank_strings_and_comments(text)
    found = re.search(rb"(?:^|[;\n\r])[ \t]*#" + str(number).encode() + rb"[ \t]*=", blanked)
    return None if found is None else line_ends(blanked, 0, found.end()) + 1


def defined_instances(text: bytes) -> int:
    """How many instances a STEP text defines (IfcOpenShell's count falls short of it where it could not read one)."""
    return sum(1 for _ in DEFINITION.finditer(blank_strings_and_comments(text)))


def refuse_unread(text: bytes, model: ifcopenshell.file) -> None:
    """Refuses a model IfcOpenShell read only part of, naming the lines it left out and why: an id defined twice
    (one of the two definitions is lost), an entity the header's FILE_SCHEMA does not have (an IFC4 file labelled
    IFC2X3), or a line it could not parse (attributes of another schema). Optimizing what was read would write a
    model without them."""
    text = blank_strings_and_comments(text)

    def line(match) -> int:
        return line_ends(text, 0, match.start(1)) + 1

    first: dict[int, re.Match] = {}
    twice: list[str] = []
    foreign: dict[str, int] = {}
    unread: list[str] = []
    schema = ifcopenshell.schema_by_name(model.schema_identifier)
    known: dict[str, bool] = {}
    for match in DEFINITION.finditer(text):
        number, name = int(match.group(1)), match.group(2).decode("ascii").upper()
        if number in first:
            if len(twice) < MAX_NAMED:
                twice.append(f"#{number} on lines {line(first[number])} and {line(match)}")
            continue
        first[number] = match
        if not name:  # a complex instance, '#12=(IFCA(...)IFCB(...))': its parts are named inside the brackets
            if len(unread) < MAX_NAMED and _missing(model, number):
                unread.append(f"{line(match)} (a complex instance)")
            continue
        if name not in known:
            try:
                schema.declaration_by_name(name)
                known[name] = True
            except (RuntimeError, IndexError):
                known[name] = False
        if not known[name]:
            if name not in foreign and len(foreign) < MAX_NAMED:
                foreign[name] = line(match)
        elif len(unread) < MAX_NAMED and _missing(model, number):
            unread.append(f"{line(match)} ({name})")
    why = []
    if twice:
        why.append(f"instance numbers defined twice ({', '.join(twice)}): IfcOpenShell keeps one of each, and what "
                   "refers to the other would change")
    if foreign:
        listed = ", ".join(f"{name} (line {at})" for name, at in foreign.items())
        why.append(f"entities the header's FILE_SCHEMA {model.schema_identifier} does not have: {listed}")
    if unread:
        why.append(f"lines IfcOpenShell could not read as {model.schema_identifier}: {', '.join(unread)}")
    if why:
        raise reject("the model was read only in part, and an optimized model would lose the rest: " + "; ".join(why)
                     + ("" if twice else "; is the file of another schema than its header's FILE_SCHEMA says?"))


def _missing(model: ifcopenshell.file, number: int) -> bool:
    try:
        model.by_id(number)
    except RuntimeError:
        return True
    return False


def misfits_schema(model: ifcopenshell.file, text: bytes, lines) -> bool:
    """Whether the first line of an entity in ``text`` (a model's STEP text, ``model`` parsed from it) is written
    (``lines``: ids → their lines as the file has them) with another number of attributes than the entity has in the
    model's schema: the file is of another schema than its header says (what a whole parse with a :func:`parser_log`
    names: :func:`refuse_attribute_counts`). Each entity's first line is searched for in the text: the model's own
    instances, listed by type, would each stay in IfcOpenShell's cache of instance objects."""
    schema = ifcopenshell.schema_by_name(model.schema_identifier)
    firsts: dict[int, int] = {}
    for entity in model.types():
        found = re.search(rb"(?:^|\n)#(\d+)[ \t]*=[ \t]*" + entity.encode() + rb"[ \t]*\(", text, re.IGNORECASE)
        if found:
            firsts[int(found.group(1))] = schema.declaration_by_name(entity).attribute_count()
    for number, line in lines(list(firsts)).items():
        written = written_attributes(line)
        if written is not None and written != firsts[number]:
            return True
    return False


def refuse_attribute_counts(log: ifcopenshell.logger, model: ifcopenshell.file, text: bytes) -> None:
    """Refuses a model whose instances have another number of attributes than their entities have in the header's
    FILE_SCHEMA (an IFC2X3 file labelled IFC4: its IfcColumn has 8, IFC4's 9): the parser padded or dropped values
    without a word, and the optimized file would be written in a schema its content is not. Names the first such
    line, its entity's count in each schema dedup reads, and how many instances are so."""
    wrong = [found for message in log.log_messages() if message.code == ATTRIBUTE_COUNT
             for found in (_COUNTS.search(message.message),) if found]
    if not wrong:
        return
    expected, written, number = (int(g) for g in wrong[0].groups())
    entity = model.by_id(number).is_a()
    at = instance_line(text, number)
    line = f"line {at}: " if at else ""
    counts = {schema: attribute_count(schema, entity) for schema in SCHEMAS if schema != model.schema_identifier}
    fits = [schema for schema, count in counts.items() if count == written]
    others = counts_elsewhere(counts)
    entities = sorted({model.by_id(int(found.group(3))).is_a() for found in wrong})
    plural = "" if written == 1 else "s"
    raise reject(
        f"{line}#{number}={entity.upper()} is written with {written} attribute{plural}, and {entity} has {expected} in "
        f"the header's FILE_SCHEMA {model.schema_identifier} ({others}); {len(wrong):,} instance(s) of "
        f"{', '.join(entities[:MAX_NAMED])}{' …' if len(entities) > MAX_NAMED else ''} are so. "
        + (f"The content looks like {' or '.join(fits)}: is the header's FILE_SCHEMA wrong? Write the schema the "
           "exporter wrote the model in" if fits else "The file is of another schema than its header says, or broken")
        + "; nothing of it is optimized, as the optimized model would be written in a schema its content is not")
