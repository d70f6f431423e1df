"""Which kind a JSON document was made for: a request or result of another kind uploaded by mistake is refused
naming what it holds, instead of a list of 'extra fields not permitted'."""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

from pydantic import BaseModel

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.schemas.dedup import DedupRequest
from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.schemas.perfmap import PerfmapBetaQueryRequest, PerfmapQueryRequest, PerfmapRequest
from plantsolve.schemas.polyhedra import PolyhedraRequest
from plantsolve.schemas.rigidity import RigidityRequest
from plantsolve.schemas.tube import TubeRequest
from plantsolve.solvers.base import binary_stl, reject

REQUESTS: Mapping[str, type[BaseModel]] = {
    "alignment": AlignmentRequest, "tube": TubeRequest, "perfmap": PerfmapRequest, "polyhedra": PolyhedraRequest,
    "flowmeter": FlowmeterRequest, "rigidity": RigidityRequest, "dedup": DedupRequest,
}
# bodies of the questions a finished job answers, by kind: its path under /v1/<kind>/jobs/<job id>/
QUESTIONS: Mapping[str, Mapping[str, type[BaseModel]]] = {
    "perfmap": {"query": PerfmapQueryRequest, "beta": PerfmapBetaQueryRequest},
}
QUESTION_KEYS = {"points", "flow", "pressure", "speed", "beta", "setting"}
KEYS_NAMED = 4
SHARED_FIELDS = {"units", "options", "source"}  # fields many kinds' requests have: they tell no kind apart


def request_fields(kind: str) -> set[str]:
    """The top-level keys a request of ``kind`` may have (field names and aliases)."""
    fields = REQUESTS[kind].model_fields
    return set(fields) | {f.alias for f in fields.values() if f.alias}


def held_kind(body: Mapping[str, Any], own: str) -> str | None:
    """What ``body`` holds when it is another kind's request or result (a sentence), else None: a result names
    its ``kind``; a request is the kind whose request fields take most of the keys ``own``'s request does not
    know (at least one, and more than the body holds of ``own``'s own fields)."""
    kind = body.get("kind")
    if isinstance(kind, str) and kind in REQUESTS and kind != own:
        return f"{_a(kind)} result (its 'kind' is {kind!r})"
    if kind == own and "report" in body:
        return f"{_a(own)} result (its 'kind' is {own!r} and it has a 'report'), not a request"
    question = _question(body)
    if question is not None:
        return question
    ours = request_fields(own)
    foreign = set(body) - ours
    if not foreign:
        return None
    scores = {k: len(foreign & request_fields(k)) for k in REQUESTS if k != own}
    best = max(scores, key=lambda k: (scores[k], -list(REQUESTS).index(k)))
    # a request of our kind with a stray key is ours: it must hold fewer of our own fields than of the other's
    own_held = len((set(body) & ours) - SHARED_FIELDS)
    if not scores[best] or own_held >= scores[best]:
        return None
    named = sorted(foreign & request_fields(best))[:KEYS_NAMED]
    return f"{_a(best)} request (its keys {', '.join(map(repr, named))} are {best}'s request fields)"


def _question(body: Mapping[str, Any]) -> str | None:
    """What ``body`` asks when it is the question a finished job answers (duty points for a map), not a request.
    Only a body shaped like one is validated (a list of points whose first is an object, or one point): a request's
    million points are not checked one by one against another schema."""
    points = body.get("points")
    if not (set(body) <= QUESTION_KEYS and (points is None or (isinstance(points, list) and points
                                                                and isinstance(points[0], dict)))):
        return None
    for kind, questions in QUESTIONS.items():
        for path, model in questions.items():
            try:
                model.model_validate(body)
            except ValueError:
                continue
            return (f"{_a(kind)} {path} question (what a finished {kind} job answers: POST it to "
                    f"/v1/{kind}/jobs/<job id>/{path})")
    return None


def _a(word: str) -> str:
    return f"{'an' if word[0] in 'aeiou' else 'a'} {word}"


def refuse_other_kind(body: Mapping[str, Any], own: str) -> None:
    """A 422 on ``file`` naming what the JSON holds when it was made for another kind."""
    held = held_kind(body, own)
    if held is not None:
        expected = ", ".join(sorted(request_fields(own) - {"source"}))
        kind = held.split()[1]
        where = f"; send it to /v1/{kind}/jobs" if held.split()[2] == "request" else ""
        raise reject(f"this JSON holds {held}, not a {own} request (whose fields are {expected}){where}")


