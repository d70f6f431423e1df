"""A file's length unit reconciled with the request's ``units``: every number a reader made becomes a number in
the request's unit, and ``source["units"]`` says how (file unit, request unit, factor, where the file unit came from).

The readers hand over their coordinates in one of two ways:

- in metres, because the format says what its unit is: EnergyPlus IDF and epJSON are always metres (the
  ``basis`` is ``"format"``), gbXML states ``lengthUnit`` (the reader converts to metres), IFC states its
  project units (``IfcUnitAssignment``; IfcOpenShell's kernel gives metres);
- as written, because the format states no unit (OBJ, STL) or the request says it (a JSON request's ``units``):
  they are in the request's unit, and only the plausibility check (:mod:`.plausibility`) can tell a room written
  in millimetres from one in metres.

``options.file_units`` overrides what the file says (a gbXML whose ``lengthUnit`` contradicts its numbers, an
OBJ exported in millimetres)."""

from __future__ import annotations

from typing import Any

import numpy as np

from plantsolve.schemas.common import Diagnostic
from plantsolve.solvers.length_units import METRES, unit_of_size

FORMATS = {"idf": "IDF", "epjson": "epJSON", "gbxml": "gbXML", "ifc": "IFC", "obj": "OBJ", "stl": "STL", "json": "JSON"}


def stated(file_unit: str, metres: float, basis: str, evidence: str, **names: Any) -> dict[str, Any]:
    """What a reader says of its coordinates: they are metres now, read from ``file_unit`` (``metres`` m each)."""
    return {"file_unit": file_unit, "file_unit_m": metres, "basis": basis, "evidence": evidence, **names}


# The basis of a unit a file's format implies where the file assigns none (an IFC project without a length unit:
# metres): an option naming another unit states what the file left open, it contradicts nothing.
NONE_ASSIGNED = "none assigned"


def symbol(metres: float) -> str:
    """The request unit of that size ('mm', 'ft', …), else the size in metres ('0.9144 m')."""
    return unit_of_size(metres) or f"{metres:g} m"


def reconcile(body: dict[str, Any], request_unit: str | None, file_units: str | None, fmt: str) -> dict[str, Any]:
    """``body`` with its coordinates (and declared measures) in ``request_unit`` and ``source["units"]`` saying so.
    ``request_unit`` None: the body's own ``units`` (a JSON request's), else the schema's default, metres."""
    if not isinstance(body.get("source") or {}, dict) or body.get("units", "m") not in METRES:
        return body  # the schema refuses it, naming the field
    source = dict(body.get("source") or {})
    said = source.get("units") if isinstance(source.get("units"), dict) else None
    in_metres = said is not None and "file_unit_m" in said  # a reader that converted to metres
    written = body.get("units")
    target = request_unit or (None if in_metres else written) or "m"
    if file_units is not None:
        # the body's numbers are the file's own, or metres made from the unit the file stated
        number_m = METRES[file_units] / (said["file_unit_m"] if in_metres else 1.0)
        file_unit, basis, factor = file_units, "options.file_units", METRES[file_units] / METRES[target]
        evidence = (f"overrides the file's {said['file_unit']} ({said['evidence']})" if in_metres else
                    f"{FORMATS.get(fmt, fmt)} states no unit; options.file_units says {file_units}")
    elif in_metres:
        number_m, file_unit, basis, evidence = 1.0, said["file_unit"], said["basis"], said["evidence"]
        factor = said["file_unit_m"] / METRES[target]  # file unit → request unit, the reader's step included
    elif written is not None and fmt == "json":
        number_m, file_unit, basis = METRES[written], written, "units"
        evidence = f"the JSON request's own units ({written!r})"
        factor = number_m / METRES[target]
    else:
        number_m, file_unit, basis, factor = METRES[target], target, "request", 1.0
        evidence = f"{FORMATS.get(fmt, fmt)} files state no unit: read in the request's"
    scale = number_m / METRES[target]  # what the body's numbers are multiplied by
    extra = {k: v for k, v in (said or {}).items() if k not in ("file_unit", "file_unit_m", "basis", "evidence")}
    source["units"] = {"file_unit": file_unit, "request_unit": target, "factor": factor, "basis": basis,
                       "evidence": evidence, **extra}
    out = {**body, "units": target, "source": source}
    if scale != 1.0:
        _scale(out, scale)
    if file_units is not None and in_metres and said["file_unit"] != file_units and said["basis"] != NONE_ASSIGNED:
        # the file states its unit: an option saying another is a contradiction, followed but never silent (with
        # the request in the option's unit nothing is converted, so units_converted would not say it)
        source["warnings"] = [*(source.get("warnings") or []), Diagnostic(code="file_unit_overridden", message=(
            f"options.file_units says {file_units}, but the {FORMATS.get(fmt, fmt)} file states {said['file_unit']} "
            f"({said['evidence']}): its lengths were read as {file_units}, × {number_m:.6g} against the file's own "
            "unit. Leave file_units out unless the file's statement is wrong."),
            details={"file_unit": said["file_unit"], "option": file_units, "basis": said["basis"],
                     "factor": number_m}).model_dump()]
    if factor != 1.0:
        source["warnings"] = [*(source.get("warnings") or []), Diagnostic(code="units_converted", message=(
            f"The {FORMATS.get(fmt, fmt)} file's lengths are in {file_unit} ({evidence}): converted to the request's "
            f"{target} (× {factor:.6g}; areas × {factor ** 2:.6g}, volumes × {factor ** 3:.6g})."),
            details={k: source["units"][k] for k in ("file_unit", "request_unit", "factor", "basis")}).model_dump()]
    return out


def _scale(body: dict[str, Any], k: float) -> None:
    """Every length of ``body`` times ``k`` (areas k², volumes k³), in place."""
    if body.get("vertices") is not None:
        body["vertices"] = _times(body["vertices"], k)
    faces = body.get("faces")
    if isinstance(faces, list):
        body["faces"] = [_scaled_face(f, k) for f in faces]
    mesh = body.get("mesh")
    if isinstance(mesh, dict) and mesh.get("vertices") is not None:
        body["mesh"] = {**mesh, "vertices": _times(mesh["vertices"], k)}
    declared = body["source"].get("declared")
    if isinstance(declared, dict):
        power = {"volume": 3, "floor_area": 2}
        body["source"]["declared"] = {
            zone: {q: v * k ** power[q] if q in power and isinstance(v, (int, float)) else v for q, v in claim.items()}
            if isinstance(claim, dict) else claim for zone, claim in declared.items()}


def _times(values: Any, k: float) -> Any:
    """Coordinates times ``k``: an array stays an array, JSON lists stay lists; anything else is left for the
    schema to refuse."""
    if isinstance(values, np.ndarray):
        return values * k
    try:
        return (np.asarray(values, dtype=float) * k).tolist()
    except (TypeError, ValueError):
        return values


def _scaled_face(face: Any, k: float) -> Any:
    if not isinstance(face, dict) or not isinstance(face.get("loops"), list):
        return face
    loops = [_times(loop, k) if isinstance(loop, list) and loop and isinstance(loop[0], (list, tuple)) else loop
             for loop in face["loops"]]
    return {**face, "loops": loops}
