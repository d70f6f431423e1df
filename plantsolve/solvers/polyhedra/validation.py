"""Semantic input checks (types, finiteness and lengths are in the schema): every one names the field."""

from __future__ import annotations

import numpy as np

from plantsolve.schemas.polyhedra import PolyhedraRequest
from plantsolve.solvers.base import FieldError, InputRejected
from plantsolve.solvers.polyhedra.file_units import METRES
from plantsolve.solvers.polyhedra.holes import holes_outside

MAX_ERRORS = 50
# physical bounds of the options, in metres: merging vertices 5 cm apart closes the gap of a thin wall, and a face
# half a metre out of its plane is no plane
OPTION_BOUNDS_M = {"merge_tolerance": 0.05, "planarity_tolerance": 0.5}


def check_input(request: PolyhedraRequest) -> None:
    """Unique face ids, vertex indices in range, at least three distinct points per loop, parents that
    exist and are enclosure faces, no zone listed twice on a face, at least one enclosure face."""
    errors: list[FieldError] = _option_errors(request)
    n_vertices = len(request.vertices)
    seen: dict[str, int] = {}
    for i, face in enumerate(request.faces):
        if face.id in seen:
            errors.append(FieldError(("faces", i, "id"), f"face id {face.id!r} repeats face {seen[face.id]}"))
        seen.setdefault(face.id, i)
        for j, loop in enumerate(face.loops):
            if loop and isinstance(loop[0], list):
                distinct = len({tuple(p) for p in loop})
            else:
                bad = [k for k, v in enumerate(loop) if v >= n_vertices]
                if bad:
                    errors.append(FieldError(("faces", i, "loops", j, bad[0]),
                                             f"vertex index {loop[bad[0]]} is out of range ({n_vertices} vertices)"))
                    continue
                distinct = len(set(loop))
            if distinct < 3:
                errors.append(FieldError(("faces", i, "loops", j), f"face {face.id!r}: a loop needs at least 3 "
                                         f"distinct points, this one has {distinct}"))
        if face.zones is not None and len(set(face.zones)) != len(face.zones):
            errors.append(FieldError(("faces", i, "zones"), f"face {face.id!r} names the same zone twice"))
        if len(errors) >= MAX_ERRORS:
            break
    by_id = {face.id: face for face in request.faces}
    for i, face in enumerate(request.faces):
        if face.parent is None:
            continue
        host = by_id.get(face.parent)
        if host is None:
            errors.append(FieldError(("faces", i, "parent"), f"subsurface {face.id!r}: no face {face.parent!r}"))
        elif host.parent is not None or host is face:
            errors.append(FieldError(("faces", i, "parent"), f"subsurface {face.id!r}: its parent {face.parent!r} "
                                     "is itself a subsurface" if host is not face else "a face cannot be its own parent"))
        elif face.zones is not None and not set(face.zones) <= set(host.zones or ["default"]):
            errors.append(FieldError(("faces", i, "zones"), f"subsurface {face.id!r}: zones {face.zones} are not "
                                     f"zones of its parent {face.parent!r}"))
        if len(errors) >= MAX_ERRORS:
            break
    if not errors:
        errors.extend(_hole_errors(request)[:MAX_ERRORS])
    if request.mesh is not None and len(errors) < MAX_ERRORS:
        errors.extend(_mesh_errors(request, seen)[:MAX_ERRORS - len(errors)])
    if not errors and request.mesh is None and all(face.parent is not None for face in request.faces):
        errors.append(FieldError(("faces",), "every face is a subsurface: no face bounds a zone" if request.faces else
                                 "no face: give faces or a mesh"))
    errors.extend(_multiplier_errors(request)[:max(0, MAX_ERRORS - len(errors))])
    if errors:
        raise InputRejected(errors[:MAX_ERRORS])


def _multiplier_errors(request: PolyhedraRequest) -> list[FieldError]:
    """A multiplier, or a zone left out of the total floor area, for a zone no face bounds (a misspelt name would
    leave the zone counted once, or counted)."""
    zones = {zone for face in request.faces for zone in (face.zones or ["default"]) if face.parent is None}
    if request.mesh is not None:
        zones.add(request.mesh.zone)
    listed = ', '.join(sorted(zones)[:10])
    return [FieldError(("zone_multipliers", name), f"no face bounds a zone {name!r} (zones: {listed})")
            for name in request.zone_multipliers if name not in zones] + \
        [FieldError(("zones_outside_total_floor_area", k), f"no face bounds a zone {name!r} (zones: {listed})")
         for k, name in enumerate(request.zones_outside_total_floor_area) if name not in zones] + \
        _subsurface_multiplier_errors(request)


