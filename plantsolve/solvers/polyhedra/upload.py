"""Files the zones come in: EnergyPlus IDF or epJSON, gbXML, IFC spaces, Wavefront OBJ, STL, or a JSON request.

Item by item: an object that cannot be read (a vertex that is not a number, a window whose host
surface does not exist, a face with fewer than three vertices) is skipped and listed in the
result's report with its line and reason; the file is refused (422 naming the line) only when
nothing usable remains.

IDF (as EnergyPlus and OpenStudio write it): objects end with ``;``, fields are separated by
``,`` and may be spread over any number of lines; ``!`` starts a comment (``!-`` field notes such
as ``!- X,Y,Z Vertex 1 {m}`` included); object names are case-insensitive. Read: ``Zone`` (origin
and relative north for relative coordinates), ``GlobalGeometryRules`` (vertex entry direction,
coordinate system), ``BuildingSurface:Detailed``, ``Wall:Detailed``, ``RoofCeiling:Detailed``,
``Floor:Detailed`` (with or without the Space Name field of EnergyPlus 9.6+) and
``FenestrationSurface:Detailed`` (windows and doors, as subsurfaces of their host; with or
without the Shading Control Name field of EnergyPlus before 9.0). Interzone surfaces are written
once per zone; the solver pairs coincident faces of different zones as adjacency. The simple-geometry
rectangles (``Wall:Exterior`` … ``Floor:Interzone``, ``Window`` … ``GlazedDoor:Interzone``) are built as
EnergyPlus builds them (``idf_rectangles``), in zone coordinates unless GlobalGeometryRules' Rectangular
Surface Coordinate System says World.

OBJ: ``v`` vertices, ``f`` faces (``v``, ``v/vt``, ``v//vn``, ``v/vt/vn``; negative indices count
back), ``g`` (or else ``o``) names the zone of the faces that follow; ``\\`` continues a line;
everything else (``vn``, ``vt``, ``usemtl``, ``mtllib``, ``s``, ``l``) is ignored. SketchUp and
Revit write unwelded, triangulated faces: coincident vertices are merged by the solver.

epJSON (``.epJSON``): the same objects in EnergyPlus' JSON form (``epjson``), read by the IDF reader.

gbXML (``.xml``, ``.gbxml``): ``Campus/Surface`` PolyLoops with their AdjacentSpaceIds (``gbxml``).

IFC: ``IfcSpace`` bodies tessellated by IfcOpenShell (``ifc_spaces``), with their base quantities.

STL (binary, read with numpy; ASCII, read with trimesh): one zone, its triangles as the request's ``mesh`` (faces
``t1``, ``t2``, … in file order).
"""

from __future__ import annotations

import io
import math
import re
import struct
from dataclasses import replace

import numpy as np

from plantsolve.schemas.common import Diagnostic
from plantsolve.schemas.polyhedra import MAX_COORDINATE, PolyhedraRequest
from plantsolve.solvers.base import InputRejected, StoredInput, decode_text, json_object, reject, utf16_without_mark
from plantsolve.solvers.other_kinds import file_holds, refuse_other_kind
from plantsolve.solvers.polyhedra.epjson import FIELDS as EPJSON_TYPES, epjson_objects
from plantsolve.solvers.polyhedra.file_units import reconcile, stated
from plantsolve.solvers.polyhedra.floor_area_parts import zones_outside_total_floor_area
from plantsolve.solvers.polyhedra.gbxml import parse_gbxml
from plantsolve.solvers.polyhedra.idf_notes import followed, notes_in_other_units, tables_answered, \
    tables_in_inch_pound
from plantsolve.solvers.polyhedra.idf_rectangles import SIMPLE_SUBSURFACES, SIMPLE_SURFACES, base_surface, subsurface
from plantsolve.solvers.polyhedra.ifc_spaces import parse_ifc
from plantsolve.solvers.polyhedra.interzone import twins_apart
from plantsolve.solvers.polyhedra.obj_units import header_unit
from plantsolve.solvers.polyhedra.space_claims import space_claims
from plantsolve.solvers.polyhedra.stl_binary import HEADER_BYTES, binary_stl_arrays, is_binary_stl
from plantsolve.solvers.polyhedra.subsurface_multipliers import simple_multiplier_index, subsurface_multiplier
from plantsolve.solvers.polyhedra.zone_multipliers import zone_list_strays, zone_multipliers
from plantsolve.solvers.decimal_comma import is_decimal_comma
from plantsolve.solvers.skipped_input import ends_mid_line, refuse_noise_stl, truncated_file
from plantsolve.solvers.upload_form import FormRules, merged, read_form, validated_request

UPLOAD_EXTENSIONS = (".idf", ".epjson", ".xml", ".gbxml", ".ifc", ".obj", ".stl", ".json")
LOOP_KINDS = ("indices", "points")  # the tags of the Loop union (schemas.polyhedra)
MAX_SKIPPED_LISTED = 200
# an ASCII STL's lines of numbers: its corners and its facets' normals
STL_NUMBERS = re.compile(rb"^[ \t]*(?:vertex|facet[ \t]+normal)[ \t][^\n]*", re.IGNORECASE | re.MULTILINE)
# ... one that writes a decimal comma (a digit, a comma, a digit within a number)
STL_COMMA_LINE = re.compile(rb"^[ \t]*(?:vertex|facet[ \t]+normal)[ \t][^\n]*?\d,\d[^\n]*", re.IGNORECASE | re.MULTILINE)

SURFACE_CLASSES = {
    # class -> (index of the zone name, index of the surface type or None) before any Space Name field
    "buildingsurface:detailed": (3, 1),
    "wall:detailed": (2, None),
    "roofceiling:detailed": (2, None),
    "floor:detailed": (2, None),
}
BOUNDARY_CONDITIONS = {
    "outdoors", "surface", "zone", "ground", "adiabatic", "foundation", "othersidecoefficients",
    "othersideconditionsmodel", "groundfcfactormethod", "groundslabpreprocessoraverage",
    "groundslabpreprocessorcore", "groundslabpreprocessorperimeter", "groundbasementpreprocessoraveragewall",
    "groundbasementpreprocessoraveragefloor", "groundbasementpreprocessorupperwall",
    "groundbasementpreprocessorlowerwall", "kivafoundation",
}


IdfObject = tuple[str, list[str], list[int], int]  # (class, fields, line of each field, line of the object)


def idf_objects(text: str) -> tuple[list[IdfObject], IdfObject | None]:
    """(class, fields, line of each field, line of the object) of every object, comments removed; and the
    object the text ends inside (fields after the last ``;``: the file was cut), or None."""
    objects = []
    fields: list[str] = []
    lines: list[int] = []
    current: list[str] = []
    current_line = 0
    for number, raw in enumerate(text.splitlines(), 1):
        line = raw.split("!", 1)[0]
        for char in line:
            if char in ",;":
                if not current and not fields and char == ";" and not "".join(current).strip():
                    continue
                fields.append("".join(current).strip())
                lines.append(current_line or number)
                current, current_line = [], 0
                if char == ";":
                    if fields and fields[0]:
                        objects.append((fields[0].lower(), fields[1:], lines[1:], lines[0]))
                    fields, lines = [], []
            else:
                if not current_line and not char.isspace():
                    current_line = number
                current.append(char)
    if "".join(current).strip():
        fields.append("".join(current).strip())
        lines.append(current_line)
    unterminated = None
    if fields and fields[0]:
        unterminated = (fields[0].lower(), fields[1:], lines[1:], lines[0])
    return objects, unterminated