_STEP_SCHEMA = re.compile(rb"FILE_SCHEMA\s*\(\s*\(\s*'([A-Za-z0-9_ ]+)", re.IGNORECASE)
_IDF_OBJECT = re.compile(
    rb"^\s*(version|zone|buildingsurface:detailed|building|globalgeometryrules|simulationcontrol)\s*,",
    re.IGNORECASE | re.MULTILINE)
_CAD_SCHEMAS = {"AUTOMOTIVE_DESIGN": "AP214", "CONFIG_CONTROL_DESIGN": "AP203",
                "AP242_MANAGED_MODEL_BASED_3D_ENGINEERING": "AP242"}


def file_holds(head: bytes) -> str | None:
    """What the start of a file shows it to be (a phrase: 'an EnergyPlus IDF'), when it is a format users mix up
    between the kinds; None when nothing is recognised."""
    text = head.lstrip(b"\xef\xbb\xbf \r\n\t")
    low = text[:4096].lower()
    if text.startswith(b"ISO-10303-21;"):
        found = _STEP_SCHEMA.search(text[:65536])
        schema = found.group(1).decode().strip().upper() if found else ""
        if schema.startswith("IFC"):
            return f"an IFC model ({schema})"
        return f"a STEP CAD model ({_CAD_SCHEMAS.get(schema, schema or 'no FILE_SCHEMA')})"
    if text.startswith(b"PK\x03\x04"):
        return "a zip archive (an .ifczip, or an Excel workbook?)"
    if text.startswith(b"<"):
        return "a gbXML building model" if b"<gbxml" in low else "an XML document"
    if text[:1] in (b"{", b"["):
        return "a JSON document"
    if low.startswith(b"solid") and b"facet" in low:
        return "an ASCII STL mesh"
    if low.startswith(b"ply"):
        return "a PLY point cloud or mesh"
    if binary_stl(head):
        return "a binary STL mesh"
    if _IDF_OBJECT.search(text[:65536]):
        return "an EnergyPlus IDF"
    lines = [line.split() for line in text[:65536].splitlines() if line.strip() and not line.startswith(b"#")]
    keys = {line[0] for line in lines}
    if b"v" in keys:
        return "a Wavefront OBJ mesh" if b"f" in keys else "a Wavefront OBJ of vertices only (a point cloud)"
    if any(k.startswith((b"PIPELINE-REFERENCE", b"UNITS-BORE", b"PIPE")) for k in keys):
        return "a piping component file (PCF)"
    if _ldraw(lines[:20]):
        return "an LDraw model (a rigidity input)"
    rows = [line for line in text[:65536].splitlines() if line.strip() and not line.startswith(b"#")][:3]
    for sep in (b",", b";", b"\t"):
        if len(rows) >= 2 and sep in rows[0] and all(_numbers(row.split(sep)) for row in rows[1:]):
            return "a CSV table with a header row" if not _numbers(rows[0].split(sep)) else "a CSV table of numbers"
    return None


def _ldraw(lines: list[list[bytes]]) -> bool:
    """LDraw's lines: each a line type 0-5 first, and a part placed (type 1: colour, position, matrix, a file name)
    or a meta-command (type 0: ``FILE``, ``Name:``, ``!LDRAW_ORG``...) among them. Numbers alone (an x y z list
    whose x is 1) are not."""
    if not lines or any(line[0] not in (b"0", b"1", b"2", b"3", b"4", b"5") for line in lines):
        return False
    return any((line[0] == b"1" and len(line) >= 15 and line[-1].lower().endswith((b".dat", b".ldr", b".mpd")))
               or (line[0] == b"0" and len(line) > 1 and line[1].upper() in (b"FILE", b"NAME:", b"!LDRAW_ORG",
                                                                              b"AUTHOR:", b"NOFILE"))
               for line in lines)


def _numbers(cells: list[bytes]) -> bool:
    """Two or more cells, each a number."""
    try:
        return len(cells) >= 2 and all(float(c) == float(c) for c in cells)
    except ValueError:
        return False