def _subsurface_multiplier_errors(request: PolyhedraRequest) -> list[FieldError]:
    """A multiplier for a face that is not a subsurface (an enclosure face is not copied on a host)."""
    if not request.subsurface_multipliers:
        return []
    subsurfaces = {face.id for face in request.faces if face.parent is not None}
    return [FieldError(("subsurface_multipliers", name), f"{name!r} is not a subsurface (a face with a parent)")
            for name in request.subsurface_multipliers if name not in subsurfaces]


def _hole_errors(request: PolyhedraRequest) -> list[FieldError]:
    """Holes with a vertex outside their face's outer loop (their area would be subtracted from the face)."""
    errors = []
    tolerance = max(1e-4 / METRES[request.units], request.options.merge_tolerance)  # 0.1 mm: EnergyPlus' planarity
    points = np.asarray(request.vertices, dtype=float).reshape(-1, 3) if len(request.vertices) else np.zeros((0, 3))
    for i, face in enumerate(request.faces):
        if len(face.loops) < 2:
            continue
        loops = [np.asarray(loop, dtype=float) if loop and isinstance(loop[0], list) else points[list(loop)]
                 for loop in face.loops]
        for k, v in holes_outside(loops, tolerance):
            errors.append(FieldError(("faces", i, "loops", k, v), f"face {face.id!r}: hole {k} has vertex "
                                     f"{loops[k][v].tolist()} outside the face's outer loop (loops[0]); a hole is "
                                     "subtracted from the face's area, so it must lie within it — another face's "
                                     "loop, or the loops in the wrong order?"))
            if len(errors) >= MAX_ERRORS:
                return errors
    return errors


def _mesh_errors(request: PolyhedraRequest, face_ids: dict[str, int]) -> list[FieldError]:
    """Triangle indices in range and three distinct per triangle (checked on the arrays); no face id that is
    also the name of a triangle."""
    mesh = request.mesh
    tri = mesh.triangles
    errors: list[FieldError] = []
    out = np.flatnonzero((tri >= len(mesh.vertices)).any(axis=1))
    for k in out[:MAX_ERRORS]:
        j = int(np.argmax(tri[k] >= len(mesh.vertices)))
        errors.append(FieldError(("mesh", "triangles", int(k), j), f"vertex index {int(tri[k, j])} is out of range "
                                 f"({len(mesh.vertices)} vertices)"))
    repeated = np.flatnonzero((tri[:, 0] == tri[:, 1]) | (tri[:, 1] == tri[:, 2]) | (tri[:, 0] == tri[:, 2]))
    for k in repeated[:MAX_ERRORS]:
        errors.append(FieldError(("mesh", "triangles", int(k)), f"triangle {mesh.id_prefix}{int(k) + 1}: a loop "
                                 "needs at least 3 distinct points"))
    prefix = mesh.id_prefix
    for face_id, i in face_ids.items():
        number = face_id[len(prefix):]
        if face_id.startswith(prefix) and number.isdigit() and not number.startswith("0") and \
                1 <= int(number) <= len(tri):
            errors.append(FieldError(("faces", i, "id"), f"face id {face_id!r} is the name of the mesh's triangle "
                                     f"{number} (mesh.id_prefix {prefix!r})"))
    return errors


def _option_errors(request: PolyhedraRequest) -> list[FieldError]:
    """The options beyond their physical bounds, in the request's units (the schema's bounds are unit-free)."""
    errors = []
    for name, bound_m in OPTION_BOUNDS_M.items():
        value = getattr(request.options, name)
        bound = bound_m / METRES[request.units]
        if value > bound:
            in_metres = f" ({bound_m:g} m)" if request.units != "m" else ""
            errors.append(FieldError(("options", name), f"{name} {value:g} {request.units} is more than "
                                     f"{bound:g} {request.units}{in_metres}, beyond any building's: a value "
                                     "meant in another unit?"))
    return errors + _unused_file_units(request)


def _unused_file_units(request: PolyhedraRequest) -> list[FieldError]:
    """``options.file_units`` says in what unit an uploaded file's numbers are; a JSON body's vertices are in its
    ``units``, and the option would change nothing: vertices meant in feet would be measured in metres without a
    word."""
    file_units = request.options.file_units
    said = (request.source or {}).get("units")
    if file_units is None or isinstance(said, dict) and said.get("basis") == "options.file_units":
        return []
    return [FieldError(("options", "file_units"), f"file_units ({file_units!r}) is the unit of an uploaded file's "
                       f"numbers; this request's vertices are in its 'units' ({request.units!r}): give \"units\": "
                       f"\"{file_units}\" if they are in {file_units}, or leave file_units out")]