def _number(value: str) -> float:
    x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"{value!r} is not finite")
    return x


def _coordinate(value: str) -> float:
    """A length of the file: beyond the schema's bound it is a writer's garbage, and the object holding it is skipped
    naming its line (the schema's refusal would name a face index the file does not have)."""
    x = _number(value)
    if abs(x) > MAX_COORDINATE:
        raise ValueError(f"{value!r} is beyond ±{MAX_COORDINATE:g}")
    return x


def _vertices(fields: list[str], lines: list[int], n_index: int) -> list[list[float]]:
    """The vertex list after the Number of Vertices field at ``n_index``."""
    if n_index >= len(fields):
        # an object cut short (``Wall:Detailed, W1, C, Z1, Outdoors;``) is skipped with this reason
        raise ValueError(f"{len(fields)} fields: the object ends before its 'Number of Vertices' field")
    coords = [f for f in fields[n_index + 1:]]
    while coords and coords[-1] == "":
        coords.pop()
    if len(coords) % 3:
        raise ValueError(f"{len(coords)} coordinates after 'Number of Vertices'{_where(lines[n_index])}: not a "
                         "multiple of 3")
    count = fields[n_index].strip().lower()
    if count not in ("", "autocalculate"):
        try:
            n = int(float(count))
        except ValueError:
            raise ValueError(f"'Number of Vertices' is {fields[n_index]!r}") from None
        if n != len(coords) // 3:
            raise ValueError(f"'Number of Vertices' says {n} but {len(coords) // 3} vertices follow")
    points = []
    for k in range(0, len(coords), 3):
        try:
            points.append([_coordinate(c) for c in coords[k:k + 3]])
        except ValueError as e:
            raise ValueError(f"vertex {k // 3 + 1}{_where(lines[n_index + 1 + k])}: {e}") from None
    if len({tuple(p) for p in points}) < 3:
        raise ValueError(f"{len({tuple(p) for p in points})} distinct vertices; a surface needs at least 3")
    return points


def _surface_layout(cls: str, fields: list[str]) -> tuple[int, int]:
    """(index of the boundary condition, index of Number of Vertices), with or without Space Name."""
    zone_index, _ = SURFACE_CLASSES[cls]
    for extra in (0, 1):
        bc = zone_index + 1 + extra
        if bc < len(fields) and fields[bc].strip().lower() in BOUNDARY_CONDITIONS:
            return bc, bc + 5
    for extra in (0, 1):  # an unknown boundary condition: the layout whose vertex fields come in threes
        n_index = zone_index + 6 + extra
        if n_index < len(fields) and (len(fields) - n_index - 1) % 3 == 0:
            return zone_index + 1 + extra, n_index
    return zone_index + 1, zone_index + 6


def _space_name(cls: str, fields: list[str]) -> str:
    """The Space Name a base surface gives ('' when blank, or when its layout has no such field: EnergyPlus before
    9.6)."""
    if cls in SURFACE_CLASSES:
        zone_index, _ = SURFACE_CLASSES[cls]
        bc, _ = _surface_layout(cls, fields)
        return fields[zone_index + 1].strip() if bc == zone_index + 2 else ""
    trimmed = [f for f in fields]
    while trimmed and not trimmed[-1].strip():
        trimmed.pop()
    has_object, _ = SIMPLE_SURFACES[cls]
    return trimmed[3].strip() if len(trimmed) == 11 + has_object else ""  # Name, Construction, Zone, Space, …


def _twin(cls: str, fields: list[str]) -> str:
    """The surface a ``*:Detailed`` base surface names as its other side (Outside Boundary Condition 'Surface'), or
    ''."""
    if cls not in SURFACE_CLASSES:
        return ""
    bc, _ = _surface_layout(cls, fields)
    if bc + 1 < len(fields) and fields[bc].strip().lower() == "surface":
        return fields[bc + 1].strip()
    return ""


def _is_floor(cls: str, fields: list[str]) -> bool:
    """A base surface EnergyPlus counts as floor (its Surface Type, or a Floor class)."""
    if cls == "buildingsurface:detailed":
        return len(fields) > 1 and fields[1].strip().lower() == "floor"
    return cls.startswith("floor:")


def _area(points: list[list[float]]) -> float:
    """Newell's area of a planar polygon."""
    loop = np.asarray(points, dtype=float)
    return float(np.linalg.norm(np.cross(loop, np.roll(loop, -1, axis=0)).sum(axis=0))) / 2


def _detailed_surface(cls: str, fields: list[str], lines: list[int]) -> tuple[str, list[list[float]]]:
    """The zone name and the vertices, as the file lists them, of a ``*:Detailed`` base surface."""
    zone_index, _ = SURFACE_CLASSES[cls]
    if len(fields) <= zone_index or not fields[zone_index]:
        raise ValueError("no zone name")
    _, n_index = _surface_layout(cls, fields)
    return fields[zone_index], _vertices(fields, lines, n_index)


def _fenestration_layout(fields: list[str]) -> int:
    for n_index in (8, 9):  # 9: the Shading Control Name field of EnergyPlus before 9.0
        if n_index >= len(fields):
            continue
        rest = [f for f in fields[n_index + 1:]]
        while rest and rest[-1] == "":
            rest.pop()
        count = fields[n_index].strip().lower()
        if len(rest) % 3:
            continue
        if count in ("", "autocalculate"):
            return n_index
        try:
            if int(float(count)) == len(rest) // 3:
                return n_index
        except ValueError:
            continue
    return 8


def parse_idf(text: str) -> dict:
    objects, unterminated = idf_objects(text)
    if not objects and unterminated is None:
        raise reject("no IDF object here (objects are 'Class, field, ...;')")
    skipped: list[dict] = []
    warnings: list[dict] = []
    if unterminated is not None:
        # the file ends inside this object: what it would have held is unknown (a vertex list cut after a
        # whole vertex still reads), so it is not read at all, and the report says so
        cls, fields, _, line = unterminated
        label = f"{cls} {fields[0]!r}" if fields and fields[0] else cls
        skipped.append({"line": line, "object": label,
                        "reason": "the file ends inside this object (no closing ';'): not read"})
        warnings.append(truncated_file(line, f"{label} has no closing ';' (the file was cut?); it was not read.",
                                       object=label).model_dump())
    elif ends_mid_line(text) and objects and not ends_with_semicolon(text):
        # cut after a ';', in a comment or blanks: the objects after it are gone (a hand edit that ends on the
        # last object's ';' without a line ending loses nothing, and is not a cut file)
        last = len(text.splitlines())
        warnings.append(truncated_file(last, f"its last line has no line ending (the file was cut?): every object up "
                                       f"to the last ';' was read, whatever the file held after line {last} is "
                                       "missing.").model_dump())
    warnings.extend(w.model_dump() for w in notes_in_other_units(text))
    warnings.extend(w.model_dump() for w in tables_in_inch_pound(objects))
    return surfaces_from_objects(objects, skipped, warnings, "idf")


def ends_with_semicolon(text: str) -> bool:
    """The text ends on an object's ';' (blanks after it aside), not inside a comment after it."""
    last = text.rstrip(" \t\x00\x1a").splitlines()[-1]
    return "!" not in last and last.endswith(";")


