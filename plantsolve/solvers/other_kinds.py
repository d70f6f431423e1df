"""Which kind a JSON document was made for: a request or result of another kind uploaded by mistake is refused
naming what it holds, instead of a list of 'extra fields not permitted'."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from pydantic import BaseModel

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.schemas.dedup import DedupRequest
from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.schemas.perfmap import PerfmapRequest
from plantsolve.schemas.polyhedra import PolyhedraRequest
from plantsolve.schemas.rigidity import RigidityRequest
from plantsolve.schemas.tube import TubeRequest
from plantsolve.solvers.base import reject

REQUESTS: Mapping[str, type[BaseModel]] = {
    "alignment": AlignmentRequest, "tube": TubeRequest, "perfmap": PerfmapRequest, "polyhedra": PolyhedraRequest,
    "flowmeter": FlowmeterRequest, "rigidity": RigidityRequest, "dedup": DedupRequest,
}
KEYS_NAMED = 4


def request_fields(kind: str) -> set[str]:
    """The top-level keys a request of ``kind`` may have (field names and aliases)."""
    fields = REQUESTS[kind].model_fields
    return set(fields) | {f.alias for f in fields.values() if f.alias}


def held_kind(body: Mapping[str, Any], own: str) -> str | None:
    """What ``body`` holds when it is another kind's request or result (a sentence), else None: a result names
    its ``kind``; a request is the kind whose request fields take most of the keys ``own``'s request does not
    know (at least one)."""
    kind = body.get("kind")
    if isinstance(kind, str) and kind in REQUESTS and kind != own:
        return f"a {kind} result (its 'kind' is {kind!r})"
    ours = request_fields(own)
    foreign = set(body) - ours
    if not foreign:
        return None
    scores = {k: len(foreign & request_fields(k)) for k in REQUESTS if k != own}
    best = max(scores, key=lambda k: (scores[k], -list(REQUESTS).index(k)))
    if not scores[best]:
        return None
    named = sorted(foreign & request_fields(best))[:KEYS_NAMED]
    return f"a {best} request (its keys {', '.join(map(repr, named))} are {best}'s request fields)"


def refuse_other_kind(body: Mapping[str, Any], own: str) -> None:
    """A 422 on ``file`` naming what the JSON holds when it was made for another kind."""
    held = held_kind(body, own)
    if held is not None:
        expected = ", ".join(sorted(request_fields(own) - {"source"}))
        raise reject(f"this JSON holds {held}, not a {own} request (whose fields are {expected}); send it to "
                     f"/v1/{held.split()[1]}/jobs" if "request" in held else
                     f"this JSON holds {held}, not a {own} request (whose fields are {expected})")
