"""What an upload holds when it is no alignment input: a file of another kind, said by name.

A PCF is recognised by its keywords, an alignment JSON by its ``components``; anything else is
refused at intake saying what it looks like (a STEP/IFC model, an LDraw model, an EnergyPlus IDF,
an XML document, a JSON document, a table of named columns, a list of x y z points), so the user
sees the wrong file at once rather than an empty result or a failure later.
"""

from __future__ import annotations

import re

from plantsolve.solvers.base import reject
from plantsolve.solvers.other_kinds import held_kind

PCF_KEYWORDS = re.compile(r"^\s*(END-POINT|CENTRE-POINT|BRANCH1-POINT|CO-ORDS|PIPELINE-REFERENCE|ISOGEN-FILES|UNITS-BORE|"
                          r"UNITS-CO-ORDS|PIPE|ELBOW|TEE|FLANGE|VALVE)\b", re.MULTILINE)
# an indented point line in any case ('    end-point 0 0 0 100'): the PCF reader takes keywords in any case, so a file
# written in lower case is a PCF, not a text to name
POINT_LINE_ANY_CASE = re.compile(r"^[ \t]+(END-POINT|CENTRE-POINT|BRANCH1-POINT)[ \t]+[-+.\d]",
                                 re.MULTILINE | re.IGNORECASE)
_NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")


def refuse_other_json(body: dict) -> None:
    """A 422 on ``file`` when a JSON upload holds no ``components`` (no alignment request), naming its fields
    and the kind whose request they are."""
    if "components" in body:
        return
    keys = [str(k) for k in body][:12]
    held = held_kind(body, "alignment")
    raise reject(f"the JSON holds no alignment request (no 'components'); it holds {', '.join(map(repr, keys)) or 'an empty object'}"
                 f"{f': it is {held}' if held else ''}")


def refuse_other_text(text: str) -> None:
    """A 422 on ``file`` when a .pcf upload holds no PCF keyword at all, saying what it holds instead."""
    if PCF_KEYWORDS.search(text) or POINT_LINE_ANY_CASE.search(text) or not text.strip():  # empty: the reader says so
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