def _where(line: int | None) -> str:
    return f" (line {line})" if line else ""


# GlobalGeometryRules' choice fields (after the Starting Vertex Position, which changes no polygon) and EnergyPlus'
# keys: a word outside them ('Clockwize', 'Relativ') read as the default would reverse every face or move every zone
_GEOMETRY_RULE_KEYS = (("Vertex Entry Direction", ("counterclockwise", "clockwise")),
                       ("Coordinate System", ("relative", "world", "absolute")),
                       ("Daylighting Reference Point Coordinate System", ("relative", "world", "absolute")),
                       ("Rectangular Surface Coordinate System", ("relative", "world", "absolute")))


def _check_geometry_rules(fields: list[str], lines: list[int], line: int) -> None:
    """Refuses (422 naming the field and its line) a GlobalGeometryRules field that is none of EnergyPlus' keys, as
    EnergyPlus does; a blank field keeps its default."""
    for index, (name, keys) in enumerate(_GEOMETRY_RULE_KEYS, start=1):
        value = fields[index].strip() if index < len(fields) else ""
        if value and value.lower() not in keys:
            at = lines[index] if index < len(lines) and lines[index] else line
            raise reject(f"GlobalGeometryRules{_where(at)}: {name} is {value!r}, none of EnergyPlus' "
                         f"{', '.join(k.title() for k in keys)}", ("file", "line", at) if at else
                         ("file", "GlobalGeometryRules", name))


def surfaces_from_objects(objects: list[IdfObject], skipped: list[dict], warnings: list[dict], fmt: str) -> dict:
    """The request body of EnergyPlus' objects (from an IDF or an epJSON file, fields in IDD order)."""
    clockwise, relative, rect_relative = False, False, True
    zones: dict[str, tuple[float, float, float, float]] = {}
    declared: dict[str, dict[str, float]] = {}
    zone_names: dict[str, str] = {}
    zone_line: dict[str, int] = {}
    unreadable_origin: dict[str, str] = {}  # zones (lower case) whose origin or north is not a number → why
    rules_line: int | None = None
    for cls, fields, lines, line in objects:
        if cls == "globalgeometryrules":
            if rules_line is not None:
                raise reject(f"a second GlobalGeometryRules{_where(line)} after the one{_where(rules_line)}: "
                             "EnergyPlus allows one, and which vertex order and coordinate system is meant is not "
                             "known; keep one", ("file", "line", line) if line else ("file", "GlobalGeometryRules"))
            rules_line = line or 0
            _check_geometry_rules(fields, lines, line)
            if len(fields) > 1 and fields[1].strip().lower() in ("clockwise",):
                clockwise = True
            if len(fields) > 2 and fields[2].strip().lower() == "relative":
                relative = True
            # the simple-geometry rectangles have their own field, Relative unless it says World or Absolute (one choice)
            if len(fields) > 4 and fields[4].strip().lower() in ("world", "absolute"):
                rect_relative = False
        elif cls == "zone" and fields and fields[0]:
            if fields[0].lower() in zones:  # which origin, multiplier and floor-area rule is meant is unknown
                first = zone_line[fields[0].lower()]
                raise reject(f"Zone {fields[0]!r}{_where(line)} repeats the Zone {zone_names[fields[0].lower()]!r}"
                             f"{_where(first)}: EnergyPlus refuses two zones of one name (names are "
                             "case-insensitive)", ("file", "line", line) if line else ("file", "Zone", fields[0]))
            try:
                north, *origin = (fields + [""] * 4)[1:5]  # an angle, then lengths
                values = [_number(north) if north.strip() else 0.0] + [_coordinate(f) if f.strip() else 0.0
                                                                        for f in origin]
            except ValueError as e:
                # used only where a surface is placed relative to this zone: then it is refused (_placed_in)
                unreadable_origin[fields[0].lower()] = f"origin or north: {e}"
                values = [0.0] * 4
            zones[fields[0].lower()] = tuple(values)
            zone_names[fields[0].lower()] = fields[0]
            zone_line[fields[0].lower()] = line
            # Volume and Floor Area (fields 9 and 10) when the file gives numbers, not autocalculate
            claim = {}
            for key, index in (("volume", 8), ("floor_area", 9)):
                try:
                    value = _number(fields[index]) if index < len(fields) else 0.0
                except ValueError:
                    continue
                if value > 0:
                    claim[key] = value
            if claim:
                declared[fields[0]] = claim
    faces: list[dict] = []
    face_line: dict[str, int] = {}
    surface_zone: dict[str, str] = {}
    world_zones: set[str] = set()  # zones with surfaces placed in world coordinates: their origin is not used
    undefined: dict[str, tuple[str, int]] = {}  # zones of relative surfaces without a Zone object: (name, first line)
    # zones with surfaces in no Space (EnergyPlus' '<zone>-Remainder' space) → the floor area of those surfaces
    remainder_floor: dict[str, float] = {}
    partners: dict[str, tuple[str, int]] = {}  # interzone surface (lower case) → (the twin it names, its line)
    windows = []
    for cls, fields, lines, line in objects:
        if cls in SURFACE_CLASSES or cls in SIMPLE_SURFACES:
            name = fields[0] if fields else ""
            detailed = cls in SURFACE_CLASSES
            try:
                if not name:
                    raise ValueError("no name")
                zone, points = _detailed_surface(cls, fields, lines) if detailed else base_surface(cls, fields)
                zone_key = zone.lower()
                # the rectangles have their own coordinate-system field (rect_relative)
                if (relative if detailed else rect_relative) and zone_key in zones:
                    _refuse_unreadable_origin(zone_key, unreadable_origin, zone_names, zone_line, line)
                    points = _placed(_to_world(points, zones[zone_key]), zone_names[zone_key], zone_line[zone_key])
                else:
                    world_zones.add(zone_key)
                    if relative if detailed else rect_relative:  # relative to a zone whose origin no object gives
                        undefined.setdefault(zone_key, (zone, line))
                if name.lower() in face_line:
                    raise ValueError(f"a surface of this name is already{_where(face_line[name.lower()])}")
            except InputRejected:
                raise
            except ValueError as e:
                skipped.append({"line": line, "object": f"{cls} {name!r}", "reason": str(e)})
                continue
            if detailed and clockwise:  # idf_rectangles builds the rectangles counter-clockwise already
                points = points[::-1]
            if not _space_name(cls, fields):
                remainder_floor[zone_key] = remainder_floor.get(zone_key, 0.0) + (
                    _area(points) if _is_floor(cls, fields) else 0.0)
            faces.append({"id": name, "loops": [points], "zones": [zone_names.get(zone_key, zone)]})
            face_line[name.lower()] = line
            surface_zone[name.lower()] = zone_key
            twin = _twin(cls, fields)
            if twin:
                partners[name.lower()] = (twin, line)
        elif cls == "fenestrationsurface:detailed" or cls in SIMPLE_SUBSURFACES:
            windows.append((cls, fields, lines, line))
    by_name = {f["id"].lower(): f["id"] for f in faces}
    loops = {f["id"].lower(): f["loops"][0] for f in faces}
    warnings.extend(w.model_dump() for w in twins_apart(partners, loops, by_name))
    subsurface_copies: dict[str, int] = {}
    for cls, fields, lines, line in windows:
        name = fields[0] if fields else ""
        label = f"{cls} {name!r}"
        host = 3 if cls == "fenestrationsurface:detailed" else 2
        try:
            if not name:
                raise ValueError("no name")
            if len(fields) <= host or fields[host].lower() not in by_name:
                raise ValueError(f"its building surface {fields[host] if len(fields) > host else ''!r} is not a "
                                 "surface read from this file")
            if cls in SIMPLE_SUBSURFACES:  # placed on its host, already in world coordinates
                points = subsurface(cls, fields, loops[fields[host].lower()])
                multiplier_at = simple_multiplier_index(fields)
            else:
                n_index = _fenestration_layout(fields)
                multiplier_at = n_index - 1
                points = _vertices(fields, lines, n_index)
                zone_key = surface_zone[fields[host].lower()]
                if relative and zone_key in zones:
                    _refuse_unreadable_origin(zone_key, unreadable_origin, zone_names, zone_line, line)
                    points = _placed(_to_world(points, zones[zone_key]), zone_names[zone_key], zone_line[zone_key])
                if clockwise:
                    points = points[::-1]
            if name.lower() in face_line:
                raise ValueError(f"a surface of this name is already{_where(face_line[name.lower()])}")
        except InputRejected:
            raise
        except ValueError as e:
            skipped.append({"line": line, "object": label, "reason": str(e)})
            continue
        faces.append({"id": name, "loops": [points], "parent": by_name[fields[host].lower()]})
        face_line[name.lower()] = line
        # a multiplier EnergyPlus refuses refuses the file (the window read once would be a wrong net area)
        copies = subsurface_multiplier(cls, fields, lines, line, multiplier_at)
        if copies > 1:
            subsurface_copies[name] = copies
    if not any("parent" not in f for f in faces):
        first = skipped[0] if skipped else None
        where = (("file", "line", first["line"]) if first["line"] else ("file", first["object"])) if first else \
            ("file",)
        reason = (f"no usable surface: {first['object']}{_where(first['line'])}: {first['reason']}" if first else
                  "no BuildingSurface:Detailed, Wall:Detailed, RoofCeiling:Detailed, Floor:Detailed or simple-geometry "
                  "surface (Wall:Exterior, Roof, Floor:GroundContact, …)")
        raise reject(reason, where)
    used_zones = {z.lower() for f in faces for z in f.get("zones", [])}
    # a Zone's own statement stands over its spaces' sum
    for zone_key, claim in space_claims(objects, remainder_floor).items():
        if zone_key in zone_names:
            name = zone_names[zone_key]
            declared[name] = {**claim, **declared.get(name, {})}
    rules = any(cls == "globalgeometryrules" for cls, *_ in objects)
    warnings.extend(_origins_ignored(zones, zone_names, zone_line, world_zones & used_zones, rules))
    warnings.extend(_zones_not_defined([undefined[k] for k in sorted(undefined, key=lambda k: undefined[k][1] or 0)
                                        if k in used_zones]))
    warnings.extend(_zones_without_surfaces([(zone_names[k], zone_line[k]) for k in zone_names if k not in used_zones],
                                            len(used_zones)))
    multiplied = {k: m for k, m in zone_multipliers(objects, zone_names).items() if k in used_zones}
    multipliers = {zone_names[k]: m for k, m in multiplied.items()}
    warnings.extend(w.model_dump() for w in zone_list_strays(objects, zone_names))
    outside = sorted(zone_names[k] for k in zones_outside_total_floor_area(objects) if k in used_zones)
    return {"units": "m", "faces": faces, **({"zone_multipliers": multipliers} if multipliers else {}),
            **({"zones_outside_total_floor_area": outside} if outside else {}),
            **({"subsurface_multipliers": subsurface_copies} if subsurface_copies else {}),
            "source": {"format": fmt, "faces": len(faces), "zones": len({z for f in faces for z in f.get("zones", [])}),
                       "units": stated("m", 1.0, "format", "EnergyPlus lengths are always metres"),
                       "vertex_entry": "clockwise" if clockwise else "counterclockwise",
                       "coordinates": "relative" if relative else "world",
                       "declared": {zone_names.get(k.lower(), k): v for k, v in declared.items()
                                    if k.lower() in used_zones},
                       "skipped": skipped[:MAX_SKIPPED_LISTED],
                       "skipped_count": len(skipped),
                       **({"multiplied_zone_lines": {zone_names[k]: zone_line[k] for k in multiplied}}
                          if multiplied else {}), "warnings": warnings}}


