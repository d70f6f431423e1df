"""What an upload holds when it is no alignment input: a file of another kind, said by name.

A PCF is recognised by its keywords, an alignment JSON by its ``components``; anything else is
refused at intake saying what it looks like (a STEP/IFC model, an LDraw model, an EnergyPlus IDF,
an XML document, a JSON document, a table of named columns, a list of x y z points), so the user
sees the wrong file at once rather than an empty result or a failure later.
"""

from __future__ import annotations

import json
import re

from plantsolve.solvers.base import reject

PCF_KEYWORDS = re.compile(r"^\s*(END-POINT|CENTRE-POINT|BRANCH1-POINT|CO-ORDS|PIPELINE-REFERENCE|ISOGEN-FILES|UNITS-BORE|"
                          r"UNITS-CO-ORDS|PIPE|ELBOW|TEE|FLANGE|VALVE)\b", re.MULTILINE)
_NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")

# top-level fields of the other kinds' JSON requests (plantsolve.schemas), the distinctive ones first
OTHER_KINDS = (
    ("flowmeter", ("pipe", "electrodes", "magnetic_field")),
    ("perfmap", ("positions", "setting_names")),
    ("polyhedra", ("vertices", "faces", "mesh")),
    ("rigidity", ("bodies", "joints", "parts")),
    ("dedup", ("filename", "file")),
    ("tube", ("points",)),  # a perfmap query holds points too: said in the message
)


_TOKEN_START = re.compile(r"-?(\d+\.?\d*([eE][-+]?\d*)?)?|t(r(ue?)?)?|f(a(l(se?)?)?)?|n(u(ll?)?)?")


def cut_json(text: str) -> int:
    """How many objects, arrays and strings a JSON text that the parser refuses leaves open, when what stops the
    parser is only the start of its last token (a text cut right after a minus sign, inside ``tru``: the parser
    says "Expecting value" one character before the end, not at it); 0 when the text is not cut that way."""
    try:
        json.loads(text)
    except json.JSONDecodeError as error:
        if _TOKEN_START.fullmatch(text[error.pos:].strip()):
            return open_at_end(text)
    return 0


def open_at_end(text: str) -> int:
    """How many objects, arrays and strings a JSON text leaves open at its end (0 for a complete one)."""
    depth = 0
    in_string = escaped = False
    for ch in text:
        if in_string:
            if escaped:
                escaped = False
            elif ch == "\\":
                escaped = True
            elif ch == '"':
                in_string = False
        elif ch == '"':
            in_string = True
        elif ch in "{[":
            depth += 1
        elif ch in "}]":
            depth -= 1
    return max(depth, 0) + in_string


def refuse_other_json(body: dict) -> None:
    """A 422 on ``file`` when a JSON upload holds no ``components`` (no alignment request), naming its fields
    and the kind whose request they are."""
    if "components" in body:
        return
    keys = [str(k) for k in body][:12]
    kind = next((k for k, fields in OTHER_KINDS if any(f in body for f in fields)), None)
    guess = f": the fields of a {kind} request, upload it to /v1/{kind}/jobs" if kind else ""
    if kind == "tube":
        guess = ": the fields of a tube request (or of a perfmap query)"
    raise reject(f"the JSON holds no alignment request (no 'components'); it holds {', '.join(map(repr, keys)) or 'an empty object'}"
                 f"{guess}")


def refuse_other_text(text: str) -> None:
    """A 422 on ``file`` when a .pcf upload holds no PCF keyword at all, saying what it holds instead."""
    if PCF_KEYWORDS.search(text) or not text.strip():  # an empty file: the PCF reader says so
        return
    raise reject("no PCF components with END-POINT/CENTRE-POINT/BRANCH1-POINT lines were found: this is no PCF "
                 f"(not one PCF keyword in it), it holds {describe(text)}")


def describe(text: str) -> str:
    """A few words on what ``text`` looks like."""
    head = text.lstrip("\ufeff \t\r\n")[:4096]
    # comment lines of IDF (!), CSV and XYZ (#) say nothing of the format
    lines = [ln.strip() for ln in head.splitlines() if ln.strip() and ln.strip()[0] not in "!#"]
    if not lines:
        return "no text (an empty file)"
    first = lines[0]
    if first.upper().startswith("ISO-10303-21"):
        schema = re.search(r"FILE_SCHEMA\s*\(\s*\(\s*'([^']+)'", head)
        return f"a STEP model (ISO-10303-21{', schema ' + schema.group(1) if schema else ''}; IFC is a dedup input)"
    if first[0] in "{[":
        return "a JSON document (upload it as .json)"
    if first.startswith("<"):
        root = re.search(r"<([A-Za-z][\w:.-]*)[\s>]", re.sub(r"<\?.*?\?>|<!--.*?-->", "", head, flags=re.DOTALL))
        return f"an XML document (root <{root.group(1) if root else '?'}>)"
    if all(ln[0] in "012345" and (len(ln) == 1 or ln[1] == " ") for ln in lines[:20]):
        return "an LDraw model (lines of type 0-5: a rigidity input)"
    table = _table(lines)
    if table is None and re.match(r"^[A-Za-z][\w:]*\s*,", first) and any(";" in ln for ln in lines):
        return f"an EnergyPlus IDF (objects such as {first.split(',')[0]!r}: a polyhedra input)"
    return table or f"text beginning {lines[0][:60]!r}"


def _table(lines: list[str]) -> str | None:
    cells = [re.split(r"[,;\t ]+", ln) for ln in lines[:50]]
    numeric = [all(_NUMBER.match(c) for c in row if c) for row in cells]
    if numeric and not numeric[0] and all(numeric[1:]) and len(cells) > 1:
        return f"a table of {len(cells[0])} named column(s) ({', '.join(cells[0][:8])}) with numeric rows"
    if all(numeric):
        widths = {len([c for c in row if c]) for row in cells}
        if widths == {3}:
            return "a list of x y z points (a tube scan?)"
        return f"numeric rows of {', '.join(map(str, sorted(widths)))} value(s)"
    return None



