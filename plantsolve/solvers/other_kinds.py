"""Which kind a JSON request was written for, told by its top-level fields: a JSON upload of another kind's request
is refused at submission naming that kind, instead of failing field by field against the wrong schema."""

from __future__ import annotations

from typing import Any

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.schemas.dedup import DedupRequest
from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.schemas.perfmap import PerfmapRequest
from plantsolve.schemas.polyhedra import PolyhedraRequest
from plantsolve.schemas.rigidity import RigidityRequest
from plantsolve.schemas.tube import TubeRequest
from plantsolve.solvers.base import reject

REQUESTS = {"alignment": AlignmentRequest, "tube": TubeRequest, "perfmap": PerfmapRequest,
            "polyhedra": PolyhedraRequest, "flowmeter": FlowmeterRequest, "rigidity": RigidityRequest,
            "dedup": DedupRequest}
# fields several kinds share: they say nothing about which kind a request is for
_SHARED = {"units", "options", "source", "upload_warnings"}


def _own(kind: str) -> set[str]:
    return set(REQUESTS[kind].model_fields) - _SHARED


def refuse_other_kind(body: Any, kind: str) -> None:
    """A 422 on ``file`` when ``body`` holds none of ``kind``'s own fields and some of another kind's, naming that
    kind and the fields that tell it."""
    if not isinstance(body, dict) or set(body) & _own(kind):
        return
    found = max(((other, sorted(set(body) & _own(other))) for other in REQUESTS if other != kind),
                key=lambda hit: len(hit[1]))
    if found[1]:
        other, fields = found
        raise reject(f"this is a {other} request (it has {', '.join(repr(f) for f in fields)}), not a {kind} one: "
                     f"submit it to POST /v1/{other}/jobs; a {kind} request has "
                     f"{', '.join(repr(f) for f in sorted(_own(kind)))}")