def _zones_not_defined(undefined: list[tuple[str, int]]) -> list[Diagnostic]:
    """Surfaces written relative to a zone that no ``Zone`` object defines: EnergyPlus refuses them, and where their
    zone's origin and north are is unknown; they are read as if both were 0, so a zone at x = 5 m lands on its
    neighbour, its shared walls lost."""
    if not undefined:
        return []
    listed = ", ".join(f"{name!r} (first surface line {line})" if line else repr(name) for name, line in undefined[:5])
    return [Diagnostic(code="zones_not_defined", message=(
        f"Surfaces are written relative to {len(undefined)} zone(s) no Zone object defines: {listed}"
        f"{' …' if len(undefined) > 5 else ''}. EnergyPlus refuses such surfaces; they were read as if the zone's "
        "origin and north axis were 0, which puts them elsewhere if the zone has an origin (add its Zone object)."),
        details={"zones": [name for name, _ in undefined[:100]], "lines": [line for _, line in undefined[:100]]})]


def _zones_without_surfaces(bare: list[tuple[str, int]], measured: int) -> list[Diagnostic]:
    """``Zone`` objects no surface read names (their surfaces lost from a cut or edited file, or skipped): they are in
    no result, so the totals, which looked whole, are those of the other zones only."""
    if not bare:
        return []
    listed = ", ".join(f"{name!r}{_where(line)}" for name, line in bare[:5])
    return [Diagnostic(code="zones_without_surfaces", message=(
        f"{len(bare)} Zone object(s) have no surface read from the file: {listed}{' …' if len(bare) > 5 else ''}. "
        f"They are in no result: total_volume and total_floor_area are those of the {measured} zone(s) with "
        "surfaces only (a file cut or edited after its zones, or their surfaces skipped: see skipped_lines)."),
        details={"zones": [name for name, _ in bare[:100]], "lines": [line for _, line in bare[:100]],
                 "count": len(bare), "zones_measured": measured})]


def _origins_ignored(zones: dict[str, tuple[float, float, float, float]], names: dict[str, str],
                     lines: dict[str, int], world_zones: set[str], rules: bool = True) -> list[Diagnostic]:
    """EnergyPlus' warning for a World coordinate system over zones with an origin or a north axis: both are ignored,
    so surfaces written relative to their zone (the rule switched without the coordinates) pile up at the origin.
    ``rules`` False: the file has no GlobalGeometryRules (an excerpt; EnergyPlus requires the object), and World is
    what the reader assumed, which the warning says rather than blame a statement the file does not make."""
    moved = sorted((k for k in world_zones if any(zones.get(k, (0.0,) * 4))), key=lambda k: lines[k])
    if not moved:
        return []
    listed = ", ".join(f"{names[k]!r} (line {lines[k]})" for k in moved[:5]) + (" …" if len(moved) > 5 else "")
    said = ("GlobalGeometryRules says World coordinates, so the origin and north axis of {n} zone(s) are ignored, as "
            "EnergyPlus ignores them" if rules else "This IDF has no GlobalGeometryRules (EnergyPlus requires one): "
            "its coordinates were read as World, so the origin and north axis of {n} zone(s) are ignored")
    return [Diagnostic(code="zone_origins_ignored", message=(
        f"{said.format(n=len(moved))}: {listed}. If their surfaces are written relative to the zone, the zones are "
        "misplaced (their adjacencies lost): say Relative" + ("." if rules else " in a GlobalGeometryRules object.")),
        details={"zones": [names[k] for k in moved[:100]], "lines": [lines[k] for k in moved[:100]],
                 "global_geometry_rules": rules})]


def _refuse_unreadable_origin(zone_key: str, unreadable: dict[str, str], names: dict[str, str], lines: dict[str, int],
                              surface_line: int | None) -> None:
    """A 422 naming the Zone's line when a surface is placed relative to a zone whose origin or north is no number:
    EnergyPlus refuses such a Zone, and read as 0 it put the zone on its neighbour (its shared walls lost, no word
    but a skipped-list entry)."""
    if zone_key not in unreadable:
        return
    at = lines.get(zone_key)
    raise reject(f"Zone {names[zone_key]!r}{_where(at)} {unreadable[zone_key]}; the surface{_where(surface_line)} is "
                 "placed relative to that zone, so where it is cannot be known (EnergyPlus refuses such a Zone)",
                 ("file", "line", at) if at else ("file", "Zone", names[zone_key]))


def _placed(points: list[list[float]], zone: str, line: int | None) -> list[list[float]]:
    """``points`` moved to their zone's origin, refused (the object skipped, naming the Zone) where the origin puts them
    beyond the schema's bound."""
    if any(abs(x) > MAX_COORDINATE for p in points for x in p):
        raise ValueError(f"its Zone {zone!r}{_where(line)} origin puts it beyond ±{MAX_COORDINATE:g} m")
    return points


def _to_world(points: list[list[float]], zone: tuple[float, float, float, float]) -> list[list[float]]:
    """Relative coordinates: rotate by the zone's relative north (clockwise, as a compass bearing) and
    move to its origin, as EnergyPlus does."""
    north, x0, y0, z0 = zone
    angle = -math.radians(north)
    c, s = math.cos(angle), math.sin(angle)
    return [[x * c - y * s + x0, x * s + y * c + y0, z + z0] for x, y, z in points]


def parse_epjson(text: str) -> dict:
    objects, skipped = epjson_objects(text)
    if not objects and not skipped:
        raise reject("no EnergyPlus surface object (BuildingSurface:Detailed, Wall:Exterior, …) in this epJSON file")
    return surfaces_from_objects(objects, skipped, [], "epjson")


def parse_obj(text: str) -> dict:
    vertices: list[list[float]] = []
    faces: list[dict] = []
    skipped: list[dict] = []
    group = None
    obj_name = None
    pending = ""
    pending_line = 0
    for number, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].rstrip()
        if line.endswith("\\"):
            pending, pending_line = pending + line[:-1] + " ", pending_line or number
            continue
        line, at = pending + line, pending_line or number
        pending, pending_line = "", 0
        parts = line.split()
        if not parts:
            continue
        key = parts[0]
        if key == "v":
            try:
                if len(parts) < 4:
                    raise ValueError(f"{len(parts) - 1} coordinates")
                vertices.append([_coordinate(p) for p in parts[1:4]])
            except ValueError as e:
                # keep the numbering of later vertices: a placeholder that no usable face may use
                vertices.append([math.nan] * 3)
                comma = next((p for p in parts[1:4] if is_decimal_comma(p)), None)
                reason = (f"{comma!r} is a decimal comma; OBJ numbers take a decimal point" if comma is not None
                          else str(e))
                skipped.append({"line": at, "object": "v", "reason": f"not a vertex: {reason}"})
        elif key == "g":
            group = " ".join(parts[1:]) or None
        elif key == "o":
            obj_name = " ".join(parts[1:]) or None
        elif key == "f":
            try:
                loop = []
                for token in parts[1:]:
                    ref = int(token.split("/")[0])
                    index = ref - 1 if ref > 0 else len(vertices) + ref
                    if ref == 0 or not 0 <= index < len(vertices):
                        raise ValueError(f"vertex {ref} does not exist ({len(vertices)} vertices so far)")
                    if not math.isfinite(vertices[index][0]):
                        raise ValueError(f"vertex {ref} could not be read")
                    loop.append(index)
                if len(set(loop)) < 3:
                    raise ValueError(f"{len(set(loop))} distinct vertices; a face needs at least 3")
            except ValueError as e:
                skipped.append({"line": at, "object": "f", "reason": str(e)})
                continue
            faces.append({"id": f"f{len(faces) + 1}", "loops": [loop], "zones": [(obj_name, group)]})
    warnings: list[dict] = _obj_zones(faces, vertices)
    last = len(text.splitlines())
    if ends_mid_line(text) and skipped and skipped[-1]["line"] == last:
        warnings.append(truncated_file(last, f"its last line has no line ending and could not be read "
                                       f"({skipped[-1]['reason']}): the file was cut?").model_dump())
    elif ends_mid_line(text):  # read as written, but a face cut to three of its corners reads too
        warnings.append(truncated_file(last, "its last line has no line ending (the file was cut?): it was read as "
                                       "written, and whatever the file held after it is missing.").model_dump())
    if not faces:
        first = skipped[0] if skipped else None
        if first:
            raise reject(f"no usable face: line {first['line']}: {first['reason']}", ("file", "line", first["line"]))
        raise reject("no face ('f' line) in this OBJ file")
    used = sorted({v for f in faces for v in f["loops"][0]})
    remap = {old: new for new, old in enumerate(used)}
    for f in faces:
        f["loops"] = [[remap[v] for v in f["loops"][0]]]
    source = {"format": "obj", "faces": len(faces), "zones": len({f["zones"][0] for f in faces}),
              "skipped": skipped[:MAX_SKIPPED_LISTED], "skipped_count": len(skipped), "warnings": warnings}
    kept = [vertices[v] for v in used]
    said, unread = header_unit(text)
    warnings.extend(w.model_dump() for w in unread)
    if said is not None:  # converted to metres here, as the formats that state their unit are
        kept = [[c * said.metres for c in p] for p in kept]
        source["units"] = stated(said.name, said.metres, "header",
                                 f"the OBJ header's comment on line {said.line}: {said.comment!r}")
    return {"units": "m", "vertices": kept, "faces": faces, "source": source}


def _obj_zones(faces: list[dict], vertices: list[list[float]]) -> list[dict]:
    """Each face's zone from its (``o``, ``g``) names, in place; a warning when the file has both and they cut it
    differently. The cut under which more zones close is taken: Blender writes an object per room and, with material
    groups, ``g`` within it per material (zones by ``g`` are open pieces of rooms); Rhino writes an object per
    surface and ``g`` per layer, SketchUp and Revit a group per room (zones by ``o`` are open pieces). Where both
    close as many, the groups are (as before this choice was made: what OBJ readers zone by)."""
    pairs = [f["zones"][0] for f in faces]
    by_group = [(g or o) or "default" for o, g in pairs]
    by_object = [(o or g) or "default" for o, g in pairs]
    objects, groups = {o for o, _ in pairs if o}, {g for _, g in pairs if g}
    same = len(set(by_group)) == len(set(by_object)) == len(set(zip(by_group, by_object, strict=True)))
    closed = {"g": 0, "o": 0}
    if not same:
        edges, lengths = _edges(faces, vertices)
        closed = {"g": _closed_zones(edges, lengths, by_group), "o": _closed_zones(edges, lengths, by_object)}
    chosen = "o" if closed["o"] > closed["g"] else "g"  # ties keep the groups, as OBJ readers zone by 'g'
    for f, zone in zip(faces, by_object if chosen == "o" else by_group, strict=True):
        f["zones"] = [zone]
    if same:
        return []
    unused = "g" if chosen == "o" else "o"
    counts = {"o": len(set(by_object)), "g": len(set(by_group))}
    return [Diagnostic(code="obj_zones_chosen", message=(
        f"This OBJ names {len(objects)} object(s) ('o') and {len(groups)} group(s) ('g'), which cut its faces "
        f"differently: the {counts[chosen]} zone(s) are its '{chosen}' names, of which {closed[chosen]} close; by "
        f"'{unused}' there would be {counts[unused]}, of which {closed[unused]} close. Rename them in the file if the "
        "other cut is meant."),
        details={"zones_by": chosen, "zones": counts[chosen], "closed": closed[chosen], "objects": len(objects),
                 "groups": len(groups), f"closed_by_{unused}": closed[unused]}).model_dump()]


def _edges(faces: list[dict], vertices: list[list[float]]) -> tuple[np.ndarray, np.ndarray]:
    """Each face side as one number (its two corners matched by coordinates, as SketchUp writes each face's corners
    apart, in either order), and the number of sides of each face."""
    points = np.asarray(vertices, dtype=float).reshape(-1, 3)
    # corners a modeller wrote with round-off apart (1e-9 m) are one corner, as the solver's merge tolerance makes them
    step = 1e-7 * max(float(np.ptp(points, axis=0).max()) if len(points) else 0.0, 1e-300)
    _, corner = np.unique(np.round(points / step), axis=0, return_inverse=True)
    corner = corner.reshape(-1).astype(np.int64)
    loops = [f["loops"][0] for f in faces]
    lengths = np.fromiter((len(loop) for loop in loops), dtype=np.int64, count=len(loops))
    first = corner[np.fromiter((v for loop in loops for v in loop), dtype=np.int64, count=int(lengths.sum()))]
    following = np.arange(1, len(first) + 1)  # each corner's next in its loop, the last's the loop's first
    ends = np.cumsum(lengths)
    following[ends - 1] = ends - lengths
    second = first[following]
    return np.minimum(first, second) * (int(corner.max()) + 1) + np.maximum(first, second), lengths


def _closed_zones(edges: np.ndarray, lengths: np.ndarray, zone_of: list[str]) -> int:
    """How many zones of the cut ``zone_of`` (each face's zone) close: every side borne by an even number of the
    zone's faces (``edges``, ``lengths``: :func:`_edges`)."""
    names = {name: k for k, name in enumerate(dict.fromkeys(zone_of))}
    zone = np.repeat(np.fromiter((names[z] for z in zone_of), dtype=np.int64, count=len(zone_of)), lengths)
    order = np.lexsort((edges, zone))
    zone, edge = zone[order], edges[order]
    starts = np.flatnonzero(np.r_[True, (zone[1:] != zone[:-1]) | (edge[1:] != edge[:-1])])
    counts = np.diff(np.r_[starts, len(edge)])
    return len(names) - len(np.unique(zone[starts[counts % 2 == 1]]))


def parse_stl(content: bytes) -> dict:
    """One zone of triangles (a binary file read by :mod:`.stl_binary`, an ASCII one by trimesh; vertices stay
    unwelded, the solver merges them)."""
    content = _without_utf8_mark(_ascii_stl_from_utf16(content))
    head = content[:1024].lstrip().lower()
    ascii_like = head.startswith(b"solid") and b"facet" in content[:4096].lower()
    declared = struct.unpack("<I", content[80:84])[0] if len(content) >= 84 else 0
    binary_like = len(content) >= 84 and 84 + 50 * declared == len(content)
    warnings: list[dict] = []
    cut_binary = False
    if ascii_like and not content.rstrip().lower().rsplit(b"\n", 1)[-1].lstrip().startswith(b"endsolid"):
        # cut before 'endsolid': the whole facets up to the last 'endfacet' are read, the cut one is not
        end = content.lower().rfind(b"endfacet")
        if end < 0:
            raise reject("the ASCII STL file ends before its first facet is complete (no 'endfacet'): the file "
                         "was cut")
        end += len(b"endfacet")
        line = content.count(b"\n", 0, end) + 2
        content = content[:end] + b"\nendsolid\n"
        warnings.append(truncated_file(line, "the ASCII STL has no 'endsolid' (the file was cut?); the facet cut "
                                       "there was not read.").model_dump())
    elif not ascii_like and not binary_like and _is_text(content[84:4096]):
        # text under an .stl name (an OBJ, a CSV) read as a binary STL cut short: its characters as garbage floats
        raise reject(f"{NOT_STL}: it is text, and not an ASCII STL ('solid … facet … endsolid')")
    elif not ascii_like and not binary_like and _another_format(content):
        # a PLY, a STEP or IFC model, a zip under an .stl name: read as a binary STL cut short, garbage floats
        raise reject(f"{NOT_STL}: its first bytes are another format's")
    elif not ascii_like and 84 < len(content) < 84 + 50 * declared:
        whole = (len(content) - 84) // 50  # a binary file cut short: its whole triangles are read
        if whole == 0:
            raise reject(f"the binary STL file says {declared} triangles but ends before the first is complete: "
                         "the file was cut")
        warnings.append(Diagnostic(code="truncated_file", message=(
            f"The binary STL says {declared} triangles but holds {whole} whole ones (the file was cut?); those were "
            "read."), details={"declared": declared, "read": whole, "bytes": len(content)}).model_dump())
        content = content[:80] + struct.pack("<I", whole) + content[84:84 + 50 * whole]
        binary_like = cut_binary = True
    if not (ascii_like or binary_like):
        raise reject(f"{NOT_STL} (neither ASCII 'solid … facet' nor a binary STL whose size matches its "
                     "triangle count)")
    if ascii_like:
        _refuse_unreadable_numbers(content, only_commas=True)
    try:
        loaded = _read_stl(content)
        solid_names: list[str] = []
        solid_of = None
        if not {"vertices", "faces"} <= set(loaded):  # several solids (an ASCII file's rooms): one zone each
            loaded, solid_names, solid_of = _joined_solids(loaded.get("geometry") or {})
    except Exception as e:  # trimesh raises many kinds for a broken file
        if ascii_like:
            _refuse_unreadable_numbers(content, only_commas=False)
        raise reject(f"unreadable STL: {type(e).__name__}: {e}") from None
    with np.errstate(invalid="ignore", over="ignore"):  # a broken file's garbage floats are sorted out below
        vertices = np.asarray(loaded["vertices"] if loaded.get("vertices") is not None else np.zeros((0, 3)),
                              dtype=float)
    triangles = np.asarray(loaded["faces"] if loaded.get("faces") is not None else np.zeros((0, 3)), dtype=np.int64)
    vertices, triangles = vertices.reshape(-1, 3), triangles.reshape(-1, 3)
    if len(triangles) == 0:
        raise reject("the STL file holds no triangle")
    # NaN, infinity and a coordinate past the schema's bound (a float the writer never meant) fail alike
    finite = (np.abs(vertices) <= MAX_COORDINATE).all(axis=1)
    good = finite[triangles].all(axis=1)
    # a corner repeated by index or by its coordinates (exporters write such zero-area facets; the reader keeps every
    # facet's corners apart, so only the coordinates tell): no area, and its loop would collapse in the solver
    for i, j in ((0, 1), (1, 2), (0, 2)):
        good &= (triangles[:, i] != triangles[:, j]) & (vertices[triangles[:, i]] != vertices[triangles[:, j]]).any(axis=1)
    skipped = [{"object": f"facet {int(k) + 1}", "reason": f"non-finite, beyond {MAX_COORDINATE:g} or repeated vertex"}
               for k in np.flatnonzero(~good)[:MAX_SKIPPED_LISTED]]
    if not good.all():
        triangles = triangles[good]
        solid_of = solid_of[good] if solid_of is not None else None
    if len(triangles) == 0:
        raise reject(f"no usable triangle in the STL file (non-finite, beyond {MAX_COORDINATE:g} or repeated vertices)")
    if cut_binary:
        refuse_noise_stl(declared, len(good), int((~good).sum()),
                         f"non-finite coordinates, coordinates beyond {MAX_COORDINATE:g} or repeated corners")
    # an ASCII file names its solid; a binary header is free text, often an exporter's banner
    name = (str((loaded.get("metadata") or {}).get("name") or "").strip() if ascii_like else "") or "default"
    if solid_of is not None and len(set(solid_of.tolist())) > 1 and _each_closed(vertices, triangles, solid_of):
        # one zone per solid, as faces (a mesh is one zone): joined, two rooms were one zone named after the last.
        # Only where each solid is closed on its own: CAD tools also write one room as a solid per wall or group
        faces = [{"id": f"{solid_names[z]} t{k + 1}", "loops": [t], "zones": [solid_names[z]]}
                 for k, (t, z) in enumerate(zip(triangles.tolist(), solid_of.tolist(), strict=True))]
        return {"units": "m", "vertices": vertices.tolist(), "faces": faces,
                "source": {"format": "stl", "faces": len(faces), "zones": len(set(solid_of.tolist())),
                           "solids": solid_names, "skipped": skipped, "skipped_count": int((~good).sum()),
                           "warnings": warnings}}
    # the triangles as two arrays (faces t1, t2, …): a face object per triangle would cost a million of them
    used = np.zeros(len(vertices), dtype=bool)
    used[triangles] = True
    if not used.all():  # the vertices of skipped facets: not part of the zone
        renumber = np.cumsum(used) - 1
        vertices, triangles = vertices[used], renumber[triangles]
    return {"units": "m", "mesh": {"zone": name, "vertices": vertices, "triangles": triangles, "id_prefix": "t"},
            "source": {"format": "stl", "faces": len(triangles), "zones": 1, "skipped": skipped,
                       "skipped_count": int((~good).sum()), "warnings": warnings}}


def _another_format(content: bytes) -> bool:
    """Whether the file is of a format :func:`file_holds` knows by a signature no binary STL has. Its 80-byte header
    is free text ('plywood shelf', '{part 7}', '<Part1>'), so a header's first word is not enough: a zip's magic
    bytes, a PLY's 'ply' line followed by its 'format' line, or a STEP, XML or JSON start followed by text, where a
    binary STL's triangles hold NULs (their 2-byte attribute, 0 in nearly every file)."""
    holds = file_holds(content[:65536]) or ""
    if holds.startswith("a zip"):
        return True
    if holds.startswith("a PLY"):
        return re.match(rb"ply\r?\nformat ", content.lstrip(b"\xef\xbb\xbf \r\n\t")) is not None
    return holds.startswith(("an IFC", "a STEP", "a gbXML", "an XML", "a JSON")) and b"\x00" not in content[84:4096]


def _read_stl(content: bytes) -> dict:
    """The reader's arrays as they are (a Trimesh object would hash them: a second of a million triangles). A file
    whose size matches its triangle count is binary, whatever its first bytes, as trimesh's reader tries it first."""
    if is_binary_stl(content):
        if len(content) == HEADER_BYTES:  # no triangle: as trimesh's reader, no geometry
            return {"geometry": {}}
        vertices, triangles = binary_stl_arrays(content)
        return {"vertices": vertices, "faces": triangles}
    import trimesh.exchange.stl  # noqa: PLC0415  (an ASCII file only: importing trimesh costs half a second)

    return trimesh.exchange.stl.load_stl_ascii(io.BytesIO(content))


def _refuse_unreadable_numbers(content: bytes, only_commas: bool) -> None:
    """Refuse an ASCII STL naming its first 'vertex' or 'facet normal' line written with a decimal comma (its reader
    said only 'ValueError', with no line), or, unless ``only_commas``, the first whose numbers do not read. The
    commas are looked for by one regular-expression search, and only in a file holding a comma."""
    found = _comma_line(content)
    if found is None and not only_commas:
        found = next((m for m in STL_NUMBERS.finditer(content) if not _all_numbers(_stl_numbers(m))), None)
    if found is None:
        return
    line = content.count(b"\n", 0, found.start()) + 1
    comma = next((w for w in _stl_numbers(found) if is_decimal_comma(w)), None)
    why = (f"{comma!r} is a decimal comma; STL numbers take a decimal point (export with a point)" if comma is not None
           else "not three numbers")
    raise reject(f"line {line}: {' '.join(found.group(0).decode('ascii', 'replace').split())[:80]!r}: {why}",
                 ("file", "line", line))


def _comma_line(content: bytes) -> re.Match | None:
    """The first number line written with a decimal comma, looked for only in the lines that hold a comma (a clean
    file holds none, or a few in its solids' names: a search through every line costs a third of the parse)."""
    comma = content.find(b",")
    while comma >= 0:
        start = content.rfind(b"\n", 0, comma) + 1
        end = content.find(b"\n", comma)
        end = len(content) if end < 0 else end
        found = STL_COMMA_LINE.match(content, start, end)
        if found:
            return found
        comma = content.find(b",", end)
    return None


def _stl_numbers(found: re.Match) -> list[str]:
    """The words after 'vertex' or 'facet normal' of a line STL_NUMBERS matched."""
    words = found.group(0).decode("ascii", "replace").split()
    return words[2:] if words[0].lower() == "facet" else words[1:]


def _all_numbers(words: list[str]) -> bool:
    try:
        return len([float(w) for w in words]) == 3
    except ValueError:
        return False


def _each_closed(vertices: np.ndarray, triangles: np.ndarray, solid_of: np.ndarray) -> bool:
    """Whether every solid's triangles close on their own: each edge, its corners matched by coordinates (the reader
    keeps every facet's corners apart), borne by an even number of its triangles."""
    _, point = np.unique(vertices, axis=0, return_inverse=True)
    corners = point.reshape(-1)[triangles]
    edges = np.sort(np.concatenate([corners[:, [0, 1]], corners[:, [1, 2]], corners[:, [2, 0]]]), axis=1)
    owner = np.concatenate([solid_of] * 3)
    _, counts = np.unique(np.column_stack([owner, edges]), axis=0, return_counts=True)
    return bool(np.all(counts % 2 == 0))


def _joined_solids(geometry: dict) -> tuple[dict, list[str], np.ndarray]:
    """The solids of an ASCII STL (trimesh's ``geometry``: name → arrays) as one vertex and triangle array, the
    solids' names (a repeated or blank name made unique, as zones must be) and each triangle's solid."""
    names, vertices, triangles, solid_of, offset = [], [], [], [], 0
    for k, (key, part) in enumerate(geometry.items()):
        name = str((part.get("metadata") or {}).get("name") or key or "").strip() or f"solid {k + 1}"
        names.append(name if name not in names else f"{name} ({k + 1})")
        with np.errstate(invalid="ignore", over="ignore"):
            points = np.asarray(part["vertices"], dtype=float).reshape(-1, 3)
        corners = np.asarray(part["faces"], dtype=np.int64).reshape(-1, 3)
        vertices.append(points)
        triangles.append(corners + offset)
        solid_of.append(np.full(len(corners), k))
        offset += len(points)
    if not triangles:
        return {}, [], np.zeros(0, dtype=np.int64)
    return ({"vertices": np.concatenate(vertices), "faces": np.concatenate(triangles)}, names,
            np.concatenate(solid_of))


def _is_text(sample: bytes) -> bool:
    """Printable ASCII and line breaks only: no binary STL's triangles (float32 normals and corners hold NULs and high
    bytes within a few facets)."""
    return bool(sample) and not sample.translate(None, bytes(range(32, 127)) + b"\t\r\n")


def _without_utf8_mark(content: bytes) -> bytes:
    """An ASCII STL saved by an editor that writes UTF-8 with a byte-order mark, without the mark: before it the file
    did not start with 'solid' and was refused as text that is no STL. A binary STL's 80-byte header may start with
    any bytes, so the mark goes only when an ASCII STL follows."""
    binary = len(content) >= 84 and 84 + 50 * struct.unpack("<I", content[80:84])[0] == len(content)
    if content.startswith(b"\xef\xbb\xbf") and content[3:1027].lstrip().lower().startswith(b"solid") and not binary:
        return content[3:]
    return content


def _ascii_stl_from_utf16(content: bytes) -> bytes:
    """An ASCII STL saved as UTF-16 (a Windows editor), as its ASCII bytes; other content as it is. Read as bytes it
    passed for a binary STL cut short, of denormal floats that collapsed to nothing."""
    text = None
    if content[:2] in (b"\xff\xfe", b"\xfe\xff"):
        try:
            text = content.decode("utf-16")
        except UnicodeDecodeError:
            return content
    elif b"\x00" in content[:4096] and utf16_without_mark(content[:4096]) is not None:  # a binary STL fails here
        text = utf16_without_mark(content)
    if text is None or not text.lstrip().lower().startswith("solid"):
        return content
    return text.encode("utf-8", errors="replace")


def parse_json(text: str) -> dict:
    """A JSON request as a file; another kind's request or result is refused naming what it holds."""
    body = json_object(text, refuse_cut=True)
    if _is_epjson(body):  # an epJSON saved under .json: its geometry, not a refusal of its keys as request fields
        return parse_epjson(text)
    refuse_other_kind(body, "polyhedra")
    return body


def _is_epjson(body: dict) -> bool:
    """EnergyPlus object types as keys (``Zone``, ``BuildingSurface:Detailed``, …) and no request field."""
    return not set(body) & set(PolyhedraRequest.model_fields) and any(key.lower() in EPJSON_TYPES for key in body)


NOT_STL = "not an STL file"  # the STL reader's refusal of a file that is no STL at all
EXPECTED = {".idf": "an EnergyPlus IDF", ".epjson": "a JSON document", ".json": "a JSON document",
            ".xml": "a gbXML building model", ".gbxml": "a gbXML building model", ".ifc": "an IFC model",
            ".obj": "a Wavefront OBJ mesh", ".stl": "an STL mesh"}


def read_file(extension: str, content: bytes) -> dict:
    """The request body the extension's reader makes of ``content``."""
    if extension == ".stl":
        return parse_stl(content)
    if extension in (".xml", ".gbxml"):
        return parse_gbxml(content)
    if extension == ".ifc":
        return parse_ifc(content)
    text = decode_text(content)
    return {".idf": parse_idf, ".epjson": parse_epjson, ".obj": parse_obj}.get(extension, parse_json)(text)


def name_what_it_holds(refused: InputRejected, extension: str, content: bytes) -> InputRejected:
    """A reader's refusal, said to be about a file of another format when its start shows one (a CSV named
    .idf, a STEP CAD model named .ifc, an OBJ point cloud)."""
    holds = file_holds(content[:65536])
    if holds is None or holds.startswith(EXPECTED.get(extension, "?")) or extension == ".stl" and "STL" in holds:
        return refused
    first, *rest = refused.errors
    said = f"this file holds {holds}, not {EXPECTED[extension]} as its name says"
    # the STL reader's own 'not an STL file' says less than the format named: one sentence, not the two
    return InputRejected([replace(first, msg=said if first.msg.startswith(NOT_STL) else f"{said}: {first.msg}"),
                          *rest])


FORM = FormRules(PolyhedraRequest, units="result")


def parse_upload(source: StoredInput, options: dict | None) -> PolyhedraRequest:
    """An IDF, epJSON, gbXML, IFC, OBJ, STL or JSON file (intake checked the extension) as a request, with the upload
    form's ``options`` (``units``, ``merge_tolerance``, ``planarity_tolerance``, ``file_units`` …) joined to it by the
    rules of :mod:`plantsolve.solvers.upload_form`: the form's ``units`` is the result's, and the file's lengths are
    converted into it (:mod:`.file_units`)."""
    form = read_form(options, FORM)
    content = source.read()
    if not content.strip():
        raise reject("the file is empty")
    try:
        body = read_file(source.extension, content)
    except InputRejected as refused:
        raise name_what_it_holds(refused, source.extension, content) from None
    fmt = (body.get("source") or {}).get("format") if isinstance(body.get("source"), dict) else None
    file_units = form.read.file_units
    if fmt == "idf" and file_units is not None:
        body["source"]["warnings"] = followed(body["source"]["warnings"], file_units)
    body = reconcile(body, form.units, file_units, fmt or source.extension[1:])
    if fmt == "idf" and isinstance(body["source"].get("units"), dict):
        source_of = body["source"]
        source_of["warnings"] = tables_answered(source_of["warnings"], source_of["units"])
    # pydantic names a loop's branch (indices or points) in the path: no key of the file
    return validated_request(FORM, merged(body, form, FORM), form,
                             elsewhere=lambda e: replace(e, loc=("file", *_without_branch(e.loc))))


def _without_branch(loc: tuple) -> tuple:
    """``loc`` without the union branch pydantic puts after ``loops, <j>`` (a top-level key 'points' stays)."""
    out: list = []
    for part in loc:
        if part in LOOP_KINDS and len(out) >= 2 and out[-2] == "loops":
            continue
        out.append(part)
    return tuple(out)
